"""Launch helpers shared by the GPU engines (:mod:`._cuda_engine`,
:mod:`._cuda_periodic`): threads per block, Ctrl-C held back while a chunk is queued,
the blocks of a batch-ordered launch."""
from __future__ import annotations

import numpy as np

from ._device import simulator

#: Threads per block of the stationary and first-passage kernels (the benchmark
#: compares 128 and 256).
THREADS_PER_BLOCK = 128
#: Steps per stationary launch at most (keeps per-block uint32 histogram counts exact).
LAUNCH_STEPS_MAX = 1 << 22


def _tpb() -> int:
    return 8 if simulator() else THREADS_PER_BLOCK


def _flat(p) -> np.ndarray:
    return np.ascontiguousarray(np.array(tuple(p), dtype=np.float64))


class _Deferred:
    """Ctrl-C held back while a chunk's launches are queued (main thread only), then
    delivered: a chunk is queued whole or not at all, and a queued chunk completes
    on the GPU whatever the host does, so the interrupted run counts it."""

    def __enter__(self):
        import signal
        import threading
        self.got, self.old = [], None
        if threading.current_thread() is threading.main_thread():
            self.old = signal.signal(signal.SIGINT, lambda *a: self.got.append(a))
        return self

    def __exit__(self, *exc):
        import signal
        if self.old is not None:
            signal.signal(signal.SIGINT, self.old)
            if self.got and exc[0] is None:
                if callable(self.old):
                    self.old(*self.got[0])
                raise KeyboardInterrupt
        return False


def block_map(starts: np.ndarray, i0: int, i1: int, tpb: int):
    """Blocks of at most ``tpb`` paths, each within one batch, covering paths
    i0 .. i1 − 1: (batch of each block, its [first, end) paths, first block of each
    batch (nb + 1 entries))."""
    lo = np.clip(starts[:-1], i0, i1)
    hi = np.clip(starts[1:], i0, i1)
    cnt = (hi - lo + tpb - 1) // tpb
    bstart = np.concatenate([[0], np.cumsum(cnt)]).astype(np.int64)
    blk_b = np.repeat(np.arange(starts.size - 1, dtype=np.int64), cnt)
    first = lo[blk_b] + (np.arange(blk_b.size) - bstart[blk_b]) * tpb
    blk_i = np.stack([first, np.minimum(first + tpb, hi[blk_b])], axis=1).astype(np.int64)
    return blk_b, blk_i, bstart
