"""Progress of long runs: one mechanism (tqdm) for Monte Carlo, FE transients and sweeps.

Shown on an interactive terminal or in a Jupyter notebook (``tqdm.auto`` picks the
widget), after :data:`LINE_DELAY` seconds (2, or ``FPK_VIBRO_PROGRESS_DELAY``), on
stderr; ``progress=False`` (the CLI's ``--quiet``) or output that is not interactive
turns it off.  Within :func:`as_lines` (the worker processes of a sweep, whose bars
would overwrite each other on one terminal) a progress bar is one plain line instead,
printed once its work has run that long.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import time
from typing import Iterator

__all__ = ["Progress", "interactive", "as_lines", "LINE_DELAY"]

def _delay() -> float:
    """``FPK_VIBRO_PROGRESS_DELAY`` (seconds; default 2), or 2 if it is not a number
    >= 0."""
    try:
        value = float(os.environ.get("FPK_VIBRO_PROGRESS_DELAY", "2"))
    except ValueError:
        return 2.0
    return value if value >= 0.0 else 2.0


#: Seconds of work after which a bar or a progress line (:func:`as_lines`) is shown:
#: the environment variable ``FPK_VIBRO_PROGRESS_DELAY`` (0 shows every stage as it
#: starts; the fault tests wait for such a line), else 2.
LINE_DELAY = _delay()

_LINES: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "fpk_vibro_progress_lines", default=None)


@contextlib.contextmanager
def as_lines(prefix: str) -> Iterator[None]:
    """Within: every enabled :class:`Progress` prints one line on stderr,
    ``prefix + label + " ..."``, once its work has run :data:`LINE_DELAY` seconds,
    and no bar.

    Parameters
    ----------
    prefix : str
        What the line starts with (e.g. the sweep point it belongs to).
    """
    token = _LINES.set(prefix)
    try:
        yield
    finally:
        _LINES.reset(token)


def interactive() -> bool:
    """True on a terminal (stderr) or inside a Jupyter kernel."""
    return "ipykernel" in sys.modules or (hasattr(sys.stderr, "isatty") and sys.stderr.isatty())


class Progress:
    """A progress bar over a fraction (0 to 1) or a count (within :func:`as_lines`:
    one plain line).

    Parameters
    ----------
    enabled : bool or None
        None: only when :func:`interactive`.
    label : str
        What runs (the bar's description).
    total : float
        The full count (1.0: fractions).
    unit : str
    """

    def __init__(self, enabled: bool | None, label: str, total: float = 1.0,
                 unit: str = "") -> None:
        self.enabled = interactive() if enabled is None else bool(enabled)
        self.total = total
        self._bar = None
        self._line: str | None = None
        prefix = _LINES.get()
        if self.enabled and prefix is not None:       # a plain line (as_lines)
            self._line, self._t0 = prefix + label, time.monotonic()
        elif self.enabled:
            from tqdm.auto import tqdm
            fraction = total == 1.0
            self._bar = tqdm(total=100.0 if fraction else total, desc=label, delay=LINE_DELAY,
                             unit="%" if fraction else (unit or "it"), file=sys.stderr,
                             leave=False, dynamic_ncols=True,
                             bar_format=("{desc}: {percentage:3.0f}%|{bar}| "
                                         "[{elapsed}<{remaining}]{postfix}") if fraction
                             else None)
            self._scale = 100.0 if fraction else 1.0

    def update(self, done: float, extra: str = "") -> None:
        """Set the progress to ``done`` (a fraction, or a count of ``total``)."""
        if self._line is not None and time.monotonic() - self._t0 >= LINE_DELAY:
            print(f"{self._line} ...", file=sys.stderr, flush=True)
            self._line = None
        if self._bar is not None:
            self._bar.n = min(done * self._scale, self._bar.total)
            if extra:
                self._bar.set_postfix_str(extra, refresh=False)
            self._bar.refresh()

    def close(self, note: str = "") -> None:
        self._line = None
        if self._bar is not None:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.close()
            self._bar = None
