"""Thread pool of the Monte Carlo kernels: blocks of paths on all cores.

The compiled block functions release the GIL (``nogil``), so a
``concurrent.futures`` pool runs them in parallel.  A numba ``prange`` would do
the same, but a ``parallel=True`` wrapper made numba re-optimise the whole block
function inside the parfor (~7 s more of a cold-cache compile, measured).
"""
from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor, wait

import numba

__all__ = ["n_threads", "run_blocks"]

_POOL: dict[int, ThreadPoolExecutor] = {}
_POOL_LOCK = threading.Lock()


def _pool(n: int) -> ThreadPoolExecutor:
    with _POOL_LOCK:
        pool = _POOL.get(n)
        if pool is None:
            pool = _POOL[n] = ThreadPoolExecutor(max_workers=n,
                                                 thread_name_prefix="fpk-mc")
        return pool


def n_threads(threads: int | None = None) -> int:
    """The worker count: ``threads`` or :func:`numba.get_num_threads`."""
    return max(1, int(numba.get_num_threads() if threads is None else threads))


def run_blocks(fn, n_blocks: int, args: tuple, threads: int | None = None) -> list:
    """``[fn(b, *args) for b in range(n_blocks)]`` with the blocks shared out to
    ``threads`` workers (``fn`` compiled ``nogil``; blocks write disjoint data).

    Each block is computed by the same compiled code from its own random stream
    whatever the number of threads, so results are bit-identical.  Blocks are
    handed out one at a time (dynamic load balance).  On Ctrl-C no further block
    starts and the running ones are finished before the interrupt propagates, so
    every block's state stays consistent.
    """
    nt = min(n_threads(threads), n_blocks)
    if nt <= 1:
        return [fn(b, *args) for b in range(n_blocks)]
    futs = [_pool(nt).submit(fn, b, *args) for b in range(n_blocks)]
    try:
        return [f.result() for f in futs]
    except BaseException:
        for f in futs:
            f.cancel()
        wait(futs)
        raise
