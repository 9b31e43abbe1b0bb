"""Progress of long runs: one mechanism (tqdm) for Monte Carlo, FE transients and sweeps.

Shown on an interactive terminal or in a Jupyter notebook (``tqdm.auto`` picks the
widget), after two seconds, on stderr; ``progress=False`` (the CLI's ``--quiet``)
or output that is not interactive turns it off.
"""
from __future__ import annotations

import sys

__all__ = ["Progress", "interactive"]


def interactive() -> bool:
    """True on a terminal (stderr) or inside a Jupyter kernel."""
    return "ipykernel" in sys.modules or (hasattr(sys.stderr, "isatty") and sys.stderr.isatty())


class Progress:
    """A progress bar over a fraction (0 to 1) or a count.

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
        if self.enabled:
            from tqdm.auto import tqdm
            fraction = total == 1.0
            self._bar = tqdm(total=100.0 if fraction else total, desc=label, delay=2.0,
                             unit="%" if fraction else (unit or "it"), file=sys.stderr,
                             leave=False, dynamic_ncols=True,
                             bar_format=("{desc}: {percentage:3.0f}%|{bar}| "
                                         "[{elapsed}<{remaining}]{postfix}") if fraction
                             else None)
            self._scale = 100.0 if fraction else 1.0

    def update(self, done: float, extra: str = "") -> None:
        """Set the progress to ``done`` (a fraction, or a count of ``total``)."""
        if self._bar is not None:
            self._bar.n = min(done * self._scale, self._bar.total)
            if extra:
                self._bar.set_postfix_str(extra, refresh=False)
            self._bar.refresh()

    def close(self, note: str = "") -> None:
        if self._bar is not None:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.close()
            self._bar = None
