"""Compiled (numba) kernels of the Monte Carlo engine (DESIGN §4).

Random numbers (:mod:`._rng`): one xoshiro256+ stream per block of paths
(seeded from ``numpy.random.SeedSequence.spawn``), standard normals by the
ziggurat method.  A block is simulated by one thread, in a fixed order, by
the same compiled code whatever the number of threads, so the results do not
depend on it.  The blocks are shared out to a thread pool
(:func:`._threads.run_blocks`; :func:`_run_block` is compiled ``nogil``).

The step (BAOAB splitting, see :mod:`fpk_vibro.montecarlo` for the argument)::

    B  y += (h/2) F(x)              F(x) = −(a x + b x³)
    A  x += (h/2) y                 free flight, impacts at x = ±Δ located exactly
    O  y ← e^{−c h} y + sqrt(D(x)(1 − e^{−2ch})/c) ξ     exact OU at fixed x
    A  x += (h/2) y                 (as above)
    B  y += (h/2) F(x)

Between steps the kernel holds v = y − (h/2) F(x) instead of y, so that the
closing B of one step and the opening B of the next are a single kick
v + h F(x) (one force evaluation per step); y is restored for sampling and on
return.  Per step, a chunk of paths draws its normals, then one branch-free
loop (:func:`_smooth_sweep`, which LLVM compiles to AVX2/SSE code) advances
every path as if no barrier were hit and flags the paths whose flights left the
strip; only those (~2 % of path-steps in the paper's case) are redone by the
scalar step with exact impact handling (:func:`_step`).

``p`` (float64 parameter vector) and ``ip`` (int64 flag vector) are laid out by
the ``P_*`` / ``I_*`` indices below.
"""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.cpython.unsafe.numbers import trailing_zeros
from numba.extending import intrinsic

from ._rng import FASTMATH, _floor_block, _normal
from ._threads import run_blocks

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


@intrinsic
def _fma(typingctx, a, b, c):
    """a*b + c rounded once (``llvm.fma``: FMA instructions, vectorised; a libm
    call on a CPU without FMA, same result).

    Written out rather than left to contraction (``_rng.FASTMATH``), so that every
    compiled copy of a function rounds alike.
    """
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)
    return sig, codegen


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


@njit(cache=True, fastmath=FASTMATH)
def _sample(xv, vv, n, kick, p, b, mom, xext, hH, hx, hy, hj):
    """Add the states x = xv[:n], y = vv[:n] + kick F(x) (``kick`` = h/2 for the
    kick-merged state of :func:`_smooth_sweep`, 0 for plain states) as samples of
    block b: the requested
    histograms, the moment sums (``mom[b]``, overflow counts included) and the
    range of x (``xext[b]``).

    Called once per sweep, not per path, and written out without array-taking
    helpers: an inlined helper receiving arrays costs numba a reference-count
    increment and decrement per call (~30 ns per sample, measured).
    """
    a = p[P_A]
    bb = p[P_B]
    gd = p[P_GD]
    nbh = hH.shape[1]
    nbx = hx.shape[1]
    nby = hy.shape[1]
    njx = hj.shape[1]
    njy = hj.shape[2]
    cH = 0.0
    cx2 = 0.0
    cy2 = 0.0
    cx4 = 0.0
    cy4 = 0.0
    cP = 0.0
    oH = 0.0
    ox = 0.0
    oy = 0.0
    oj = 0.0
    xmin = xext[b, 0]
    xmax = xext[b, 1]
    for j in range(n):
        x = xv[j]
        x2 = x * x
        y = vv[j] - kick * (a + bb * x2) * x
        y2 = y * y
        H = 0.5 * y2 + x2 * (0.5 * a + 0.25 * bb * x2)
        if nbh > 0:
            k = _hist_index(H, p[P_H0], p[P_HIW], nbh)
            if k >= 0:
                hH[b, k] += 1.0
            else:
                oH += 1.0
        if nbx > 0:
            k = _hist_index(x, p[P_X0], p[P_XIW], nbx)
            if k >= 0:
                hx[b, k] += 1.0
            else:
                ox += 1.0
        if nby > 0:
            k = _hist_index(y, p[P_Y0], p[P_YIW], nby)
            if k >= 0:
                hy[b, k] += 1.0
            else:
                oy += 1.0
        if njx > 0:
            kx = _hist_index(x, p[P_JX0], p[P_JXIW], njx)
            ky = _hist_index(y, p[P_JY0], p[P_JYIW], njy)
            if kx >= 0 and ky >= 0:
                hj[b, kx, ky] += 1.0
            else:
                oj += 1.0
        cH += H
        cx2 += x2
        cy2 += y2
        cx4 += x2 * x2
        cy4 += y2 * y2
        cP += 1.0 if H > gd else 0.0
        xmin = min(xmin, x)
        xmax = max(xmax, x)
    mom[b, M_N] += n
    mom[b, M_H] += cH
    mom[b, M_X2] += cx2
    mom[b, M_Y2] += cy2
    mom[b, M_X4] += cx4
    mom[b, M_Y4] += cy4
    mom[b, M_PIMP] += cP
    mom[b, M_OVH] += oH
    mom[b, M_OVX] += ox
    mom[b, M_OVY] += oy
    mom[b, M_OVJ] += oj
    xext[b, 0] = xmin
    xext[b, 1] = xmax


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


# paths advanced together in a block: the vectorised sweep's length, at most 64
# (one bit per path in the sweep's int64 mask)
CHUNK = 64


@njit(cache=True, fastmath=FASTMATH)
def _smooth_sweep(xa, va, xb, vb, xm, z, n, hh, ha, hb, ec, sd0, d1s2, d2s2, has_d2,
                  lo_t, hi_t):
    """One step of n paths from (xa, va) into (xb, vb), assuming no impact.

    The state is kept in kick-merged (leapfrog) form: v is the velocity before
    the closing half kick, y = v + (h/2) F(x), so the closing kick of one step
    and the opening kick of the next are one kick v + h F(x) (``ha`` = h a,
    ``hb`` = h b) and the force is evaluated once per step.

    Branch-free, so the compiler vectorises it (SIMD over paths).  Returns two
    bit masks (bit j for path j, n ≤ 64) of the paths where the assumption
    fails: ``bad1``, the first flight left [lo_t, hi_t] (or a NaN), and
    ``bad2``, only the second did.  :func:`_run_block` redoes the former with
    the exact :func:`_step` from (xa, va), which this sweep leaves untouched (it
    writes into separate arrays), and the latter from the midpoint it stores,
    x1 in ``xm`` and the velocity after the O step in ``vb``, by the second
    flight alone.
    """
    bad1 = 0
    bad2 = 0
    for j in range(n):
        x = xa[j]
        y1 = _fma(-_fma(hb * x, x, ha), x, va[j])             # v − (ha + hb x²) x
        x1 = _fma(hh, y1, x)
        if has_d2:
            y2 = _fma(math.sqrt(_fma(d2s2 * x1, x1, d1s2)), z[j], ec * y1)
        else:
            y2 = _fma(sd0, z[j], ec * y1)
        x2 = _fma(hh, y2, x1)
        ok1 = (x1 >= lo_t) & (x1 <= hi_t)
        ok2 = (x2 >= lo_t) & (x2 <= hi_t)
        xb[j] = x2
        vb[j] = y2
        xm[j] = x1
        bad1 |= (0 if ok1 else 1) << j
        bad2 |= (0 if ok2 else 1) << j
    return bad1, bad2 & ~bad1


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def _run_block(b, xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
               mom, imp, xext, hH, hx, hy, hj):
    """Block b of :func:`advance` (compiled without the GIL; :func:`advance`
    runs the blocks on a thread pool).

    The block's paths are advanced CHUNK at a time; each step draws the chunk's
    normals from the block's stream (in path order), advances every path by the
    vectorised :func:`_smooth_sweep`, then redoes the few paths it flagged
    (a barrier crossed, ~2 % of path-steps in the paper's case) with the scalar
    :func:`_step`.
    """
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
    ha = 2.0 * hh * a
    hb = 2.0 * hh * bcub
    xa = np.empty(CHUNK)
    va = np.empty(CHUNK)
    xb = np.empty(CHUNK)
    vb = np.empty(CHUNK)
    xm = np.empty(CHUNK)
    z = np.empty(CHUNK)
    end = starts[b + 1]
    for i0 in range(starts[b], end, CHUNK):
        n = min(CHUNK, end - i0)
        for j in range(n):
            x = xs[i0 + j]
            xa[j] = x
            va[j] = ys[i0 + j] + hh * (a + bcub * x * x) * x      # v = y − (h/2) F(x)
        cnt = sample_every - step0 % sample_every if sample_every > 0 else -1
        for k in range(n_steps):
            for j in range(n):
                z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            bad1, bad2 = _smooth_sweep(xa, va, xb, vb, xm, z, n, hh, ha, hb, ec, sd0,
                                       d1s2, d2s2, has_d2, lo_t, hi_t)
            while bad2 != 0:                # an impact in the second flight only
                j = trailing_zeros(bad2)
                bad2 &= bad2 - 1
                x, y, m = _flight(xm[j], vb[j], hh, 0.0, lo, hi, flo, fhi, r, mode, maxk,
                                  lo_t, hi_t)
                xb[j] = x
                vb[j] = y
                nimp += m
            while bad1 != 0:                # in the first flight (or a NaN): whole step
                j = trailing_zeros(bad1)
                bad1 &= bad1 - 1
                x = xa[j]
                f = -(a + bcub * x * x) * x
                x, y, f, m = _step(x, va[j] + hh * f, f, z[j], hh, ec, sd0, d1s2, d2s2,
                                   a, bcub, lo, hi, flo, fhi, r, mode, has_d2, maxk,
                                   lo_t, hi_t)
                xb[j] = x
                vb[j] = y - hh * f
                nimp += m
            xa, xb = xb, xa
            va, vb = vb, va
            cnt -= 1
            if cnt == 0:
                cnt = sample_every
                _sample(xa, va, n, hh, p, b, mom, xext, hH, hx, hy, hj)
        for j in range(n):
            x = xa[j]
            xs[i0 + j] = x
            ys[i0 + j] = va[j] - hh * (a + bcub * x * x) * x      # y = v + (h/2) F(x)
    imp[b, 0] += nimp
    imp[b, 1] += (starts[b + 1] - starts[b]) * float(n_steps)
    rng[b, 0] = s0
    rng[b, 1] = s1
    rng[b, 2] = s2
    rng[b, 3] = s3


def advance(xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
            mom, imp, xext, hH, hx, hy, hj, threads=None):
    """Advance every path by ``n_steps`` steps (in place), sampling if asked.

    Blocks run on ``threads`` workers (:func:`run_blocks`).  Within a block,
    paths are advanced CHUNK at a time by a vectorised sweep (:func:`_run_block`);
    the random numbers of a block are drawn in the order chunk, step, path from
    the block's own stream.

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
    for b in range(starts.shape[0] - 1):
        i0 = starts[b]
        i1 = starts[b + 1]
        _sample(xs[i0:i1], ys[i0:i1], i1 - i0, 0.0, p, b, mom, xext, hH, hx, hy, hj)


def normals_floor(rng, per_block, threads=None):
    """Draw ``per_block`` normals from each block's stream (the RNG's own rate).

    The same generator, the same blocking and the same thread-pool dispatch as
    :func:`advance`; returns the per-block sums (so nothing is optimised away).
    """
    return np.array(run_blocks(_floor_block, rng.shape[0], (rng, per_block), threads))
