"""Where the points of a run are computed: in this process, in local worker processes
(:mod:`fpk_vibro.app.pool`) or on a Dask cluster (:mod:`fpk_vibro.app.scheduler`).

Every route yields each point's record as it finishes; a point whose worker died or
whose Dask task failed is a failed record, and a lost scheduler is
:class:`SchedulerLost` (the run keeps what finished).  A signal stops the points in
progress everywhere as in this process: each keeps what it finished (written as
interrupted), worker processes by a SIGINT of their own (:mod:`fpk_vibro.app.pool`),
Dask tasks, which cannot be signalled, by ``Interrupted`` raised in their thread
(:func:`_task`, :func:`_stop_tasks`).
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import socket
import threading
import time
from typing import Any, Callable

from .outdir import point_records

__all__ = ["SchedulerLost", "dask_client", "execute"]


class SchedulerLost(RuntimeError):
    """The Dask scheduler went away during the sweep."""


@contextlib.contextmanager
def dask_client(address: str | None):
    """A Dask client of ``address`` (None: no client), connected with every step
    bounded (:func:`fpk_vibro.app.scheduler.client`), closed at the end."""
    if address is None:
        yield None
        return
    from .scheduler import client as connect, quiet
    client = connect(address)
    client.fpk_address = address
    try:
        with quiet():
            yield client
    finally:
        with quiet():
            try:
                client.close(timeout=5)
            except Exception:          # a lost scheduler: nothing to close
                pass


def _died(job: tuple, reason: str) -> dict[str, Any]:
    """The record of a point whose worker died: what it wrote, or a failure that is
    not written to ``points/`` (so that ``--resume`` computes it again)."""
    index, params, out_dir = job[1], job[2], job[4]
    rec = point_records(out_dir).get(index)
    if rec is not None and rec.get("status") in ("done", "failed"):
        return rec
    return {"index": index, "parameters": params, "status": "failed",
            "error": f"{reason}; --resume computes it again"}


def execute(point_job: Callable[[tuple], dict[str, Any]], jobs: list, serial: bool,
            workers: int | None, client: Any = None):
    """Yield ``point_job(job)``, each job's record, as it finishes: in this process, in
    worker processes (:mod:`fpk_vibro.app.pool`) or on Dask (``client``).

    ``point_job`` must be importable: the workers and Dask take it by reference."""
    if not jobs:
        return
    if client is not None:
        yield from _on_dask(point_job, client, jobs)
        return
    if serial:
        for job in jobs:
            yield point_job(job)
        return
    from .pool import run_jobs
    yield from run_jobs(point_job, jobs, workers or os.cpu_count() or 1, _died)


#: On a Dask worker: the threads running a point, thread id → (the run's token, the
#: point's index); and the runs asked to stop (:func:`_stop_tasks`).
_RUNNING: dict[int, tuple[str, int] | None] = {}
_STOPPED: set[str] = set()
_LOCK = threading.Lock()


def _raise_in(thread: int, exc: type[BaseException] | None) -> int:
    """``exc`` raised in ``thread`` at its next Python instruction (None: a pending
    one dropped); the number of threads changed."""
    return ctypes.pythonapi.PyThreadState_SetAsyncExc(
        ctypes.c_ulong(thread), None if exc is None else ctypes.py_object(exc))


def _leave(me: int) -> None:
    with _LOCK:
        _RUNNING.pop(me, None)
        _raise_in(me, None)


def _task(job: tuple, point_job: Callable[[tuple], dict[str, Any]]) -> dict[str, Any]:
    """``point_job(job)`` as a Dask task that its run can stop (:func:`_stop_tasks`):
    stopped, the point keeps what it finished (``point_job`` writes it as
    interrupted) and the task returns that record.  The interruption never reaches
    Dask (a ``KeyboardInterrupt`` out of a task would close the worker)."""
    me, token, rec = threading.get_ident(), job[6], None
    try:
        try:
            with _LOCK:
                if token in _STOPPED:          # the run stopped before this task began
                    return {"index": job[1], "parameters": job[2], "status": "interrupted"}
                _RUNNING[me] = (token, job[1])
            rec = point_job(job)
        except KeyboardInterrupt:
            pass
    finally:
        while True:        # an interruption delivered only now is taken here, not by Dask
            try:
                _leave(me)
                break
            except KeyboardInterrupt:
                pass
    if rec is None:
        rec = point_records(job[4]).get(job[1]) or {
            "index": job[1], "parameters": job[2], "status": "interrupted"}
    return rec


def _stop_tasks(token: str) -> list[int]:
    """On a Dask worker (``client.run``): interrupt every thread running a point of the
    run ``token`` (each once), and start none of its points any more; their indices."""
    from .interrupt import Interrupted
    stopped = []
    with _LOCK:
        _STOPPED.add(token)
        for thread, held in list(_RUNNING.items()):
            if held is not None and held[0] == token:
                _RUNNING[thread] = None
                if _raise_in(thread, Interrupted):
                    stopped.append(held[1])
    return stopped


def _stop_on_dask(client: Any, futures: list, jobs: list) -> None:
    """After a signal: the run's tasks in progress stopped (:func:`_stop_tasks`), and
    :data:`~fpk_vibro.app.pool.GRACE` seconds at most to write what they finished;
    a second signal ends the wait."""
    from .pool import GRACE
    try:
        stopped = client.run(_stop_tasks, jobs[0][6], on_error="ignore")
        index = {job[1]: f for f, job in zip(futures, jobs)}
        mine = [index[i] for found in stopped.values() if isinstance(found, list)
                for i in found if i in index]
        deadline = time.monotonic() + GRACE
        while not all(f.done() for f in mine) and time.monotonic() < deadline:
            time.sleep(0.05)
    except (KeyboardInterrupt, Exception):   # a second signal, a lost scheduler: what
        pass                                 # is written is kept


def _on_dask(point_job: Callable[[tuple], dict[str, Any]], client: Any, jobs: list):
    """The jobs on Dask: a task that fails fails its point; a lost scheduler raises
    :class:`SchedulerLost` after every point reported so far; a signal stops the
    tasks in progress, which keep what they finished (:func:`_stop_on_dask`)."""
    from distributed import as_completed
    address = getattr(client, "fpk_address", "")
    futures = client.map(_task, jobs, point_job=point_job, pure=False)
    job_of = {f.key: job for f, job in zip(futures, jobs)}
    lost = False
    try:
        for fut in as_completed(futures, loop=client.loop):
            try:
                rec = fut.result()
            except (KeyboardInterrupt, GeneratorExit, SystemExit):
                raise
            except BaseException as exc:   # CancelledError is one (not an Exception)
                if "connection-lost" in str(getattr(exc, "reason", "")) or \
                        client.status not in ("running", "newly-created") or \
                        _scheduler_gone(exc, address, client):
                    lost = True
                    raise SchedulerLost(f"the Dask scheduler {address} was lost "
                                        "mid-sweep") from None
                job = job_of[fut.key]
                rec = {"index": job[1], "parameters": job[2], "status": "failed",
                       "error": "on Dask: " + " ".join(
                           f"{type(exc).__name__}: {exc}".split())[:500]}
            yield rec
    except BaseException as exc:
        if not lost:
            if isinstance(exc, KeyboardInterrupt):
                _stop_on_dask(client, futures, jobs)
            try:
                client.cancel(futures, force=True)
            except Exception:
                pass
        raise


def _scheduler_gone(exc: BaseException, address: str, client: Any = None,
                    patience: float = 5.0) -> bool:
    """Whether ``exc`` (fetching a result) is the scheduler's loss: a closed
    connection while nothing listens at ``address`` any more.  The client notices
    the loss itself only later, so a result fetched in between would otherwise be
    taken for a point's own failure; and a killed cluster's workers may drop their
    connections a moment before its scheduler stops listening, so a still-open
    address is asked again for up to ``patience`` seconds (measured: fresh-ci once
    saw the worker's 'Stream is closed' while the scheduler still answered)."""
    from distributed.comm import CommClosedError, parse_address, parse_host_port
    if not isinstance(exc, (CommClosedError, OSError)) or not address:
        return False
    try:
        host, port = parse_host_port(parse_address(address)[1])
    except Exception:      # an address the check cannot read: not proof of a loss
        return False
    deadline = time.monotonic() + patience
    while True:
        try:
            socket.create_connection((host, port), timeout=2.0).close()
        except OSError:
            return True
        if client is not None and client.status not in ("running", "newly-created"):
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.2)
    return False
