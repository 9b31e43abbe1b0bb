"""Local worker processes for a sweep (``fpk-vibro run --workers N``).

Each worker is a fresh interpreter (``python -c``, not a fork of the run):

* it inherits no file descriptor of the run, so never the output directory's lock
  (a fork would share the lock's open file and keep the directory "in use" after
  the run itself died);
* it lives in its own session, so a Ctrl-C at the terminal reaches the run alone,
  which then ends every worker (no worker prints a traceback of its own);
* it dies with the run (``PR_SET_PDEATHSIG`` on Linux, and a parent-pid watchdog).

The run hands one point at a time to each worker over a socket and knows which
point every worker holds: a worker that dies (``kill -9``, the out-of-memory
killer, a crash) fails that one point with the reason, a fresh worker takes the
remaining points.  There are never more workers than points.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from collections import deque
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterator

__all__ = ["run_jobs", "death_reason"]

_BOOT = "from fpk_vibro.app.pool import _serve; _serve()"
_SIGNALS = {signal.SIGINT, signal.SIGTERM}
#: Seconds a worker gets to end after SIGTERM (or after its last point) before SIGKILL.
GRACE = 5.0


def death_reason(returncode: int | None) -> str:
    """How a worker process ended, in words (``killed by SIGKILL …``, ``exit status 3``)."""
    if returncode is None:
        return "it stopped answering"
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        hint = " (the out-of-memory killer?)" if -returncode == signal.SIGKILL else ""
        return f"killed by {name}{hint}"
    return f"exit status {returncode}"


class _Worker:
    """One worker process and the run's end of its socket."""

    def __init__(self) -> None:
        ours, theirs = socket.socketpair()
        root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [root] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []))}
        # SIGINT/SIGTERM blocked while the process is created: a signal cannot leave a
        # half-started, untracked child behind (it is delivered right after)
        old = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", _BOOT, str(theirs.fileno()), str(os.getpid())],
                pass_fds=[theirs.fileno()], stdin=subprocess.DEVNULL, env=env,
                start_new_session=True)
        finally:
            theirs.close()
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        self.conn = Connection(ours.detach())
        self.job: Any = None

    def stop(self, now: bool) -> None:
        """End the process: at once (SIGTERM) or after its current work (EOF)."""
        self.conn.close()
        if now and self.proc.poll() is None:
            self.proc.terminate()

    def reap(self) -> int | None:
        try:
            return self.proc.wait(timeout=GRACE)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()


def run_jobs(fn: Callable[[Any], Any], jobs: list, n: int,
             died: Callable[[Any, str], Any]) -> Iterator[Any]:
    """Yield ``fn(job)`` for every job, computed by at most ``min(n, len(jobs))`` workers.

    ``fn`` must be importable (it is pickled by reference); an exception it raises
    is raised here.  A job whose worker dies yields ``died(job, reason)`` instead.
    Closing the generator (or an exception in it, e.g.
    :class:`~fpk_vibro.app.interrupt.Interrupted`) ends every worker at once.
    """
    n = max(1, min(n, len(jobs)))
    todo, idle = deque(jobs), []
    busy: dict[Connection, _Worker] = {}
    workers: list[_Worker] = []
    done = False
    try:
        while todo or busy:
            while todo and len(busy) < n:
                w = idle.pop() if idle else _Worker()
                if w not in workers:
                    workers.append(w)
                w.job = todo.popleft()
                busy[w.conn] = w
                try:
                    w.conn.send((fn, w.job))
                except OSError:        # dead already: found by wait() below
                    pass
            for conn in wait(list(busy)):
                w = busy.pop(conn)
                try:
                    ok, result = conn.recv()
                except (EOFError, OSError):
                    workers.remove(w)
                    w.stop(now=True)
                    result = died(w.job, f"its worker process died: {death_reason(w.reap())}")
                else:
                    idle.append(w)
                    if not ok:             # fn raised: so does the run, as a Pool would
                        raise result
                yield result
        done = True
    finally:
        for w in workers:
            w.stop(now=not done)
        for w in workers:
            w.reap()


def _serve() -> None:
    """A worker: compute the jobs the run sends until it closes the socket."""
    from .interrupt import worker_init
    fd, parent = int(sys.argv[1]), int(sys.argv[2])
    worker_init(parent)
    conn = Connection(fd)
    while True:
        try:
            fn, job = conn.recv()
        except (EOFError, OSError):
            return
        try:
            result = fn(job)
        except BaseException as exc:   # re-raised by the run
            try:
                conn.send((False, exc))
            except Exception:          # not picklable
                conn.send((False, RuntimeError(" ".join(
                    f"{type(exc).__name__}: {exc}".split()))))
            continue
        conn.send((True, result))
