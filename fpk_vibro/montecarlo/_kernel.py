"""Compiled (numba) kernels of the Monte Carlo engine (DESIGN §4).

Random numbers (:mod:`._rng`): one xoshiro256+ stream per block of paths
(seeded from ``numpy.random.SeedSequence.spawn``), standard normals by the
ziggurat method.  A block is simulated by one thread, in a fixed order, by
the same compiled code whatever the number of threads, so the results do not
depend on it.  The blocks are shared out to a ``concurrent.futures`` thread
pool (:func:`run_blocks`; :func:`_run_block` is compiled ``nogil``) rather
than a numba ``prange``: a ``parallel=True`` wrapper made numba re-optimise
the whole block function inside the parfor (~7 s of a cold-cache compile).

The step (BAOAB splitting, see :mod:`fpk_vibro.montecarlo` for the argument)::

    B  y += (h/2) F(x)              F(x) = −(a x + b x³)
    A  x += (h/2) y                 free flight, impacts at x = ±Δ located exactly
    O  y ← e^{−c h} y + sqrt(D(x)(1 − e^{−2ch})/c) ξ     exact OU at fixed x
    A  x += (h/2) y                 (as above)
    B  y += (h/2) F(x)

``p`` (float64 parameter vector) and ``ip`` (int64 flag vector) are laid out by
the ``P_*`` / ``I_*`` indices below.
"""
from __future__ import annotations

import math
import threading
from concurrent.futures import ThreadPoolExecutor, wait

import numba
import numpy as np
from numba import njit

from ._rng import FASTMATH, _floor_block, _normal

# float parameters
P_A, P_B, P_HH, P_EC, P_SD0, P_D1S2, P_D2S2, P_LO, P_HI, P_R, P_GD = range(11)
P_H0, P_HIW, P_X0, P_XIW, P_Y0, P_YIW, P_JX0, P_JXIW, P_JY0, P_JYIW = range(11, 21)
P_FLO, P_FHI = 21, 22
NP = 23
# integer flags
I_MODE, I_D2, I_MAXK = range(3)
NI = 3
# moment accumulator columns
M_N, M_H, M_X2, M_Y2, M_X4, M_Y4, M_PIMP, M_OVH, M_OVX, M_OVY, M_OVJ = range(11)
NM = 11
MODE_NONE, MODE_RIGHT, MODE_BOTH = 0, 1, 2

@njit(cache=True, fastmath=FASTMATH)
def _impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, r, mode, maxk):
    """The impact part of :func:`_flight` (not inlined: rare)."""
    n = 0
    s = 0.0
    v = y
    corr = 0.0
    while True:
        if xn > hi:
            s = min(s + (hi - x) / v, tau)         # v > 0 here
            off = s + off0
            vi = v + corr + off * fhi
            x = hi
            if vi > 0.0:
                v = -r * vi
                n += 1
            else:
                v = 0.0
            corr = -off * fhi
        elif mode == MODE_BOTH and xn < lo:
            s = min(s + (lo - x) / v, tau)         # v < 0 here
            off = s + off0
            vi = v + corr + off * flo
            x = lo
            if vi < 0.0:
                v = -r * vi
                n += 1
            else:
                v = 0.0
            corr = -off * flo
        else:
            return xn, v + corr, n
        if n >= maxk:
            return x, v + corr, n
        xn = x + (tau - s) * v


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _flight(x, y, tau, off0, lo, hi, flo, fhi, r, mode, maxk, lo_t, hi_t):
    """Free flight x += tau*y with impacts located exactly at x = lo / hi.

    ``y`` is the splitting's stored velocity, which already holds the whole
    opening kick (h/2) F.  At an impact at local time s the physical velocity is
    y_imp = y + (s + off0) F_b (``off0`` = −h/2 in the first flight, 0 in the
    second; F_b the force at the barrier); it is reflected, v = −r y_imp, the
    rest of the flight uses v, and the stored velocity returned is
    v − (s + off0) F_b, so that the closing kick completes the step correctly
    (the kick timing error at an impact is O(h²), not O(h)).  If y_imp does not
    point into the barrier (a graze the true curved path would not make), the
    path touches the barrier with v = 0 and no impact is counted.

    Returns (x, stored y, number of impacts).  At most ``maxk`` impacts per call;
    if the bound is reached the path stays on the barrier it hit last.
    """
    xn = x + tau * y
    # one test: lo_t = lo only with a left barrier, hi_t = hi only with a right
    # one (else ∓inf); a NaN goes to _impacts, which returns it unchanged
    if (xn >= lo_t) & (xn <= hi_t):
        return xn, y, 0
    return _impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, r, mode, maxk)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _hist_index(v, v0, inv_w, nb):
    """Bin of v in [v0, v0 + nb/inv_w] (right end included), or −1 outside."""
    u = (v - v0) * inv_w
    if not (u >= 0.0):
        return -1
    k = int(u)
    if k >= nb:
        # v at the right end up to rounding (e.g. a path resting on x = Δ)
        if u <= nb * (1.0 + 1e-12):
            return nb - 1
        return -1
    return k


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _accumulate(x, y, p, mom, b, hH, hx, hy, hj):
    """Add one sample (x, y) to block b's requested histograms; returns
    (H, x², y², 1[H > G(Δ)]) for the moment sums (and counts overflows in mom)."""
    a = p[P_A]
    bb = p[P_B]
    x2 = x * x
    y2 = y * y
    H = 0.5 * y2 + x2 * (0.5 * a + 0.25 * bb * x2)
    nb = hH.shape[1]
    if nb > 0:
        k = _hist_index(H, p[P_H0], p[P_HIW], nb)
        if k >= 0:
            hH[b, k] += 1.0
        else:
            mom[b, M_OVH] += 1.0
    nb = hx.shape[1]
    if nb > 0:
        k = _hist_index(x, p[P_X0], p[P_XIW], nb)
        if k >= 0:
            hx[b, k] += 1.0
        else:
            mom[b, M_OVX] += 1.0
    nb = hy.shape[1]
    if nb > 0:
        k = _hist_index(y, p[P_Y0], p[P_YIW], nb)
        if k >= 0:
            hy[b, k] += 1.0
        else:
            mom[b, M_OVY] += 1.0
    nbx = hj.shape[1]
    if nbx > 0:
        kx = _hist_index(x, p[P_JX0], p[P_JXIW], nbx)
        ky = _hist_index(y, p[P_JY0], p[P_JYIW], hj.shape[2])
        if kx >= 0 and ky >= 0:
            hj[b, kx, ky] += 1.0
        else:
            mom[b, M_OVJ] += 1.0
    return H, x2, y2, 1.0 if H > p[P_GD] else 0.0


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, r, mode,
          has_d2, maxk, lo_t, hi_t):
    """One BAOAB step (module docstring); f = F(x) on entry and on return."""
    y += hh * f
    x, y, m1 = _flight(x, y, hh, -hh, lo, hi, flo, fhi, r, mode, maxk, lo_t, hi_t)
    if has_d2:
        y = ec * y + math.sqrt(d1s2 + d2s2 * x * x) * z
    else:
        y = ec * y + sd0 * z
    x, y, m2 = _flight(x, y, hh, 0.0, lo, hi, flo, fhi, r, mode, maxk, lo_t, hi_t)
    f = -(a + bcub * x * x) * x
    return x, y + hh * f, f, m1 + m2


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def _run_block(b, xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
               mom, imp, xext, hH, hx, hy, hj):
    """Block b of :func:`advance` (compiled without the GIL; :func:`advance`
    runs the blocks on a thread pool)."""
    a = p[P_A]
    bcub = p[P_B]
    hh = p[P_HH]
    ec = p[P_EC]
    sd0 = p[P_SD0]
    d1s2 = p[P_D1S2]
    d2s2 = p[P_D2S2]
    lo = p[P_LO]
    hi = p[P_HI]
    r = p[P_R]
    flo = p[P_FLO]
    fhi = p[P_FHI]
    mode = ip[I_MODE]
    has_d2 = ip[I_D2] != 0
    maxk = ip[I_MAXK]
    lo_t = lo if mode == MODE_BOTH else -math.inf
    hi_t = hi if mode != MODE_NONE else math.inf
    s0 = rng[b, 0]
    s1 = rng[b, 1]
    s2 = rng[b, 2]
    s3 = rng[b, 3]
    nimp = 0
    xmin = xext[b, 0]
    xmax = xext[b, 1]
    cN = 0.0
    cH = 0.0
    cx2 = 0.0
    cy2 = 0.0
    cx4 = 0.0
    cy4 = 0.0
    cP = 0.0
    end = starts[b + 1]
    for i0 in range(starts[b], end, 4):
        # four lanes in registers; lanes past the block end are dummies
        # (simulated from rest at x = 0, never stored nor sampled)
        nl = min(4, end - i0)
        x0 = xs[i0]
        y0 = ys[i0]
        x1 = xs[i0 + 1] if nl > 1 else 0.0
        y1 = ys[i0 + 1] if nl > 1 else 0.0
        x2 = xs[i0 + 2] if nl > 2 else 0.0
        y2 = ys[i0 + 2] if nl > 2 else 0.0
        x3 = xs[i0 + 3] if nl > 3 else 0.0
        y3 = ys[i0 + 3] if nl > 3 else 0.0
        f0 = -(a + bcub * x0 * x0) * x0
        f1 = -(a + bcub * x1 * x1) * x1
        f2 = -(a + bcub * x2 * x2) * x2
        f3 = -(a + bcub * x3 * x3) * x3
        cnt = sample_every - step0 % sample_every if sample_every > 0 else -1
        for k in range(n_steps):
            z, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            x0, y0, f0, m0 = _step(x0, y0, f0, z, hh, ec, sd0, d1s2, d2s2, a, bcub,
                                   lo, hi, flo, fhi, r, mode, has_d2, maxk, lo_t, hi_t)
            z, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            x1, y1, f1, m1 = _step(x1, y1, f1, z, hh, ec, sd0, d1s2, d2s2, a, bcub,
                                   lo, hi, flo, fhi, r, mode, has_d2, maxk, lo_t, hi_t)
            z, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            x2, y2, f2, m2 = _step(x2, y2, f2, z, hh, ec, sd0, d1s2, d2s2, a, bcub,
                                   lo, hi, flo, fhi, r, mode, has_d2, maxk, lo_t, hi_t)
            z, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            x3, y3, f3, m3 = _step(x3, y3, f3, z, hh, ec, sd0, d1s2, d2s2, a, bcub,
                                   lo, hi, flo, fhi, r, mode, has_d2, maxk, lo_t, hi_t)
            nimp += m0
            if nl == 4:
                nimp += m1 + m2 + m3
            else:
                nimp += (m1 if nl > 1 else 0) + (m2 if nl > 2 else 0)
            cnt -= 1
            if cnt == 0:
                cnt = sample_every
                for j in range(nl):
                    if j == 0:
                        xv, yv = x0, y0
                    elif j == 1:
                        xv, yv = x1, y1
                    elif j == 2:
                        xv, yv = x2, y2
                    else:
                        xv, yv = x3, y3
                    H, xx, yy, ind = _accumulate(xv, yv, p, mom, b, hH, hx, hy, hj)
                    cN += 1.0
                    cH += H
                    cx2 += xx
                    cy2 += yy
                    cx4 += xx * xx
                    cy4 += yy * yy
                    cP += ind
                    xmin = min(xmin, xv)
                    xmax = max(xmax, xv)
        xs[i0] = x0
        ys[i0] = y0
        if nl > 1:
            xs[i0 + 1] = x1
            ys[i0 + 1] = y1
        if nl > 2:
            xs[i0 + 2] = x2
            ys[i0 + 2] = y2
        if nl > 3:
            xs[i0 + 3] = x3
            ys[i0 + 3] = y3
    mom[b, M_N] += cN
    mom[b, M_H] += cH
    mom[b, M_X2] += cx2
    mom[b, M_Y2] += cy2
    mom[b, M_X4] += cx4
    mom[b, M_Y4] += cy4
    mom[b, M_PIMP] += cP
    imp[b, 0] += nimp
    imp[b, 1] += (starts[b + 1] - starts[b]) * float(n_steps)
    xext[b, 0] = xmin
    xext[b, 1] = xmax
    rng[b, 0] = s0
    rng[b, 1] = s1
    rng[b, 2] = s2
    rng[b, 3] = s3


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


def advance(xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
            mom, imp, xext, hH, hx, hy, hj, threads=None):
    """Advance every path by ``n_steps`` steps (in place), sampling if asked.

    Blocks run on ``threads`` workers (:func:`run_blocks`).  Within a block,
    paths are advanced four at a time, held in registers (independent
    dependency chains that the CPU overlaps); the random numbers of a block are
    drawn in the order step, then lane, from the block's own stream.

    Parameters
    ----------
    xs, ys : float64[n_paths]
        States, updated in place.
    rng : uint64[n_blocks, 4]
        One xoshiro256+ state per block, updated in place.
    starts : int64[n_blocks + 1]
        Block b holds paths ``starts[b]:starts[b+1]``.
    n_steps, step0, sample_every : int
        A sample is taken after step k (0-based within this call) when
        ``(step0 + k + 1) % sample_every == 0``; ``sample_every = 0`` disables it.
    p, ip : parameter vectors (module docstring).
    mom : float64[n_blocks, NM]
        Per-block sums of the sampled moments (``M_*`` columns).
    imp : float64[n_blocks, 2]
        Per-block impact count and path-steps advanced.
    xext : float64[n_blocks, 2]
        Per-block min and max of x over the samples taken.
    hH, hx, hy, hj : float64 arrays
        Per-block histogram counts; a zero-length bin axis means "not requested".
    threads : int, optional
        Worker threads (default :func:`numba.get_num_threads`, i.e. all cores
        unless changed); the result does not depend on it.
    """
    run_blocks(_run_block, rng.shape[0], (xs, ys, rng, starts, n_steps, step0,
                                          sample_every, p, ip, mom, imp, xext,
                                          hH, hx, hy, hj), threads)


@njit(cache=True, fastmath=FASTMATH)
def snapshot(xs, ys, starts, p, mom, xext, hH, hx, hy, hj):
    """Accumulate the current states of all paths once (transient densities;
    cheap, so serial)."""
    n_blocks = starts.shape[0] - 1
    for b in range(n_blocks):
        xmin = xext[b, 0]
        xmax = xext[b, 1]
        for i in range(starts[b], starts[b + 1]):
            H, xx, yy, ind = _accumulate(xs[i], ys[i], p, mom, b, hH, hx, hy, hj)
            mom[b, M_N] += 1.0
            mom[b, M_H] += H
            mom[b, M_X2] += xx
            mom[b, M_Y2] += yy
            mom[b, M_X4] += xx * xx
            mom[b, M_Y4] += yy * yy
            mom[b, M_PIMP] += ind
            xmin = min(xmin, xs[i])
            xmax = max(xmax, xs[i])
        xext[b, 0] = xmin
        xext[b, 1] = xmax


def normals_floor(rng, per_block, threads=None):
    """Draw ``per_block`` normals from each block's stream (the RNG's own rate).

    The same generator, the same blocking and the same thread-pool dispatch as
    :func:`advance`; returns the per-block sums (so nothing is optimised away).
    """
    return np.array(run_blocks(_floor_block, rng.shape[0], (rng, per_block), threads))
