"""The periodic response's sampling on the GPU: :func:`advance`, what
:meth:`._cuda_engine.Ensemble.advance` does with ``periodic=`` (issue 34).

The CPU's :func:`._kernel.advance` with ``periodic=(M, slot_of, step_slot, s_avg, mh,
xeh, pimp)`` samples each path at the grid points of the phases it needs and counts
the impacts of the steps in their phase bins; here one thread per path does the same
with the scalar step of :mod:`._scalar_step` (forcing included).  The number of sampled
rows depends on the phases, too many for registers, so each thread adds into its own
row of a scratch array in global memory (moments per instant slot, per harmonic point,
impact sums per step slot, the call's wall sums), then the rows are summed per block
in path order and the blocks per batch in block order (:func:`._cuda_kernels._fold_py`):
no float is added by an atomic, so one seed gives the same bits on the same GPU.
Histogram counts (whole numbers) and the x range (maxima) use atomics, exact in any
order.  A launch covers at most :data:`SCRATCH_DOUBLES` / (its row length) paths.

Not recorded on the GPU: ``xeh`` (the x range of the harmonic points' samples; the
periodic response does not use it) and the gaps between impacts.
"""
from __future__ import annotations

import numpy as np

from . import _cuda_kernels as CK
from ._sampling import NM

__all__ = ["advance"]

#: Scratch doubles of one launch at most (1 GiB).
SCRATCH_DOUBLES = 1 << 27
#: The per-thread wall sums: impacts, Σu, Σu², Σ loss (left, then right).
NWS = 8

_KERN: dict = {}
cuda = None          # numba.cuda, a module global (the simulator swaps globals only)


def _make(nbh, nbx, nby, njx, njy):
    """The periodic kernel and its block sum for these histogram sizes."""
    global cuda
    cuda = CK.cuda
    step = CK._step0
    forc = CK._forc
    normal2 = CK._normal2
    hidx = CK._hidx
    msample = CK._msample
    P = CK

    def hist(row, H, x, y, pf, hH, hx, hy, hj):
        oh = 0.0
        ox = 0.0
        oy = 0.0
        oj = 0.0
        if nbh > 0:
            k = hidx(H, pf[P.PH0], pf[P.PHIW], nbh)
            if k < 0:
                oh = 1.0
            else:
                cuda.atomic.add(hH, (row, k), 1.0)
        if nbx > 0:
            k = hidx(x, pf[P.PX0], pf[P.PXIW], nbx)
            if k < 0:
                ox = 1.0
            else:
                cuda.atomic.add(hx, (row, k), 1.0)
        if nby > 0:
            k = hidx(y, pf[P.PY0], pf[P.PYIW], nby)
            if k < 0:
                oy = 1.0
            else:
                cuda.atomic.add(hy, (row, k), 1.0)
        if njx > 0:
            kx = hidx(x, pf[P.PJX0], pf[P.PJXIW], njx)
            ky = hidx(y, pf[P.PJY0], pf[P.PJYIW], njy)
            if kx < 0 or ky < 0:
                oj = 1.0
            else:
                cuda.atomic.add(hj, (row, kx, ky), 1.0)
        return oh, ox, oy, oj

    hist = cuda.jit(device=True)(hist)

    def sample(scr, li, col, row, x, y, pf, hH, hx, hy, hj, xe, with_hist):
        """The state's moments into ``scr[li, col:col + NM]`` (and the histograms' row
        ``row`` with its x range, where ``with_hist``)."""
        a = pf[P.PA]
        bb = pf[P.PB]
        x2 = x * x
        H = 0.5 * y * y + x2 * (0.5 * a + 0.25 * bb * x2)
        oh = 0.0
        ox = 0.0
        oy = 0.0
        oj = 0.0
        if with_hist:
            oh, ox, oy, oj = hist(row, H, x, y, pf, hH, hx, hy, hj)
            cuda.atomic.max(xe, (row, 0), -x)
            cuda.atomic.max(xe, (row, 1), x)
        m = msample((0.0,) * NM, x, y, H, pf[P.PGD], oh, ox, oy, oj, 0.0)
        for c in range(NM):
            scr[li, col + c] += m[c]

    sample = cuda.jit(device=True)(sample)

    def kern(xs, ys, tls, wls, rs0, rs1, blk_b, blk_i, i0, n_steps, step0, t, pf, has_d2,
             maxk, kinds, par, tab_u, tab_r, tf, forced, M, slot_of, step_slot, s_avg, nb,
             n_inst, c_mh, c_imp, c_w, scr, ext, xe, hH, hx, hy, hj):
        blk = cuda.blockIdx.x
        b = blk_b[blk]
        i = blk_i[blk, 0] + cuda.threadIdx.x
        if i >= blk_i[blk, 1]:
            return
        li = i - i0
        a = pf[P.PA]
        bcub = pf[P.PB]
        hh = pf[P.PHH]
        famp = pf[P.PFA]
        fom = pf[P.PFO]
        fph = pf[P.PFP]
        x = xs[i]
        y = ys[i]
        f = -(a + bcub * x * x) * x
        tl = tls[i]
        wl = int(wls[i])
        s0 = rs0[i]
        s1 = rs1[i]
        rec = (scr, scr, scr, scr, (0.0,) * 6)         # never read (no counting)
        g1 = -0.0
        if forced:
            g1 = forc(famp, fom, fph, tf, hh, 0)
        z2 = 0.0
        umax = 0.0
        for k in range(n_steps):
            if k % 2 == 0:
                z, z2, s0, s1 = normal2(s0, s1)
            else:
                z = z2
            g0 = g1
            if forced:
                g1 = forc(famp, fom, fph, tf, hh, k + 1)
            (x, y, f, tl, wl, nl, nr, ul, ur, ql, qr, el, er, um, xm, ym) = step(
                x, y, f, z, hh, pf[P.PEC], pf[P.PSD0], pf[P.PD1S2], pf[P.PD2S2], a, bcub,
                pf[P.PLO], pf[P.PHI], pf[P.PFLO], pf[P.PFHI], kinds, par, tab_u, tab_r,
                has_d2, maxk, t + k * 2.0 * hh, tl, wl, rec, g0, g1)
            gk = (step0 + k) % M
            if nl + nr > 0:
                umax = max(umax, um)
                sums = (float(nl), ul, ql, el, float(nr), ur, qr, er)
                for c in range(NWS):
                    scr[li, c_w + c] += sums[c]
                ss = step_slot[gk]
                if ss >= 0:
                    for c in range(NWS):
                        scr[li, c_imp + ss * NWS + c] += sums[c]
            gm1 = (gk + 1) % M
            ss = slot_of[gm1]
            if ss >= 0:
                sample(scr, li, ss * NM, ss * nb + b, x, y, pf, hH, hx, hy, hj, xe, True)
            if gm1 % s_avg == 0:
                sample(scr, li, n_inst * NM, n_inst * nb + b, x, y, pf, hH, hx, hy, hj, xe,
                       True)
                sample(scr, li, c_mh + (gm1 // s_avg) * NM, 0, x, y, pf, hH, hx, hy, hj,
                       xe, False)
        xs[i] = x
        ys[i] = y
        tls[i] = tl
        wls[i] = wl
        rs0[i] = s0
        rs1[i] = s1
        if umax > 0.0:
            cuda.atomic.max(ext, (b, 0), umax)

    def block_sum(scr, blk_i, i0, part):
        """Thread (block, q): ``part[block, q]`` = Σ ``scr[i − i0, q]`` over the block's
        paths, in path order."""
        t_ = cuda.grid(1)
        Q = scr.shape[1]
        if t_ < part.shape[0] * Q:
            blk = t_ // Q
            q = t_ % Q
            sm = 0.0
            for i in range(blk_i[blk, 0], blk_i[blk, 1]):
                sm += scr[i - i0, q]
            part[blk, q] = sm

    return cuda.jit(kern), cuda.jit(block_sum)


def _kernels(hH, hx, hy, hj):
    CK.kernels()
    key = (hH.shape[1], hx.shape[1], hy.shape[1], hj.shape[1],
           hj.shape[2] if hj.shape[1] > 0 else 0)
    if key not in _KERN:
        _KERN[key] = _make(*key)
    return _KERN[key]


def advance(ens, xs, ys, starts, n_steps, step0, p, ip, mom, imp, xext, hH, hx, hy, hj,
            walls, extra, t0, periodic) -> None:
    """:func:`._kernel.advance` with ``periodic=`` on the GPU (module docstring): the
    same per-row sums into the same arrays (``walls`` [nb, 2, ≥3], ``extra`` [nb, 2,
    NX]: X_E and X_M; ``xeh`` left as it is)."""
    from . import _setup as S
    from ._cuda_launch import _Deferred, _flat, _tpb, block_map
    from ._flight import X_E, X_M
    M, slot_of, step_slot, s_avg, mh, xeh, pimp = periodic
    nc = ens.K.cuda
    nb = imp.shape[0]
    starts = S.block_starts(ens.n, nb) if starts is None else np.asarray(starts)
    n_inst = mom.shape[0] // nb - 1
    n_h = mh.shape[0] // nb
    n_s = pimp.shape[0] // nb
    c_mh = (n_inst + 1) * NM
    c_imp = c_mh + n_h * NM
    c_w = c_imp + n_s * NWS
    Q = c_w + NWS
    kern, bsum = _kernels(hH, hx, hy, hj)
    tpb = _tpb()
    per_launch = max(tpb, min(ens.n, SCRATCH_DOUBLES // Q) // tpb * tpb)
    pf = nc.to_device(_flat(p))
    dslot, dstep = nc.to_device(np.asarray(slot_of)), nc.to_device(np.asarray(step_slot))
    dh = [nc.to_device(np.zeros_like(h)) for h in (hH, hx, hy, hj)]
    xe = nc.to_device(np.full((mom.shape[0], 2), -np.inf))
    ext = nc.to_device(np.full((nb, 1), -np.inf))
    sums = nc.to_device(np.zeros((nb, Q)))
    forced = bool(getattr(ip, "forced", 0))
    state = (ens.x, ens.y, ens.tl, ens.wl, ens.s0, ens.s1)
    for i0 in range(0, ens.n, per_launch):
        i1 = min(ens.n, i0 + per_launch)
        blk_b, blk_i, bstart = (nc.to_device(a) for a in block_map(starts, i0, i1, tpb))
        nblk = blk_b.size
        if nblk == 0:
            continue
        scr = nc.to_device(np.zeros((i1 - i0, Q)))
        part = nc.device_array((nblk, Q))
        with _Deferred():
            kern[nblk, tpb](*state, blk_b, blk_i, i0, n_steps, step0, ens.t, pf,
                            int(ip.has_d2), int(ip.max_impacts), *ens.walls, float(t0),
                            forced, int(M), dslot, dstep, int(s_avg), nb, n_inst, c_mh,
                            c_imp, c_w, scr, ext, xe, *dh)
            bsum[(nblk * Q + 127) // 128, 128](scr, blk_i, i0, part)
            CK.kernels().fold[(nb * Q + 127) // 128, 128](part, bstart, sums)
        nc.synchronize()
    ens.t += n_steps * 2.0 * p.hh
    s = sums.copy_to_host()
    for sl in range(n_inst + 1):
        mom[sl * nb:(sl + 1) * nb] += s[:, sl * NM:(sl + 1) * NM]
    for g in range(n_h):
        mh[g * nb:(g + 1) * nb] += s[:, c_mh + g * NM:c_mh + (g + 1) * NM]
    counts = np.diff(starts).astype(float)
    ks = (step0 + np.arange(n_steps)) % M
    for sl in range(n_s):
        w = s[:, c_imp + sl * NWS:c_imp + (sl + 1) * NWS]
        rows = pimp[sl * nb:(sl + 1) * nb]
        for side in (0, 1):
            rows[:, side, :4] += w[:, 4 * side:4 * side + 4]
        rows[:, 0, 4] += counts * float(np.count_nonzero(np.asarray(step_slot)[ks] == sl))
    w = s[:, c_w:c_w + NWS]
    imp[:, 0] += w[:, 0] + w[:, 4]
    imp[:, 1] += counts * n_steps
    nw = min(walls.shape[2], 3) if walls is not None else 0
    for side in (0, 1):
        if nw:
            walls[:, side, :nw] += w[:, 4 * side:4 * side + nw]
        if extra is not None:
            extra[:, side, X_E] += w[:, 4 * side + 3]
    if extra is not None:
        extra[:, 0, X_M] = np.maximum(extra[:, 0, X_M], ext.copy_to_host()[:, 0])
    e = xe.copy_to_host()
    xext[:, 0] = np.minimum(xext[:, 0], -e[:, 0])
    xext[:, 1] = np.maximum(xext[:, 1], e[:, 1])
    for h, d in zip((hH, hx, hy, hj), dh):
        h += d.copy_to_host()
    xs[:] = ens.x.copy_to_host()
    ys[:] = ens.y.copy_to_host()
