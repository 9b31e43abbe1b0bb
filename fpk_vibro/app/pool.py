"""Local worker processes for a sweep (``fpk-vibro run --workers N``).

Each worker is a fresh interpreter (``python -c``, not a fork of the run):

* it inherits no file descriptor of the run, so never the output directory's lock
  (a fork would share the lock's open file and keep the directory "in use" after
  the run itself died);
* it lives in its own session, so a Ctrl-C at the terminal reaches the run alone,
  which then asks every worker to stop (SIGINT: the point in progress keeps what it
  finished and is written as interrupted, as in the run's own process; the worker
  says nothing) and ends any still there after :data:`GRACE` seconds (SIGKILL);
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
import time
from collections import deque
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterator

__all__ = ["run_jobs", "death_reason"]

_BOOT = "from fpk_vibro.app.pool import _serve; _serve()"
_SIGNALS = {signal.SIGINT, signal.SIGTERM}
#: Seconds the workers get, all together, to end after the request to stop (or after
#: their last point) before SIGKILL.
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
        """End the process: now (SIGINT: it stops its point, keeping what it finished,
        :func:`~fpk_vibro.app.interrupt.worker_init`) or after its current work (EOF)."""
        self.conn.close()
        if now and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)

    def reap(self, deadline: float | None = None) -> int | None:
        """Its exit status, waiting until ``deadline`` (monotonic; default
        :data:`GRACE` from now), then SIGKILL."""
        deadline = time.monotonic() + GRACE if deadline is None else deadline
        try:
            return self.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()


def _end(workers: list[_Worker], now: bool) -> None:
    """Stop every worker (:meth:`_Worker.stop`) and wait :data:`GRACE` seconds in all
    for them; a second signal meanwhile kills the rest at once."""
    for w in workers:
        w.stop(now)
    deadline = time.monotonic() + GRACE
    try:
        for w in workers:
            w.reap(deadline)
    except KeyboardInterrupt:
        for w in workers:
            w.reap(0.0)
        raise


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
        _end(workers, now=not done)


def _serve() -> None:
    """A worker: compute the jobs the run sends until it closes the socket or asks the
    worker to stop (SIGINT: :func:`~fpk_vibro.app.interrupt.worker_init`)."""
    from .interrupt import worker_init
    fd, parent = int(sys.argv[1]), int(sys.argv[2])
    conn = Connection(fd)
    try:
        worker_init(parent)
        while True:
            fn, job = conn.recv()
            try:
                reply = (True, fn(job))
            except BaseException as exc:   # re-raised by the run
                reply = (False, exc)
            try:
                conn.send(reply)
            except OSError:                # the run has gone (below)
                raise
            except Exception:              # not picklable
                exc = reply[1]
                conn.send((False, RuntimeError(" ".join(
                    f"{type(exc).__name__}: {exc}".split()))))
    except (KeyboardInterrupt, EOFError, OSError):   # asked to stop, or the run has gone
        return
