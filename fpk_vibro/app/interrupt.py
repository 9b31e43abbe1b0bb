"""SIGINT and SIGTERM as one exception, so that a run can stop cleanly on either.

Within :func:`signals_handled` both signals raise :class:`Interrupted` in the main
thread (SIGTERM otherwise kills the process without any cleanup).  The solvers
already stop on ``KeyboardInterrupt`` (a subclass) and return what they
finished; :func:`received` tells the runner which signal stopped them, and the
command line exits with 128 + its number (130 for SIGINT, 143 for SIGTERM).
"""
from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

__all__ = ["Interrupted", "signals_handled", "received", "worker_init"]

_received: list[int] = []


class Interrupted(KeyboardInterrupt):
    """A run stopped by a signal; ``signum`` says which."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def received() -> int | None:
    """The signal received within the current :func:`signals_handled`, if any."""
    return _received[-1] if _received else None


def _raise(signum: int, frame) -> None:
    _received.append(signum)
    raise Interrupted(signum)


@contextlib.contextmanager
def signals_handled() -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`Interrupted` (main thread only; else a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()
    old = {s: signal.signal(s, _raise) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _asked_to_stop(signum: int, frame) -> None:
    """A worker's SIGINT: its run asks it to stop.  From now on the run speaks for it
    (one line): the worker's own output goes to /dev/null."""
    import os
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
    finally:
        os.close(devnull)
    raise Interrupted(signum)


def worker_init(parent: int | None = None) -> None:
    """For worker processes (in a session of their own: a Ctrl-C at the terminal
    reaches the run alone): the run decides.  SIGINT is the run's request to stop:
    :class:`Interrupted` is raised in the point in progress, which keeps what it
    finished as in the run's own process (written as interrupted), and the worker
    is silent from then on; SIGTERM ends it at once.

    With ``parent`` (its pid) the worker also dies with it: ``PR_SET_PDEATHSIG``
    (SIGKILL) on Linux, and a thread that checks the parent pid every second
    elsewhere (or if the parent died before the call).
    """
    signal.signal(signal.SIGINT, _asked_to_stop)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    if parent is None:
        return
    import os
    import sys
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)          # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:          # it died before prctl
        os._exit(1)

    def watch() -> None:
        import time
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="fpk-vibro-parent-watch", daemon=True).start()
