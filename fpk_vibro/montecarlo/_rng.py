"""The kernels' random source: xoshiro256+ streams and ziggurat normals.

xoshiro256+ (Blackman & Vigna) gives 64-bit outputs whose top 53 bits make the
uniform; the ziggurat (Marsaglia & Tsang 2000, 128 layers in Doornik's ZIGNOR
layout) turns about 98.8 % of the outputs into a normal with one table look-up
and a multiplication.  The state lives in four uint64 locals; each block of paths
owns one stream (``numpy.random.SeedSequence.spawn``), so results do not depend
on the number of threads.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# No fast-math flags, not even "contract": with contraction LLVM chooses which product
# of a*b + c*d to fuse, and chose differently in a function's own compiled code and in
# the copy linked into its caller; which of the two a process runs depends on what it
# compiled or loaded from the cache first (a cold and a warm cache gave different
# bits).  The kernels' fused multiply-adds are written out instead (``_sweep._fma``).
FASTMATH = False

_U11 = np.uint64(11)
_U17 = np.uint64(17)
_U45 = np.uint64(45)
_U19 = np.uint64(19)
_U1 = np.uint64(1)
_TWO_M53 = 2.0 ** -53
_TWO_M52 = 2.0 ** -52


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _next(s0, s1, s2, s3):
    """xoshiro256+ : returns (output, new state)."""
    res = s0 + s3
    t = s1 << _U17
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = (s3 << _U45) | (s3 >> _U19)
    return res, s0, s1, s2, s3


def _zig_tables(n=128, R=3.442619855899, V=9.91256303526217e-3):
    """Ziggurat tables (Marsaglia & Tsang 2000, Doornik's ZIGNOR layout)."""
    X = np.zeros(n + 1)
    f = math.exp(-0.5 * R * R)
    X[0] = V / f
    X[1] = R
    for i in range(2, n):
        X[i] = math.sqrt(-2.0 * math.log(V / X[i - 1] + f))
        f = math.exp(-0.5 * X[i] * X[i])
    X[n] = 0.0
    return X, X[1:] / X[:-1]


_ZX, _ZR = _zig_tables()
_ZR_TAIL = 3.442619855899
_U4 = np.uint64(4)
_U127 = np.uint64(127)


@njit(cache=True, fastmath=FASTMATH)
def _zig_finish(r, u, i, s0, s1, s2, s3):
    """The complete ziggurat from the draw r (u its signed uniform, i its layer)
    on: the rectangle test, else the tail (layer 0) or the wedge test, drawing
    further outputs of the stream until a normal is accepted (out of line: one
    compiled function for the whole rare path)."""
    while True:
        if abs(u) < _ZR[i]:
            return u * _ZX[i], s0, s1, s2, s3
        if i == 0:                      # the tail beyond R
            while True:
                r, s0, s1, s2, s3 = _next(s0, s1, s2, s3)
                xt = -math.log(np.float64(np.int64((r >> _U11) + _U1)) * _TWO_M53) / _ZR_TAIL
                r, s0, s1, s2, s3 = _next(s0, s1, s2, s3)
                yt = -math.log(np.float64(np.int64((r >> _U11) + _U1)) * _TWO_M53)
                if yt + yt >= xt * xt:
                    break
            z = _ZR_TAIL + xt
            return (-z if u < 0.0 else z), s0, s1, s2, s3
        xw = u * _ZX[i]
        f0 = math.exp(-0.5 * (_ZX[i] * _ZX[i] - xw * xw))
        f1 = math.exp(-0.5 * (_ZX[i + 1] * _ZX[i + 1] - xw * xw))
        r, s0, s1, s2, s3 = _next(s0, s1, s2, s3)
        if f1 + (np.float64(np.int64(r >> _U11)) * _TWO_M53) * (f0 - f1) < 1.0:
            return xw, s0, s1, s2, s3
        # rejected: start again from a fresh output
        r, s0, s1, s2, s3 = _next(s0, s1, s2, s3)
        # signed top 53 bits -> u uniform in [-1, 1) (one int64 -> double conversion)
        u = np.float64(np.int64(r) >> 11) * _TWO_M52
        i = np.int64((r >> _U4) & _U127)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _normal(s0, s1, s2, s3):
    """One N(0, 1) draw by the ziggurat method (128 layers); returns (z, state).

    About 98.8 % of draws cost one 64-bit random number, a table look-up and a
    multiplication (inlined); the rest go to the exact wedge/tail tests.
    """
    r, s0, s1, s2, s3 = _next(s0, s1, s2, s3)
    # signed top 53 bits -> u uniform in [-1, 1) (one int64 -> double conversion)
    u = np.float64(np.int64(r) >> 11) * _TWO_M52
    i = np.int64((r >> _U4) & _U127)
    if abs(u) < _ZR[i]:
        return u * _ZX[i], s0, s1, s2, s3
    return _zig_finish(r, u, i, s0, s1, s2, s3)


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def _floor_block(b, rng, per_block):
    """Block b of :func:`._kernel.normals_floor`: ``per_block`` normals, summed."""
    s0 = rng[b, 0]
    s1 = rng[b, 1]
    s2 = rng[b, 2]
    s3 = rng[b, 3]
    acc = 0.0
    for k in range(per_block):
        z, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
        acc += z
    rng[b, 0] = s0
    rng[b, 1] = s1
    rng[b, 2] = s2
    rng[b, 3] = s3
    return acc
