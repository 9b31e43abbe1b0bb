"""The GPU counterpart of :func:`._paths_kernel.paths_block` (numba-cuda; compiled on
first use): one thread per path, the scalar step of :mod:`._scalar_step` (the
functions the CPU reference compiles), the normals and ζ as the stationary kernel
draws them (:mod:`._cuda_kernels`), the counting of :mod:`._paths_kernel` (its
``visit`` and ``touches`` compiled for the device).

The step returns its midpoint x_m (after the first free flight) and the velocity
after the O kick, so each flight's impacts are told apart by the flight's own test
(does x + (h/2) v leave the strip?): the vertices are x₀, [walls of the first flight],
x_m, [walls of the second], x₁ (where both flights hit, the first is given one touch:
the wall it moves to).  Counts of a thread are kept in a local array of
``2 L + 2`` whole numbers (``L`` ≤ :data:`MAX_LEVELS`) and added once per launch to its
batch's row by float atomics of whole numbers, exact in any order; samples go to the
thread's own row.  So one seed gives the same numbers on one GPU model.
"""
from __future__ import annotations

import numpy as np

from . import _cuda_kernels as CK
from ._cuda_launch import _flat, _tpb
from ._paths_kernel import build as build_counting

__all__ = ["GpuPaths", "MAX_LEVELS"]

#: Levels a GPU count takes at most (each thread holds 2 L + 2 counts).
MAX_LEVELS = 128
#: Path-steps per launch, about.
LAUNCH_PATH_STEPS = 1 << 32

_KERN: dict = {}
cuda = None          # numba.cuda, a module global so that the simulator can swap it


def _make(coloured: bool):
    global cuda
    cuda = CK.cuda
    step = CK._step0
    normal2 = CK._normal2
    visit, touches = build_counting(cuda.jit(device=True))
    nloc = 2 * MAX_LEVELS + 2
    f64 = np.float64
    PA, PB, PHH, PEC, PSD0, PD1S2, PD2S2, PLO, PHI, PFLO, PFHI, PZE, PZS, PZK = (
        CK.PA, CK.PB, CK.PHH, CK.PEC, CK.PSD0, CK.PD1S2, CK.PD2S2, CK.PLO, CK.PHI,
        CK.PFLO, CK.PFHI, CK.PZE, CK.PZS, CK.PZK)

    def kern(xs, ys, zts, rs0, rs1, n_steps, every, col0, pf, has_d2, maxk, kinds, par,
             tab_u, tab_r, outx, outy, with_y, lev, L, m, count, pst, cnt, wcnt, nb, lo_in,
             hi_in):
        i = cuda.grid(1)
        n = xs.shape[0]
        if i >= n:
            return
        b = ((i + 1) * nb - 1) // n
        loc = cuda.local.array(nloc, dtype=f64)
        for c in range(2 * L + 2):
            loc[c] = 0.0
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
        ze = pf[PZE]
        zsd = pf[PZS]
        kz = pf[PZK]
        x = xs[i]
        y = ys[i]
        f = -(a + bcub * x * x) * x
        s0 = rs0[i]
        s1 = rs1[i]
        zt = 0.0
        if coloured:
            zt = zts[i]
        idx = 0
        st = 0
        pmax = 0.0
        if count:
            idx = int(pst[i, 0])
            st = int(pst[i, 1])
            pmax = pst[i, 2]
        z2 = 0.0
        zx = 0.0
        g0 = -0.0
        g1 = -0.0
        nl_t = 0.0
        nr_t = 0.0
        cs = every
        col = col0
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
            free1 = x + hh * (y + hh * (f + g0))
            (x, y, f, _tl, _wl, nl, nr, _ul, _ur, _ql, _qr, _el, _er, _um, xm, ym) = step(
                x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, kinds, par,
                tab_u, tab_r, has_d2, maxk, 0.0, -1.0, 0, 0, g0, g1)
            nl_t += nl
            nr_t += nr
            if count:
                if nl + nr == 0:
                    idx, st, pmax = visit(xm, idx, st, pmax, lev, L, m, loc)
                else:
                    imp1 = not ((free1 >= lo) and (free1 <= hi))
                    free2 = xm + hh * ym
                    imp2 = not ((free2 >= lo) and (free2 <= hi))
                    r1 = 1 if free1 > hi else 0
                    r2 = 1 if ym > 0.0 else 0
                    if imp1 and imp2:
                        n1l = 0
                        n1r = 0
                        if (r1 == 1 and nr > 0) or nl == 0:
                            n1r = 1
                        else:
                            n1l = 1
                        idx, st, pmax = touches(n1l, n1r, r1, lo, hi, lo_in, hi_in, idx,
                                                st, pmax, lev, L, m, loc)
                        idx, st, pmax = visit(xm, idx, st, pmax, lev, L, m, loc)
                        idx, st, pmax = touches(nl - n1l, nr - n1r, r2, lo, hi, lo_in,
                                                hi_in, idx, st, pmax, lev, L, m, loc)
                    elif imp1:
                        idx, st, pmax = touches(nl, nr, r1, lo, hi, lo_in, hi_in, idx, st,
                                                pmax, lev, L, m, loc)
                        idx, st, pmax = visit(xm, idx, st, pmax, lev, L, m, loc)
                    else:
                        idx, st, pmax = visit(xm, idx, st, pmax, lev, L, m, loc)
                        idx, st, pmax = touches(nl, nr, r2, lo, hi, lo_in, hi_in, idx, st,
                                                pmax, lev, L, m, loc)
                idx, st, pmax = visit(x, idx, st, pmax, lev, L, m, loc)
            if every > 0:
                cs -= 1
                if cs == 0:
                    cs = every
                    outx[i, col] = x
                    if with_y:
                        outy[i, col] = y
                    col += 1
        xs[i] = x
        ys[i] = y
        rs0[i] = s0
        rs1[i] = s1
        if coloured:
            zts[i] = zt
        if count:
            pst[i, 0] = idx
            pst[i, 1] = st
            pst[i, 2] = pmax
            for c in range(2 * L + 2):
                if loc[c] != 0.0:
                    cuda.atomic.add(cnt, (b, c), loc[c])
        if nl_t != 0.0:
            cuda.atomic.add(wcnt, (b, 0), nl_t)
        if nr_t != 0.0:
            cuda.atomic.add(wcnt, (b, 1), nr_t)

    return cuda.jit(kern)


def kernel(coloured: bool):
    """The compiled kernel (once per ``coloured``)."""
    CK.kernels()
    key = bool(coloured)
    if key not in _KERN:
        _KERN[key] = _make(key)
    return _KERN[key]


class GpuPaths:
    """The device side of a :class:`._paths.Paths` whose paths live on the GPU (its
    :class:`._cuda_engine.Ensemble`): counting state and counts resident there."""

    def __init__(self, paths) -> None:
        self.paths = paths
        self.ens = paths.ens
        self.nc = CK.kernels().cuda
        nc = self.nc
        nb = paths.n_batches
        self.pf = nc.to_device(_flat(paths.p))
        self.lev = nc.to_device(np.zeros(1))          # (placeholders while not counting)
        self.L = 0
        self.count = False
        self.pst = nc.to_device(np.zeros((1, 5)))
        self.cnt = nc.to_device(np.zeros((nb, 2)))
        self.wcnt = nc.to_device(np.zeros((nb, 3)))
        self.kern = kernel(self.ens.coloured)

    def count_from_here(self, levels, mean_level, pst) -> None:
        if levels.size > MAX_LEVELS:
            raise ValueError(f"at most {MAX_LEVELS} levels on the GPU; got {levels.size}")
        nc = self.nc
        self.L = levels.size
        self.count = True
        self.lev = nc.to_device(levels if levels.size else np.zeros(1))
        self.pst = nc.to_device(np.ascontiguousarray(pst))
        self.cnt = nc.to_device(np.zeros((self.paths.n_batches, 2 * self.L + 2)))

    def reset_counts(self) -> None:
        nc = self.nc
        self.cnt = nc.to_device(np.zeros(self.cnt.shape))
        self.wcnt = nc.to_device(np.zeros(self.wcnt.shape))

    def advance(self, n_steps, every, outx, outy, cnt, wcnt) -> None:
        """As :meth:`._paths.Paths.advance`; ``cnt``, ``wcnt`` receive the totals since
        the last reset."""
        nc = self.nc
        P = self.paths
        ens = self.ens
        n = P.n_paths
        per = max(2, LAUNCH_PATH_STEPS // max(n, 1)) // 2 * 2
        if every > 0:
            per = max(every, per // every * every)
        dx = nc.device_array(outx.shape) if outx.size else nc.to_device(np.zeros((1, 1)))
        dy = nc.device_array(outy.shape) if outy.size else nc.to_device(np.zeros((1, 1)))
        walls = ens.walls
        tpb = _tpb()
        grid = (n + tpb - 1) // tpb
        done = 0
        while done < n_steps:
            steps = min(per, n_steps - done)
            col0 = done // every if every > 0 else 0
            self.kern[grid, tpb](ens.x, ens.y, ens.zt, ens.s0, ens.s1, steps, every, col0,
                                 self.pf, int(P.ip.has_d2), int(P.ip.max_impacts), *walls,
                                 dx, dy, bool(outy.size), self.lev, self.L,
                                 float(P.mean_level), self.count, self.pst, self.cnt,
                                 self.wcnt, P.n_batches, float(P.lo_in), float(P.hi_in))
            nc.synchronize()
            done += steps
        if outx.size:
            outx[:] = dx.copy_to_host()
        if outy.size:
            outy[:] = dy.copy_to_host()
        cnt[:] = self.cnt.copy_to_host()
        w = self.wcnt.copy_to_host()
        wcnt[:, :2] = w[:, :2]
        wcnt[:, 2] += np.diff(P.starts) * float(n_steps)
