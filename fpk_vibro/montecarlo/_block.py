"""One block of paths advanced by the CPU engine (compiled ``nogil``, numba):
:func:`_run_block`, run on the thread pool by :func:`._kernel.advance`."""
from __future__ import annotations

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from ._flight import LEFT, RIGHT, W_N, W_Q, W_U, X_E, X_M, _flight
from ._rng import FASTMATH, _normal
from ._sampling import NM, _sample
from ._sweep import CHUNK, _smooth_sweep, _step_core, _step_full


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def _run_block(b, xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
               mom, imp, xext, hH, hx, hy, hj, wimp, speeds, law, extra, asked, gtab, per,
               zeta):
    """Block b of :func:`._kernel.advance` (compiled without the GIL; ``advance``
    runs the blocks on a thread pool).

    The block's paths are advanced CHUNK at a time; each step draws the chunk's
    normals from the block's stream (in path order), advances every path by the
    vectorised :func:`._sweep._smooth_sweep`, then redoes the few paths it flagged
    (a wall crossed, ~2 % of path-steps in the paper's case) with the scalar
    :func:`._sweep._step_core`.  Impact statistics are summed in locals and added to
    ``imp[b]`` and ``wimp[b]`` once, at the end; impact speeds go to ``speeds[b]``
    (a histogram per wall, :mod:`._flight`; no column: not kept).  ``law``: the
    walls' restitution packed (:func:`._params.wall_laws`); the energy the impacts
    remove and the largest speed go to ``extra[b]``.  ``asked``: None, or (last,
    energies, gaps) (``advance``): the impact energies into ``energies[b]`` and,
    where ``last`` has a row per path (each path's last impact: time relative to this
    call's start on entry, to its end on return, and wall), the gaps between impacts
    into ``extra[b]`` and ``gaps[b]`` (:mod:`._flight`).

    ``gtab`` (``ip.forced``): the harmonic force at the call's step times, g_k at
    t0 + k h (k = 0..n_steps).  The merged kick of step k (the closing kick of step
    k − 1 and the opening kick of step k, both at t_k) adds h g_k to every path; the
    stored v is y − (h/2)(F(x) + g) at the state's time.  ``per``: None, or the
    periodic sampling tables of ``advance``.

    ``zeta`` (``ip.coloured``; empty: white noise): each path's coloured force ζ, the
    same role with a value per path: step k kicks with g = κ ζ_k (opening kick, first
    flight's wall force) and κ ζ_{k+1}, ζ_{k+1} = e^{−h/τ} ζ_k + s ξ (second flight,
    closing kick; κ = ``p.z_k``, :func:`._params.kick_gain`), ξ drawn per step after
    the normals of the y noise (drawn only with D2 > 0: the O step's y noise is the
    parametric one alone); the stored v is y − (h/2)(F(x) + κ ζ).  The samples add
    Σζ² and Σζy (:func:`._sampling._sample`).
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
    col = zeta.shape[0] > 0
    ze = p.z_e
    zsd = p.z_s
    kz = p.z_k
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
    z = np.zeros(CHUNK)             # coloured without D2: no y noise, z stays 0
    zc = np.empty(CHUNK)            # ζ of the chunk's paths at the state's time
    zn = np.empty(CHUNK)            # and after the step
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
            if col:
                zc[j] = zeta[i0 + j]
                va[j] -= hh * (kz * zc[j])
        cnt = sample_every - step0 % sample_every if sample_every > 0 else -1
        for k in range(n_steps):
            if has_d2 or not col:
                for j in range(n):
                    z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
            vin = va
            if col:
                for j in range(n):
                    zn[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                for j in range(n):
                    vk[j] = va[j] + h * (kz * zc[j])
                    zn[j] = ze * zc[j] + zsd * zn[j]
                vin = vk
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
                elif col:
                    flo2 = flo + kz * zn[j]
                    fhi2 = fhi + kz * zn[j]
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
                elif col:
                    g0 = kz * zc[j]
                    g1 = kz * zn[j]
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
            if col:
                zc, zn = zn, zc
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
                    elif col:
                        for j in range(n):
                            vk[j] = va[j] + hh * (kz * zc[j])
                        _sample(xa, vk, n, hh, p, b, mom, xext, hH, hx, hy, hj, zc)
                    else:
                        _sample(xa, va, n, hh, p, b, mom, xext, hH, hx, hy, hj)
        for j in range(n):
            x = xa[j]
            xs[i0 + j] = x
            ys[i0 + j] = va[j] - hh * (a + bcub * x * x) * x      # y = v + (h/2) F(x)
            if forced:
                ys[i0 + j] += hh * gtab[n_steps]
            if col:
                ys[i0 + j] += hh * (kz * zc[j])
                zeta[i0 + j] = zc[j]
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
