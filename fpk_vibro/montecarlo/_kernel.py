"""Compiled (numba) kernels of the Monte Carlo engine.

Random numbers (:mod:`._rng`): one xoshiro256+ stream per block of paths
(seeded from ``numpy.random.SeedSequence.spawn``), standard normals by the
ziggurat method.  A block is simulated by one thread, in a fixed order, by
the same compiled code whatever the number of threads, so the results do not
depend on it.  The blocks are shared out to a thread pool
(:func:`._threads.run_blocks`; :func:`_run_block` is compiled ``nogil``).

The step (BAOAB splitting, see :mod:`fpk_vibro.montecarlo` for the argument)::

    B  y += (h/2) F(x)              F(x) = −(a x + b x³)
    A  x += (h/2) y                 free flight, impacts at x_L, x_R located exactly
    O  y ← e^{−c h} y + sqrt(D(x)(1 − e^{−2ch})/c) ξ     exact OU at fixed x
    A  x += (h/2) y                 (as above; :mod:`._flight`)
    B  y += (h/2) F(x)

Between steps the kernel holds v = y − (h/2) F(x) instead of y, so that the
closing B of one step and the opening B of the next are a single kick
v + h F(x) (one force evaluation per step); y is restored for sampling and on
return.  Per step, a chunk of paths draws its normals, then one branch-free
loop (:func:`_smooth_sweep`, which LLVM compiles to AVX2/SSE code) advances
every path as if no wall were hit and flags the paths whose flights left the
strip; only those (~2 % of path-steps in the paper's case) are redone by the
scalar step with exact impact handling (:func:`_step_walls`).

``p`` and ``ip`` are the step's records :class:`._params.StepParams` (floats) and
:class:`._params.StepFlags` (integers), read by field name.  A side without a wall
has ``p.lo`` = −inf (``p.hi`` = +inf), so no flight crosses it: the kernel needs no
case for which walls exist (``ip.mode`` only records it).
"""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.cpython.unsafe.numbers import trailing_zeros
from numba.extending import intrinsic

from ._flight import (LEFT, NW, NX, RIGHT, W_N, W_Q, W_U, X_E, X_G0, X_GL, X_GM,  # noqa: F401
                      X_GR, X_M, X_TL, X_TR, _flight)
from ._rng import FASTMATH, _floor_block, _normal
from ._threads import run_blocks

# the step's records (:mod:`._params`; their field positions and MODE_* stay
# importable from here) and the sampling (:mod:`._sampling`)
from ._params import (I_D2, I_MAXK, I_MODE, MODE_BOTH, MODE_LEFT, MODE_NONE,  # noqa: F401
                      MODE_RIGHT, NI, NP, P_A, P_B, P_D1S2, P_D2S2, P_EC, P_FHI, P_FLO, P_GD,
                      P_H0, P_HH, P_HI, P_HIW, P_JX0, P_JXIW, P_JY0, P_JYIW, P_LO, P_R, P_RL,
                      P_SD0, P_UWL, P_UWR, P_X0, P_XIW, P_Y0, P_YIW)
from ._sampling import (M_H, M_N, M_OVH, M_OVJ, M_OVX, M_OVY, M_PIMP, M_X, M_X2,  # noqa: F401
                        M_X4, M_Y2, M_Y4, NM, _hist_index, _sample, snapshot)


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


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step_core(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi,
               has_d2, maxk, lo_t, hi_t, hu, iwl, iwr, law, ext, t0, i, gg):
    """One BAOAB step (module docstring); f = F(x) on entry and on return.

    Returns (x, y, f) and the wall statistics of the step as :func:`._flight._flight`
    gives them (impacts left, right, Σu left, right, Σu² left, right, Σe left, right,
    largest u); ``hu``, ``iwl``, ``iwr``, ``law``, ``ext``, ``i``: as there (``t0``
    the step's start time).  ``gg``: None, or (g0, g1): the kicks add the harmonic
    force, g0 at the step's start (opening kick, and the wall force of the first
    flight) and g1 at its end (second flight, closing kick); f stays F(x) alone.
    (At most 30 arguments: beyond, CPython 3.11 passes them as *args, which numba
    cannot inline.)
    """
    fo = f
    flo1 = flo
    fhi1 = fhi
    if gg is not None:
        g0 = gg[0]
        fo = f + g0
        flo1 = flo + g0
        fhi1 = fhi + g0
    y += hh * fo
    x, y, nl, nr, ul, ur, ql, qr, el, er, um = _flight(
        x, y, hh, -hh, lo, hi, flo1, fhi1, rlo, rhi, maxk, lo_t, hi_t, hu, iwl, iwr, law,
        ext, t0, i)
    if has_d2:
        y = ec * y + math.sqrt(d1s2 + d2s2 * x * x) * z
    else:
        y = ec * y + sd0 * z
    flo2 = flo
    fhi2 = fhi
    if gg is not None:
        flo2 = flo + gg[1]
        fhi2 = fhi + gg[1]
    x, y, nl2, nr2, ul2, ur2, ql2, qr2, el2, er2, um2 = _flight(
        x, y, hh, 0.0, lo, hi, flo2, fhi2, rlo, rhi, maxk, lo_t, hi_t, hu, iwl, iwr, law,
        ext, t0 + hh, i)
    f = -(a + bcub * x * x) * x
    fo = f
    if gg is not None:
        fo = f + gg[1]
    return (x, y + hh * fo, f, nl + nl2, nr + nr2, ul + ul2, ur + ur2, ql + ql2, qr + qr2,
            el + el2, er + er2, max(um, um2))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step_full(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi,
               has_d2, maxk, lo_t, hi_t, hu, iwl, iwr, law, ext, t0, i):
    """:func:`_step_core` without forcing: one BAOAB step, f = F(x) on entry and on
    return; the wall statistics as :func:`._flight._flight` gives them."""
    return _step_core(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo,
                      rhi, has_d2, maxk, lo_t, hi_t, hu, iwl, iwr, law, ext, t0, i, None)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step_walls(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi,
                has_d2, maxk, lo_t, hi_t, hu=None, iwl=0.0, iwr=0.0):
    """:func:`_step_full` with constant restitutions ``rlo``, ``rhi``, returning (x, y,
    f, impacts left, right, Σu left, right, Σu² left, right): the scalar reference
    of the tests."""
    (x, y, f, nl, nr, ul, ur, ql, qr, _, _, _) = _step_full(
        x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi, has_d2,
        maxk, lo_t, hi_t, hu, iwl, iwr, None, None, 0.0, 0)
    return x, y, f, nl, nr, ul, ur, ql, qr


@njit(cache=True, fastmath=FASTMATH)
def _step(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, r, mode,
          has_d2, maxk, lo_t, hi_t):
    """:func:`_step_walls` with one restitution ``r`` on both walls, returning (x, y,
    f, impacts): the plain scalar scheme the vectorised sweep is checked against
    (``mode`` is not needed: an absent wall is at ∓inf)."""
    x, y, f, nl, nr, _, _, _, _ = _step_walls(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub,
                                              lo, hi, flo, fhi, r, r, has_d2, maxk, lo_t,
                                              hi_t)
    return x, y, f, nl + nr


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
               mom, imp, xext, hH, hx, hy, hj, wimp, speeds, law, extra, asked, gtab, per):
    """Block b of :func:`advance` (compiled without the GIL; :func:`advance`
    runs the blocks on a thread pool).

    The block's paths are advanced CHUNK at a time; each step draws the chunk's
    normals from the block's stream (in path order), advances every path by the
    vectorised :func:`_smooth_sweep`, then redoes the few paths it flagged
    (a wall crossed, ~2 % of path-steps in the paper's case) with the scalar
    :func:`_step_walls`.  Impact statistics are summed in locals and added to
    ``imp[b]`` and ``wimp[b]`` once, at the end; impact speeds go to ``speeds[b]``
    (a histogram per wall, :mod:`._flight`; no column: not kept).  ``law``: the
    walls' restitution packed (:func:`._params.wall_laws`); the energy the impacts
    remove and the largest speed go to ``extra[b]``.  ``asked``: None, or (last,
    energies, gaps) (:func:`advance`): the impact energies into ``energies[b]`` and,
    where ``last`` has a row per path (each path's last impact: time relative to this
    call's start on entry, to its end on return, and wall), the gaps between impacts
    into ``extra[b]`` and ``gaps[b]`` (:mod:`._flight`).

    ``gtab`` (``ip.forced``): the harmonic force at the call's step times, g_k at
    t0 + k h (k = 0..n_steps).  The merged kick of step k (the closing kick of step
    k − 1 and the opening kick of step k, both at t_k) adds h g_k to every path; the
    stored v is y − (h/2)(F(x) + g) at the state's time.  ``per``: None, or the
    periodic sampling tables of :func:`advance`.
    """
    a = p.a
    bcub = p.b
    hh = p.hh
    ec = p.ec
    sd0 = p.sd0
    d1s2 = p.d1s2
    d2s2 = p.d2s2
    lo = p.lo
    hi = p.hi
    rlo = p.r_left
    rhi = p.r_right
    flo = p.f_lo
    fhi = p.f_hi
    hu = speeds[b]
    iwl = p.u_iw_left
    iwr = p.u_iw_right
    if asked is None:
        ext = None
        track = False
        last = np.zeros((0, 2))
    else:
        last = asked[0]
        ext = (extra[b], asked[1][b], asked[2][b], last, p.e_iw_left, p.e_iw_right,
               p.g_iw)
        track = last.shape[0] > 0
    nbk = rng.shape[0]
    if per is None:
        pM = 0
        slot_of = np.zeros(1, dtype=np.int64)
        step_slot = np.zeros(1, dtype=np.int64)
        s_avg = 1
        mh = np.zeros((1, NM))
        xeh = np.zeros((1, 2))
        pimp = np.zeros((1, 2, 5))
        e2 = np.zeros((1, 0))
        e3 = np.zeros((1, 0, 0))
    else:
        pM, slot_of, step_slot, s_avg, mh, xeh, pimp, e2, e3 = per
    avg_row = (mom.shape[0] // nbk - 1) * nbk + b
    forced = ip.forced != 0
    h = 2.0 * hh
    el = 0.0
    er = 0.0
    um = 0.0
    has_d2 = ip.has_d2 != 0
    maxk = ip.max_impacts
    lo_t = lo                       # ∓inf where there is no wall
    hi_t = hi
    s0 = rng[b, 0]
    s1 = rng[b, 1]
    s2 = rng[b, 2]
    s3 = rng[b, 3]
    nl = 0
    nr = 0
    ul = 0.0
    ur = 0.0
    ql = 0.0
    qr = 0.0
    ha = 2.0 * hh * a
    hb = 2.0 * hh * bcub
    xa = np.empty(CHUNK)
    va = np.empty(CHUNK)
    xb = np.empty(CHUNK)
    vb = np.empty(CHUNK)
    xm = np.empty(CHUNK)
    vk = np.empty(CHUNK)
    z = np.empty(CHUNK)
    g0 = 0.0
    g1 = 0.0
    nl0, nr0, ul0, ur0, ql0, qr0, el0, er0 = 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    end = starts[b + 1]
    for i0 in range(starts[b], end, CHUNK):
        n = min(CHUNK, end - i0)
        if forced:
            g0 = gtab[0]
        for j in range(n):
            x = xs[i0 + j]
            xa[j] = x
            va[j] = ys[i0 + j] + hh * (a + bcub * x * x) * x      # v = y − (h/2) F(x)
            if forced:
                va[j] -= hh * g0
        cnt = sample_every - step0 % sample_every if sample_every > 0 else -1
        for k in range(n_steps):
            for j in range(n):
                z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            vin = va
            if forced:
                g0 = gtab[k]
                g1 = gtab[k + 1]
                hg = h * g0
                for j in range(n):
                    vk[j] = va[j] + hg
                vin = vk
            if pM > 0:
                nl0, nr0, ul0, ur0, ql0, qr0, el0, er0 = nl, nr, ul, ur, ql, qr, el, er
            bad1, bad2 = _smooth_sweep(xa, vin, xb, vb, xm, z, n, hh, ha, hb, ec, sd0,
                                       d1s2, d2s2, has_d2, lo_t, hi_t)
            while bad2 != 0:                # an impact in the second flight only
                j = trailing_zeros(bad2)
                bad2 &= bad2 - 1
                if forced:
                    flo2 = flo + g1
                    fhi2 = fhi + g1
                else:
                    flo2 = flo
                    fhi2 = fhi
                x, y, ml, mr, sl, sr, tl, tr, gl, gr, gm = _flight(
                    xm[j], vb[j], hh, 0.0, lo, hi, flo2, fhi2, rlo, rhi, maxk, lo_t, hi_t,
                    hu, iwl, iwr, law, ext, k * h + hh, i0 + j)
                el += gl
                er += gr
                um = max(um, gm)
                xb[j] = x
                vb[j] = y
                nl += ml
                nr += mr
                ul += sl
                ur += sr
                ql += tl
                qr += tr
            while bad1 != 0:                # in the first flight (or a NaN): whole step
                j = trailing_zeros(bad1)
                bad1 &= bad1 - 1
                x = xa[j]
                f = -(a + bcub * x * x) * x
                if forced:
                    x, y, f, ml, mr, sl, sr, tl, tr, gl, gr, gm = _step_core(
                        x, va[j] + hh * (f + g0), f, z[j], hh, ec, sd0, d1s2, d2s2, a, bcub,
                        lo, hi, flo, fhi, rlo, rhi, has_d2, maxk, lo_t, hi_t, hu, iwl, iwr,
                        law, ext, k * h, i0 + j, (g0, g1))
                    vb[j] = y - hh * (f + g1)
                else:
                    x, y, f, ml, mr, sl, sr, tl, tr, gl, gr, gm = _step_full(
                        x, va[j] + hh * f, f, z[j], hh, ec, sd0, d1s2, d2s2, a, bcub, lo,
                        hi, flo, fhi, rlo, rhi, has_d2, maxk, lo_t, hi_t, hu, iwl, iwr,
                        law, ext, k * h, i0 + j)
                    vb[j] = y - hh * f
                el += gl
                er += gr
                um = max(um, gm)
                xb[j] = x
                nl += ml
                nr += mr
                ul += sl
                ur += sr
                ql += tl
                qr += tr
            xa, xb = xb, xa
            va, vb = vb, va
            if pM > 0:
                # periodic: this step's impacts to its phase slot, the new state's
                # samples to its grid point's slots (advance)
                gk = (step0 + k) % pM
                ss = step_slot[gk]
                if ss >= 0:
                    r = ss * nbk + b
                    pimp[r, 0, 0] += nl - nl0
                    pimp[r, 1, 0] += nr - nr0
                    pimp[r, 0, 1] += ul - ul0
                    pimp[r, 1, 1] += ur - ur0
                    pimp[r, 0, 2] += ql - ql0
                    pimp[r, 1, 2] += qr - qr0
                    pimp[r, 0, 3] += el - el0
                    pimp[r, 1, 3] += er - er0
                    pimp[r, 0, 4] += n
                gm1 = (gk + 1) % pM
                vs = va
                if forced:
                    for j in range(n):
                        vk[j] = va[j] + hh * g1
                    vs = vk
                ss = slot_of[gm1]
                if ss >= 0:
                    _sample(xa, vs, n, hh, p, ss * nbk + b, mom, xext, hH, hx, hy, hj)
                if gm1 % s_avg == 0:
                    _sample(xa, vs, n, hh, p, avg_row, mom, xext, hH, hx, hy, hj)
                    _sample(xa, vs, n, hh, p, (gm1 // s_avg) * nbk + b, mh, xeh, e2, e2,
                            e2, e3)
            else:
                cnt -= 1
                if cnt == 0:
                    cnt = sample_every
                    if forced:
                        for j in range(n):
                            vk[j] = va[j] + hh * g1
                        _sample(xa, vk, n, hh, p, b, mom, xext, hH, hx, hy, hj)
                    else:
                        _sample(xa, va, n, hh, p, b, mom, xext, hH, hx, hy, hj)
        for j in range(n):
            x = xa[j]
            xs[i0 + j] = x
            ys[i0 + j] = va[j] - hh * (a + bcub * x * x) * x      # y = v + (h/2) F(x)
            if forced:
                ys[i0 + j] += hh * gtab[n_steps]
        if track:
            for j in range(n):
                last[i0 + j, 0] -= n_steps * h      # relative to the call's end
    imp[b, 0] += nl + nr
    imp[b, 1] += (starts[b + 1] - starts[b]) * float(n_steps)
    wimp[b, LEFT, W_N] += nl
    wimp[b, RIGHT, W_N] += nr
    wimp[b, LEFT, W_U] += ul
    wimp[b, RIGHT, W_U] += ur
    wimp[b, LEFT, W_Q] += ql
    wimp[b, RIGHT, W_Q] += qr
    extra[b, LEFT, X_E] += el
    extra[b, RIGHT, X_E] += er
    extra[b, 0, X_M] = max(extra[b, 0, X_M], um)
    rng[b, 0] = s0
    rng[b, 1] = s1
    rng[b, 2] = s2
    rng[b, 3] = s3


def advance(xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
            mom, imp, xext, hH, hx, hy, hj, threads=None, walls=None, speeds=None,
            law=None, extra=None, last=None, energies=None, gaps=None, t0=0.0,
            periodic=None):
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
    p, ip : StepParams, StepFlags
        The step's records (module docstring).
    mom : float64[n_blocks, NM]
        Per-block sums of the sampled moments (``M_*`` columns).
    imp : float64[n_blocks, 2]
        Per-block impact count (both walls) and path-steps advanced.
    xext : float64[n_blocks, 2]
        Per-block min and max of x over the samples taken.
    hH, hx, hy, hj : float64 arrays
        Per-block histogram counts; a zero-length bin axis means "not requested".
    threads : int, optional
        Worker threads (default :func:`numba.get_num_threads`, i.e. all cores
        unless changed); the result does not depend on it.
    walls : float64[n_blocks, 2, NW], optional
        Per-block wall statistics, added to: ``walls[b, side, W_N]`` impacts,
        ``W_U`` Σ u, ``W_Q`` Σ u² (u the speed before impact; side 0 left, 1
        right).  Default: not kept.
    speeds : float64[n_blocks, 2, m], optional
        Per-block impact-speed histograms, added to (:mod:`._flight`; bin widths
        1/``p.u_iw_left``, 1/``p.u_iw_right``, column m − 1 the speeds beyond).  Default
        (or m = 0): not kept.
    law : float64 array, optional
        The walls' restitution packed (:func:`._params.wall_laws`); default the
        constants ``p.r_left``, ``p.r_right``.
    extra : float64[n_blocks, 2, NX], optional
        Per-block further wall statistics, added to (:mod:`._flight`: the energy the
        impacts remove, the largest impact speed in ``[b, 0, X_M]``, the gaps
        between impacts).
        Default: not kept.
    last : float64[n_paths, 2], optional
        Each path's last impact (time relative to now, −inf: none; wall 0 left, 1
        right), updated; then the gaps between impacts are counted in ``extra``
        (:mod:`._flight`).  Default: not tracked.
    energies : float64[n_blocks, 2, m], optional
        Per-block histograms of the energy each impact removes (bin widths
        1/``p.e_iw_left``, 1/``p.e_iw_right``).  Default: not kept.
    gaps : float64[n_blocks, 1, m], optional
        Per-block histogram of the gaps between successive impacts of a path (bin
        width 1/``p.g_iw``).  Default: not kept.
    t0 : float, optional
        The time of the states on entry: with forcing (``ip.forced``) the kick at
        t_k = t0 + k h adds h F cos(Ω t_k + φ0) (the merged closing and opening
        kicks, both at t_k; ``p.f_amp``, ``p.f_omega``, ``p.f_phase``).
    periodic : tuple, optional
        (M, slot_of, step_slot, s_avg, mh, xeh, pimp): phase-resolved sampling over a
        period of M steps (:mod:`._periodic`).  ``step0`` is then the grid index of
        the entry state (mod M) and ``sample_every`` is ignored.  After a step from
        grid point g to g + 1 (mod M): its impacts go to ``pimp[step_slot[g]·B + b]``
        (columns 0–3 count, Σu, Σu², Σe per side, column 4 of side 0 the path-steps);
        the new state is sampled into row ``slot_of[g + 1]·B + b`` of ``mom``,
        ``xext`` and the histograms (B blocks; −1: not sampled), and where
        (g + 1) % s_avg = 0 into their last B rows (the period average) and, moments
        only, into ``mh[((g + 1) // s_avg)·B + b]`` (``xeh`` its x range).
    """
    nb = rng.shape[0]
    if walls is None:
        walls = np.zeros((nb, 2, NW))
    if speeds is None:
        speeds = np.zeros((nb, 2, 0))
    if law is None:
        law = np.array([0.0, p.r_left, 0.0, 1.0, 0.0, 12.0,
                        0.0, p.r_right, 0.0, 1.0, 0.0, 12.0])
    if extra is None:
        extra = np.zeros((nb, 2, NX))
    asked = None
    if last is not None or (energies is not None and energies.shape[2] > 0) or \
            (gaps is not None and gaps.shape[2] > 0):
        asked = (np.zeros((0, 2)) if last is None else last,
                 np.zeros((nb, 2, 0)) if energies is None else energies,
                 np.zeros((nb, 1, 0)) if gaps is None else gaps)
    if ip.forced:
        gtab = p.f_amp * np.cos(p.f_omega * (t0 + 2.0 * p.hh * np.arange(n_steps + 1))
                                + p.f_phase)
    else:
        gtab = np.zeros(0)
    per = None
    if periodic is not None:
        per = tuple(periodic) + (np.zeros((1, 0)), np.zeros((1, 0, 0)))
        sample_every = 0
    run_blocks(_run_block, nb, (xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
                                mom, imp, xext, hH, hx, hy, hj, walls, speeds, law, extra,
                                asked, gtab, per), threads)


def normals_floor(rng, per_block, threads=None):
    """Draw ``per_block`` normals from each block's stream (the RNG's own rate).

    The same generator, the same blocking and the same thread-pool dispatch as
    :func:`advance`; returns the per-block sums (so nothing is optimised away).
    """
    return np.array(run_blocks(_floor_block, rng.shape[0], (rng, per_block), threads))
