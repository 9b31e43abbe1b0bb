"""The GPU kernels of the Monte Carlo engine (numba-cuda; compiled on first use).

One thread per path, float64.  Each thread keeps its path's state, its xoroshiro128+
stream (:mod:`._cuda_rng`) and its sums in registers (tuples), and advances by the
scalar step of :mod:`._scalar_step` (the very functions the CPU reference compiles).

Every block holds paths of one batch only (:func:`._cuda_engine.block_map`: a
batch's last block may have idle threads), so:

- **sums** (moments, wall sums, gap sums; :data:`NSUM` per path) are reduced within
  the block in a fixed order (each of ``RW`` threads adds a column over the block's
  threads, thread 0 first) into the block's own row ``part[block]``; then
  :func:`_fold_py` adds a batch's rows, block by block in index order, into its
  per-batch sums.  No float is added by an atomic, so the rounding order is fixed by
  the launch geometry alone, and one seed gives bit-identical numbers on the same
  GPU model (the same compiled code: a different GPU or numba-cuda may contract
  other multiply-adds);
- **histograms** are counts: uint32 in the block's shared memory, then float64
  atomics of whole numbers into the per-batch arrays, exact in any order (below 2⁵³);
- **maxima** (x range, largest impact speed, longest gap) by atomic max, exact.

Path i belongs to batch b with ``starts[b] <= i < starts[b + 1]`` as on the CPU
(:func:`._setup.block_starts`).

The stationary kernel is specialised at compile time (:func:`stationary`): with or
without the paired 2h path, the histogram sizes, with or without impact-speed and
inter-impact histograms; a plain moments run carries none of the others' registers.
The module's functions are plain Python compiled on first use, so importing this
module needs no GPU and no numba-cuda.
"""
from __future__ import annotations

import math

import numpy as np

from ._params import StepParams
from ._sampling import (M_H, M_N, M_OVH, M_OVJ, M_OVX, M_OVY, M_PIMP, M_X, M_X2, M_X4,
                        M_Y2, M_Y4, NM, _hist_index)

# positions of the StepParams fields in the float array the kernels take
_F = {name: i for i, name in enumerate(StepParams._fields)}
PA, PB, PHH, PEC, PSD0, PD1S2, PD2S2, PLO, PHI, PGD = (
    _F[k] for k in ("a", "b", "hh", "ec", "sd0", "d1s2", "d2s2", "lo", "hi", "barrier_energy"))
PH0, PHIW, PX0, PXIW, PY0, PYIW, PJX0, PJXIW, PJY0, PJYIW = (
    _F[k] for k in ("h0", "h_iw", "x0", "x_iw", "y0", "y_iw", "jx0", "jx_iw", "jy0", "jy_iw"))
PFLO, PFHI, PUWL, PUWR = (_F[k] for k in ("f_lo", "f_hi", "u_iw_left", "u_iw_right"))
PFA, PFO, PFP = (_F[k] for k in ("f_amp", "f_omega", "f_phase"))
PZE, PZS, PZK = (_F[k] for k in ("z_e", "z_s", "z_k"))


#: Histogram cells per block in shared memory at most (uint32 counts of one batch).
SHARED_CELLS = 2048
#: Threads per block at most (the block reduction's shared array), a power of two.
TPB_MAX = 256
#: Sums reduced per pass of the block reduction.
RW = 8
#: The per-thread sums of a path, in this order: the NM (14) moment columns ``M_*``,
#: the 8 wall sums (impacts, Σu, Σu², Σ loss; left then right) and the 10 gap sums
#: (X_GL, X_TL, X_GR, X_TR, X_G0; left then right).
NSUM = NM + 18
#: Per-batch maxima (atomic max: exact in any order): −min x, max x, largest impact
#: speed, longest gap ending on the left, on the right wall.
NEXT = 5
#: First-passage constants (:mod:`._cuda_fp`), kept here for the engine.
from ._cuda_fp import BRIDGE_CUT, FP_DISPLACEMENT, FP_ENERGY, FP_SPEED, NFP  # noqa: E402
from ._flight import X_G0, X_GL, X_GM, X_GR, X_TL, X_TR  # noqa: E402

cuda = None          # numba.cuda and the compiled device functions (set by _base())
_step = None         # the step counting impact records
_step0 = None        # the step without them
_normal2 = None
_hidx = None
_forc = None         # the harmonic force at a step (:func:`._scalar_step.forcing_at`)
_FP = None           # the device build of :mod:`._cuda_fp`
_seed = None
_K = None
_STAT = {}


def _batch(i, n, nb):
    return ((i + 1) * nb - 1) // n


def _add2(h, i, k, w):
    cuda.atomic.add(h, (i, k), w)


def _add1(h, k, w):
    cuda.atomic.add(h, k, w)


def _msample(m, x, y, H, gd, oh, ox, oy, oj, zt):
    """The moment sums m (the ``M_*`` columns) with the state (x, y) added; ``zt``
    the path's coloured force ζ (0 for white noise)."""
    x2 = x * x
    y2 = y * y
    return (m[0] + 1.0, m[1] + H, m[2] + x2, m[3] + y2, m[4] + x2 * x2, m[5] + y2 * y2,
            m[6] + (1.0 if H > gd else 0.0), m[7] + oh, m[8] + ox, m[9] + oy, m[10] + oj,
            m[11] + x, m[12] + zt * zt, m[13] + zt * y)


def _wadd(w, nl, nr, ul, ur, ql, qr, el, er):
    return (w[0] + float(nl), w[1] + ul, w[2] + ql, w[3] + el, w[4] + float(nr), w[5] + ur,
            w[6] + qr, w[7] + er)


def _gsums(acc):
    """The 10 gap sums of a thread's ``acc`` (:data:`NSUM`)."""
    return (acc[0, X_GL], acc[0, X_TL], acc[0, X_GR], acc[0, X_TR], acc[0, X_G0],
            acc[1, X_GL], acc[1, X_TL], acc[1, X_GR], acc[1, X_TR], acc[1, X_G0])


def _maxima(ext, b, xmin, xmax, um, acc):
    """The thread's maxima into its batch's row of ``ext`` (:data:`NEXT`)."""
    if xmin <= xmax:
        cuda.atomic.max(ext, (b, 0), -xmin)
        cuda.atomic.max(ext, (b, 1), xmax)
    if um > 0.0:
        cuda.atomic.max(ext, (b, 2), um)
    if acc[0, X_GM] > 0.0:
        cuda.atomic.max(ext, (b, 3), acc[0, X_GM])
    if acc[1, X_GM] > 0.0:
        cuda.atomic.max(ext, (b, 4), acc[1, X_GM])


def _fold_py(part, bstart, sums):
    """Thread (b, q): ``sums[b, q]`` += Σ ``part[k, q]`` over batch b's blocks
    k = bstart[b] .. bstart[b + 1] − 1, in that order (no atomics)."""
    t = cuda.grid(1)
    K = sums.shape[1]
    if t < sums.shape[0] * K:
        b = t // K
        q = t % K
        s = sums[b, q]
        for k in range(bstart[b], bstart[b + 1]):
            s += part[k, q]
        sums[b, q] = s


def _make_stationary(paired, nbh, nbx, nby, njx, njy, wh, shared, forced=False,
                     coloured=False):
    """The stationary kernel for one configuration (module docstring); ``forced``:
    the kicks add the harmonic force (:func:`._scalar_step.forcing_at`, step k of the
    call at t0 + 2 hh (kf0 + k)), else −0.0 (the unforced step bit for bit);
    ``coloured``: the kicks add each path's κ ζ (``zts``; κ = ``z_k``), ζ_k in the
    step's first half and ζ_{k+1} = e^{−h/τ} ζ_k + s ξ' in its second
    (:mod:`._kernel`), ξ' a normal of the path's stream: with D2 > 0 the second of
    the step's pair (the first drives the parametric noise), else one normal a step
    as the white noise's; the samples add Σζ² and Σζy (:func:`_msample`)."""
    step = _step if wh else _step0
    forc = _forc
    normal2 = _normal2
    hidx = _hidx
    msample = _msample
    wadd = _wadd
    gsums = _gsums
    maxima = _maxima
    tot = nbh + nbx + nby + njx * njy
    ox_, oy_, oj_ = nbh, nbh + nbx, nbh + nbx + nby
    shn = tot if shared and tot > 0 else 1
    ks = 2 * NSUM if paired else NSUM
    u32 = np.uint32
    f64 = np.float64
    zm = (0.0,) * NM
    z8 = (0.0,) * 8

    def hist(sh, loc, b, H, x, y, pf, hH, hx, hy, hj):
        """Count (x, y) in the histograms; (overflows of H, x, y, joint)."""
        oh = 0.0
        ox = 0.0
        oy = 0.0
        oj = 0.0
        if nbh > 0:
            k = hidx(H, pf[PH0], pf[PHIW], nbh)
            if k < 0:
                oh = 1.0
            elif loc:
                cuda.atomic.add(sh, k, u32(1))
            else:
                cuda.atomic.add(hH, (b, k), 1.0)
        if nbx > 0:
            k = hidx(x, pf[PX0], pf[PXIW], nbx)
            if k < 0:
                ox = 1.0
            elif loc:
                cuda.atomic.add(sh, ox_ + k, u32(1))
            else:
                cuda.atomic.add(hx, (b, k), 1.0)
        if nby > 0:
            k = hidx(y, pf[PY0], pf[PYIW], nby)
            if k < 0:
                oy = 1.0
            elif loc:
                cuda.atomic.add(sh, oy_ + k, u32(1))
            else:
                cuda.atomic.add(hy, (b, k), 1.0)
        if njx > 0:
            kx = hidx(x, pf[PJX0], pf[PJXIW], njx)
            ky = hidx(y, pf[PJY0], pf[PJYIW], njy)
            if kx < 0 or ky < 0:
                oj = 1.0
            elif loc:
                cuda.atomic.add(sh, oj_ + kx * njy + ky, u32(1))
            else:
                cuda.atomic.add(hj, (b, kx, ky), 1.0)
        return oh, ox, oy, oj

    hist = cuda.jit(device=True)(hist)

    def energy(x, y, a, bb):
        x2 = x * x
        return 0.5 * y * y + x2 * (0.5 * a + 0.25 * bb * x2)

    energy = cuda.jit(device=True)(energy)

    def kern(xs, ys, tls, wls, rs0, rs1, xcs, ycs, tlcs, wlcs, blk_b, blk_i, n_steps,
             step0, sample_every, t0, pf, pf2, has_d2, maxk, kinds, par, tab_u, tab_r, iwa,
             part, ext, hH, hx, hy, hj, hu, he, hg, ext2, hH2, hx2, hy2, hj2, hu2, he2, hg2,
             famp, fom, fph, tf, kf0, zts):
        blk = cuda.blockIdx.x
        tid = cuda.threadIdx.x
        bd = cuda.blockDim.x
        b = blk_b[blk]
        i = blk_i[blk, 0] + tid
        sh = cuda.shared.array(shn, dtype=u32)
        red = cuda.shared.array((RW, TPB_MAX), dtype=f64)
        acc = cuda.local.array((2, 8), dtype=f64)
        acc2 = cuda.local.array((2, 8), dtype=f64)
        for c in range(8):
            acc[0, c] = 0.0
            acc[1, c] = 0.0
            acc2[0, c] = 0.0
            acc2[1, c] = 0.0
        if shared and tot > 0:
            for c in range(tid, shn, bd):
                sh[c] = u32(0)
            cuda.syncthreads()
        m = zm
        w = z8
        m2 = zm
        w2 = z8
        if i < blk_i[blk, 1]:
            a = pf[PA]
            bcub = pf[PB]
            hh = pf[PHH]
            ec = pf[PEC]
            sd0 = pf[PSD0]
            d1s2 = pf[PD1S2]
            d2s2 = pf[PD2S2]
            lo = pf[PLO]
            hi = pf[PHI]
            flo = pf[PFLO]
            fhi = pf[PFHI]
            gd = pf[PGD]
            iw = (iwa[0], iwa[1], iwa[2], iwa[3], iwa[4], iwa[5])
            bw = b if wh else 0
            rec = (hu[bw], he[bw], hg[bw, 0], acc, iw)
            rec2 = (hu2[bw], he2[bw], hg2[bw, 0], acc2, iw)
            x = xs[i]
            y = ys[i]
            f = -(a + bcub * x * x) * x
            tl = tls[i]
            wl = int(wls[i])
            s0 = rs0[i]
            s1 = rs1[i]
            xmin = math.inf
            xmax = -math.inf
            umax = 0.0
            xc = 0.0
            yc = 0.0
            fc = 0.0
            tlc = -1.0
            wlc = 0
            xmin2 = math.inf
            xmax2 = -math.inf
            umax2 = 0.0
            cz = 0.0
            cz2 = 0.0
            if paired:
                xc = xcs[i]
                yc = ycs[i]
                fc = -(a + bcub * xc * xc) * xc
                tlc = tlcs[i]
                wlc = int(wlcs[i])
                cz = ec / math.sqrt(1.0 + ec * ec)
                cz2 = 1.0 / math.sqrt(1.0 + ec * ec)
            t = t0
            cnt = sample_every - step0 % sample_every if sample_every > 0 else -1
            z2 = 0.0
            zprev = 0.0
            g0 = -0.0
            g1 = -0.0
            gp = -0.0
            zt = 0.0
            zx = 0.0
            ze = pf[PZE]
            zsd = pf[PZS]
            kz = pf[PZK]
            if forced:
                g1 = forc(famp, fom, fph, tf, hh, kf0)
            if coloured:
                zt = zts[i]
            for k in range(n_steps):
                if coloured and has_d2:
                    z, zx, s0, s1 = normal2(s0, s1)
                elif k % 2 == 0:
                    z, z2, s0, s1 = normal2(s0, s1)
                else:
                    z = z2
                if coloured:
                    if not has_d2:
                        zx = z
                        z = 0.0
                    g0 = kz * zt
                    zt = ze * zt + zsd * zx
                    g1 = kz * zt
                if forced:
                    gp = g0
                    g0 = g1
                    g1 = forc(famp, fom, fph, tf, hh, kf0 + k + 1)
                (x, y, f, tl, wl, nl, nr, ul, ur, ql, qr, el, er, um, xm, ym) = step(
                    x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, kinds, par,
                    tab_u, tab_r, has_d2, maxk, t, tl, wl, rec, g0, g1)
                if nl + nr > 0:
                    w = wadd(w, nl, nr, ul, ur, ql, qr, el, er)
                    umax = max(umax, um)
                if paired:
                    if k % 2 == 1:
                        zc = cz * zprev + cz2 * z
                        (xc, yc, fc, tlc, wlc, nl, nr, ul, ur, ql, qr, el, er, um, xm,
                         ym) = step(xc, yc, fc, zc, pf2[PHH], pf2[PEC], pf2[PSD0], pf2[PD1S2],
                                    pf2[PD2S2], a, bcub, lo, hi, flo, fhi, kinds, par, tab_u,
                                    tab_r, has_d2, maxk, t - hh * 2.0, tlc, wlc, rec2, gp,
                                    g1)
                        if nl + nr > 0:
                            w2 = wadd(w2, nl, nr, ul, ur, ql, qr, el, er)
                            umax2 = max(umax2, um)
                    zprev = z
                t += 2.0 * hh
                cnt -= 1
                if cnt == 0:
                    cnt = sample_every
                    H = energy(x, y, a, bcub)
                    oh, ox, oy, oj = hist(sh, shared, b, H, x, y, pf, hH, hx, hy, hj)
                    m = msample(m, x, y, H, gd, oh, ox, oy, oj, zt)
                    xmin = min(xmin, x)
                    xmax = max(xmax, x)
                    if paired:
                        H = energy(xc, yc, a, bcub)
                        oh, ox, oy, oj = hist(sh, False, b, H, xc, yc, pf, hH2, hx2, hy2,
                                              hj2)
                        m2 = msample(m2, xc, yc, H, gd, oh, ox, oy, oj, 0.0)
                        xmin2 = min(xmin2, xc)
                        xmax2 = max(xmax2, xc)
            xs[i] = x
            ys[i] = y
            tls[i] = tl
            wls[i] = wl
            rs0[i] = s0
            rs1[i] = s1
            if coloured:
                zts[i] = zt
            maxima(ext, b, xmin, xmax, umax, acc)
            if paired:
                xcs[i] = xc
                ycs[i] = yc
                tlcs[i] = tlc
                wlcs[i] = wlc
                maxima(ext2, b, xmin2, xmax2, umax2, acc2)
        # the block's sums in a fixed order (idle threads add zeros): deterministic
        if paired:
            vals = m + w + gsums(acc) + m2 + w2 + gsums(acc2)
        else:
            vals = m + w + gsums(acc)
        for q0 in range(0, ks, RW):
            for r in range(RW):
                if q0 + r < ks:
                    red[r, tid] = vals[q0 + r]
            cuda.syncthreads()
            if tid < RW and q0 + tid < ks:
                sm = 0.0
                for c in range(bd):
                    sm += red[tid, c]
                part[blk, q0 + tid] = sm
            cuda.syncthreads()
        if shared and tot > 0:
            for c in range(tid, shn, bd):
                v = sh[c]
                if v != u32(0):
                    if c < ox_:
                        cuda.atomic.add(hH, (b, c), float(v))
                    elif c < oy_:
                        cuda.atomic.add(hx, (b, c - ox_), float(v))
                    elif c < oj_:
                        cuda.atomic.add(hy, (b, c - oy_), float(v))
                    else:
                        q = c - oj_
                        cuda.atomic.add(hj, (b, q // njy, q % njy), float(v))

    return cuda.jit(kern)


def stationary(paired, track, hH, hx, hy, hj, hu, he, hg, hists2=(), forced=False,
               coloured=False):
    """The stationary kernel for these arrays' sizes (compiled once per configuration);
    ``track``: the gaps between impacts are recorded; ``forced``: harmonic forcing;
    ``coloured``: coloured external noise (not with ``paired``)."""
    if paired and coloured:
        raise ValueError("the paired kernel takes white external noise only")
    _base()
    nbh, nbx, nby = hH.shape[1], hx.shape[1], hy.shape[1]
    njx, njy = hj.shape[1], (hj.shape[2] if hj.shape[1] > 0 else 0)
    wh = bool(track) or any(h.shape[-1] > 0 for h in (hu, he, hg))
    if paired:
        wh = wh or any(h.shape[-1] > 0 for h in hists2[4:])
        if tuple(h.shape[1:] for h in hists2[:4]) != tuple(
                h.shape[1:] for h in (hH, hx, hy, hj)):
            raise ValueError("the paired kernel takes the 2h path's histograms only with "
                             "the same sizes as the fine path's")
    tot = nbh + nbx + nby + njx * njy
    shared = 0 < tot <= SHARED_CELLS
    key = (bool(paired), nbh, nbx, nby, njx, njy, bool(wh), shared, bool(forced),
           bool(coloured))
    if key not in _STAT:
        _STAT[key] = _make_stationary(*key)
    return _STAT[key]


def _given_py(xs, ys, tls, wls, zs, t0, pf, has_d2, maxk, kinds, par, tab_u, tab_r, out,
              hu, he, hg, accs, iwa, forced):
    """Thread j: the steps of path j with the given normals ``zs[k, j]`` (the tests'
    comparison with the CPU); ``out[j]`` += impacts and Σu, Σu², loss per wall, its
    gap records in ``accs[j]``."""
    j = cuda.grid(1)
    if j >= xs.shape[0]:
        return
    a = pf[PA]
    bcub = pf[PB]
    hh = pf[PHH]
    x = xs[j]
    y = ys[j]
    tl = tls[j]
    wl = int(wls[j])
    f = -(a + bcub * x * x) * x
    t = t0
    rec = (hu, he, hg, accs[j], (iwa[0], iwa[1], iwa[2], iwa[3], iwa[4], iwa[5]))
    for k in range(zs.shape[0]):
        g0 = -0.0
        g1 = -0.0
        if forced:
            g0 = _forc(pf[PFA], pf[PFO], pf[PFP], t0, hh, k)
            g1 = _forc(pf[PFA], pf[PFO], pf[PFP], t0, hh, k + 1)
        (x, y, f, tl, wl, nl, nr, ul, ur, ql, qr, el, er, um, xm, ym) = _step(
            x, y, f, zs[k, j], hh, pf[PEC], pf[PSD0], pf[PD1S2], pf[PD2S2], a, bcub,
            pf[PLO], pf[PHI], pf[PFLO], pf[PFHI], kinds, par, tab_u, tab_r, has_d2, maxk,
            t, tl, wl, rec, g0, g1)
        t += 2.0 * hh
        out[j, 0] += nl
        out[j, 1] += ul
        out[j, 2] += ql
        out[j, 3] += el
        out[j, 4] += nr
        out[j, 5] += ur
        out[j, 6] += qr
        out[j, 7] += er
    xs[j] = x
    ys[j] = y
    tls[j] = tl
    wls[j] = wl


def _seed_py(rs0, rs1, sd, i0):
    """Thread j: the state of stream i0 + j of seed ``sd`` (:func:`._cuda_rng.seed_py`)."""
    j = cuda.grid(1)
    if j < rs0.shape[0]:
        a, b = _seed(sd, i0 + j)
        rs0[j] = a
        rs1[j] = b


def _base():
    """Compile the device functions (once)."""
    global cuda, _step, _step0, _normal2, _hidx, _FP, _seed, _forc
    if _FP is not None:
        return
    from . import _cuda_fp, _cuda_rng, _device, _scalar_step
    nc = _device.cuda()
    dev = nc.jit(device=True)
    cuda = nc
    S = _scalar_step.build(dev, dev(_add2), dev(_add1))
    S0 = _scalar_step.build(dev, dev(_add2), dev(_add1), counting=False)
    sincospi = None
    if not _device.simulator():
        from numba.cuda import libdevice
        sincospi = libdevice.sincospi
    R = _cuda_rng.build(dev, sincospi)
    _step, _step0, _normal2, _seed = S.step, S0.step, R.normal2, R.seed
    _hidx = dev(_hist_index.py_func)
    _forc = dev(_scalar_step.forcing_at)
    g = globals()
    for name in ("_batch", "_msample", "_wadd", "_gsums", "_maxima"):
        g[name] = dev(g[name])
    _FP = _cuda_fp.build(dev, S0.step, R.normal2, R.uniform, R.seed, S0.restitution)


def kernels():
    """The compiled kernels that do not depend on a configuration (a namespace):
    ``given`` and ``first_passage``; :func:`stationary` for the others."""
    global _K
    if _K is not None:
        return _K
    from . import _cuda_fp
    _base()

    class NS:
        pass

    ns = NS()
    ns.cuda = cuda
    ns.given = cuda.jit(_given_py)
    ns.seed = cuda.jit(_seed_py)
    ns.first_passage, ns.fp_fold = _cuda_fp.kernel(cuda, _FP)
    ns.fold = cuda.jit(_fold_py)
    ns.stationary = stationary
    _K = ns
    return ns
