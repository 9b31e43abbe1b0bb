"""Where the points of a run are computed: in this process, in local worker processes
(:mod:`fpk_vibro.app.pool`) or on a Dask cluster (:mod:`fpk_vibro.app.scheduler`).

Every route yields each point's record as it finishes; a point whose worker died or
whose Dask task failed is a failed record, and a lost scheduler is
:class:`SchedulerLost` (the run keeps what finished).
"""
from __future__ import annotations

import contextlib
import os
import socket
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


def _on_dask(point_job: Callable[[tuple], dict[str, Any]], client: Any, jobs: list):
    """The jobs on Dask: a task that fails fails its point; a lost scheduler raises
    :class:`SchedulerLost` after every point reported so far."""
    from distributed import as_completed
    address = getattr(client, "fpk_address", "")
    futures = client.map(point_job, jobs, pure=False)
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
    except BaseException:
        if not lost:
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
