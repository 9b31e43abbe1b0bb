"""First passage on a GPU: one path at a time per thread, written once for two targets.

:func:`build` compiles the plain functions below for a target (``numba.njit``: the
CPU copy the tests compare with; ``cuda.jit(device=True)``: the kernel of
:func:`kernel`).  A path draws its own stream (``seed`` of :mod:`._cuda_rng`, from its
index), so its numbers do not depend on the thread that runs it, and threads take
the next path from a counter when theirs exits (no thread waits on a long path).

The energy safe set {H < H_c} mirrors the CPU engine's :mod:`._fp_kernel`:

- H ≥ H_c at the step's end: exit, timed by H linear within the step;
- an impact in the step: the energy just before the larger one (G(x_w) + Σu²/2 of
  that wall) ≥ H_c is an exit at mid-step; else the Brownian bridge runs to the
  impact (y0 → the velocity before it) and from it (the rebound → y1), each over the
  whole step, and the path exits at mid-step with probability 1 − (1 − p_a)(1 − p_b);
- otherwise the bridge of y against the band |y| < sqrt(2 (H_c − G(x))) over the
  step, drawn only where an exponent is below ``BRIDGE_CUT``.  A bound avoids the
  square roots on most steps: b − |y| ≥ (H_c − H) / B with B = sqrt(2 (H_c − min G)),
  so when 2 L0 L1 / (σ̄² dt) ≥ BRIDGE_CUT for these bounds both exponents are beyond
  the cut and nothing is drawn (the same decision as computing them).
"""
from __future__ import annotations

import math

import numpy as np

from ._params import StepParams

_F = {name: i for i, name in enumerate(StepParams._fields)}
_PF = tuple(_F[k] for k in ("a", "b", "hh", "ec", "sd0", "d1s2", "d2s2", "lo", "hi", "f_lo",
                            "f_hi"))

#: First-passage kinds.
FP_ENERGY, FP_DISPLACEMENT, FP_SPEED = 0, 1, 2
#: Sums per batch: Σ T, Σ T², exits, censored, path-steps, bridge exits.
NFP = 6
#: Batches at most (per-block sums in shared memory).
NB_MAX = 256
_SHN = NB_MAX * NFP
BRIDGE_CUT = 16.0
P_CUT = math.exp(-BRIDGE_CUT)

cuda = None          # numba.cuda (set by kernel(); the simulator swaps this global)


def _exponents_py(y0, b0, y1, b1, s, dt):
    k = 2.0 / (s * dt)
    return (k * max(b0 - y0, 0.0) * max(b1 - y1, 0.0),
            k * max(b0 + y0, 0.0) * max(b1 + y1, 0.0))


def build(jit, step, normal2, uniform, seed, restitution):
    """``decide`` (the energy set's test of one step) and ``path`` (one path from
    its start to its exit or the horizon) compiled by ``jit`` over the target's
    ``step``, random functions and ``restitution``."""
    exponents = jit(_exponents_py)

    def cross(y0, b0, y1, b1, s, dt):
        ep, em = exponents(y0, b0, y1, b1, s, dt)
        return math.exp(-ep) + math.exp(-em)

    cross = jit(cross)

    def decide(x0, y0, g0, x, y, g, nl, nr, ql, qr, glo, ghi, hc, d1, d2, dt, bridge,
               kinds, par, tab_u, tab_r):
        """A step from (x0, y0) to (x, y), inside {H < H_c} at its end (G(x0) = g0,
        G(x) = g), ``nl``/``nr`` impacts with Σu² ``ql``/``qr``: (p, now): exit now at
        mid-step, or with probability p (0: no draw)."""
        sy = 2.0 * d1 + d2 * (x0 * x0 + x * x)
        b0 = math.sqrt(max(2.0 * (hc - g0), 0.0))
        b1 = math.sqrt(max(2.0 * (hc - g), 0.0))
        if nl + nr > 0:
            hl = glo + 0.5 * ql if nl > 0 else -math.inf
            hr = ghi + 0.5 * qr if nr > 0 else -math.inf
            if hr >= hl:
                hp = hr
                up = math.sqrt(qr)
                gw = ghi
                rw = restitution(up, kinds[1], par[1], tab_u[1], tab_r[1])
            else:
                hp = hl
                up = -math.sqrt(ql)
                gw = glo
                rw = restitution(-up, kinds[0], par[0], tab_u[0], tab_r[0])
            if hp >= hc:
                return 0.0, True
            if not bridge:
                return 0.0, False
            bw = math.sqrt(max(2.0 * (hc - gw), 0.0))
            pa = min(cross(y0, b0, up, bw, sy, dt), 1.0)
            pb = min(cross(-rw * up, bw, y, b1, sy, dt), 1.0)
            p = 1.0 - (1.0 - pa) * (1.0 - pb)
            return (p if p > P_CUT else 0.0), False
        if not bridge:
            return 0.0, False
        ep, em = exponents(y0, b0, y, b1, sy, dt)
        if min(ep, em) < BRIDGE_CUT:
            return math.exp(-ep) + math.exp(-em), False
        return 0.0, False

    decide = jit(decide)

    def path(i, sd, x, y, kind, hc, xlo, xhi, uc, d1, d2, bridge, kmax, inv_bmax, a, bcub,
             hh, ec, sd0, d1s2, d2s2, lo, hi, flo, fhi, glo, ghi, has_d2, maxk, kinds, par,
             tab_u, tab_r, rec):
        """Path i of seed ``sd`` from (x, y): (T, steps, by the bridge); T < 0:
        censored at ``kmax`` steps.  ``rec``: the step's records (unused by a build
        without counting, :func:`._scalar_step.build`)."""
        s0, s1 = seed(sd, i)
        dt = 2.0 * hh
        f = -(a + bcub * x * x) * x
        g = x * x * (0.5 * a + 0.25 * bcub * x * x)
        lb = max(hc - 0.5 * y * y - g, 0.0) * inv_bmax
        k = 0
        have = False
        z2 = 0.0
        while k < kmax:
            if have:
                z = z2
                have = False
            else:
                z, z2, s0, s1 = normal2(s0, s1)
                have = True
            x0 = x
            y0 = y
            g0 = g
            lb0 = lb
            (x, y, f, tl, wl, nl, nr, ul, ur, ql, qr, el, er, um, xm, ym) = step(
                x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, kinds,
                par, tab_u, tab_r, has_d2, maxk, 0.0, -1.0, 0, rec, -0.0, -0.0)
            k += 1
            if kind == FP_ENERGY:
                g = x * x * (0.5 * a + 0.25 * bcub * x * x)
                h1 = 0.5 * y * y + g
                if not (h1 < hc):
                    if h1 == h1:
                        h0 = 0.5 * y0 * y0 + g0
                        return (k - 1 + min((hc - h0) / (h1 - h0), 1.0)) * dt, k, 0.0
                    return (k - 1) * dt, k, 0.0
                lb = (hc - h1) * inv_bmax
                if nl + nr == 0:
                    if not bridge:
                        continue
                    sy = 2.0 * d1 + d2 * (x0 * x0 + x * x)
                    if 2.0 * lb0 * lb >= BRIDGE_CUT * sy * dt:
                        continue
                p, now = decide(x0, y0, g0, x, y, g, nl, nr, ql, qr, glo, ghi, hc, d1, d2,
                                dt, bridge, kinds, par, tab_u, tab_r)
                if now:
                    return (k - 0.5) * dt, k, 0.0
                if p > 0.0:
                    u, s0, s1 = uniform(s0, s1)
                    if u < p:
                        return (k - 0.5) * dt, k, 1.0
            elif kind == FP_DISPLACEMENT:
                if (nl > 0 and lo <= xlo) or (nr > 0 and hi >= xhi):
                    return (k - 0.5) * dt, k, 0.0
                if not (xm > xlo and xm < xhi):
                    e = xhi if xm >= xhi else xlo
                    w = (e - x0) / (xm - x0) if xm != x0 else 1.0
                    return (k - 1 + 0.5 * min(max(w, 0.0), 1.0)) * dt, k, 0.0
                if not (x > xlo and x < xhi):
                    e = xhi if x >= xhi else xlo
                    w = (e - xm) / (x - xm) if x != xm else 1.0
                    return (k - 0.5 + 0.5 * min(max(w, 0.0), 1.0)) * dt, k, 0.0
            else:
                if um > uc:
                    return (k - 0.5) * dt, k, 0.0
                if not (x == x):
                    return (k - 1) * dt, k, 0.0
        return -1.0, k, 0.0

    path = jit(path)

    class NS:
        pass

    ns = NS()
    ns.decide, ns.path, ns.cross = decide, path, cross
    return ns


def _cpu():
    from numba import njit
    from . import _cuda_rng, _scalar_step
    jit = njit(inline="always")
    S = _scalar_step.CPU
    R = _cuda_rng.CPU
    return build(jit, S.step, R.normal2, R.uniform, R.seed, S.restitution)


_CPU = None


def cpu():
    """The CPU (``njit``) compilation, built on first use."""
    global _CPU
    if _CPU is None:
        _CPU = _cpu()
    return _CPU


def min_potential(system) -> float:
    """A lower bound of G(x) = a x²/2 + b x⁴/4 between the walls (−inf if none)."""
    a, b = float(system.a), float(system.b)
    lo, hi = system.x_bounds
    cand = [0.0]
    for x in (lo, hi):
        if math.isfinite(x):
            cand.append(x * x * (0.5 * a + 0.25 * b * x * x))
        elif b < 0.0 or (b == 0.0 and a < 0.0):
            return -math.inf
    if a < 0.0 < b:
        cand.append(-a * a / (4.0 * b))
    return min(cand)


def kernel(nc, D):
    """The first-passage kernels for ``nc`` (numba.cuda) over the device build ``D``
    (:func:`build`): (``fp``, ``fold``).

    ``fp`` runs paths ``path0`` .. ``path0 + n_paths − 1`` (threads take the next from
    ``counter``) and writes path i's exit time, censored at the horizon, to ``Ts[i]``;
    the integer counts (exits, censored, path-steps, bridge exits: columns 2–5 of
    ``sums``) and the exit-time histogram are added by atomics, exact in any order.
    ``fold`` sums ``Ts`` and ``Ts²`` per thread g over i = g, g + G, ... (G threads, a
    multiple of the batches, so all of one batch) in that order into ``part[g]``:
    the float sums never depend on which thread ran which path, nor on timing.
    """
    global cuda
    cuda = nc
    path = D.path
    f64 = np.float64
    I = _PF
    z6 = (0.0,) * 6

    def fp(n_paths, path0, x0s, y0s, sd, nb, pf, has_d2, maxk, kinds, par, tab_u, tab_r,
           kind, hc, xlo, xhi, uc, d1, d2, bridge, kmax, giw, inv_bmax, hT, sums, counter,
           hu, hti, Ts):
        sh = cuda.shared.array(_SHN, dtype=f64)
        t = cuda.threadIdx.x
        for c in range(t, nb * NFP, cuda.blockDim.x):
            sh[c] = 0.0
        cuda.syncthreads()
        a = pf[I[0]]
        bcub = pf[I[1]]
        hh = pf[I[2]]
        ec = pf[I[3]]
        sd0 = pf[I[4]]
        d1s2 = pf[I[5]]
        d2s2 = pf[I[6]]
        lo = pf[I[7]]
        hi = pf[I[8]]
        flo = pf[I[9]]
        fhi = pf[I[10]]
        glo = lo * lo * (0.5 * a + 0.25 * bcub * lo * lo) if lo > -math.inf else 0.0
        ghi = hi * hi * (0.5 * a + 0.25 * bcub * hi * hi) if hi < math.inf else 0.0
        ng = hT.shape[1]
        n0 = x0s.shape[0]
        dt = 2.0 * hh
        rec = (hu, hu, hti, hu, z6)
        while True:
            i = cuda.atomic.add(counter, 0, 1)
            if i >= n_paths:
                break
            ip = path0 + i
            b = ip % nb
            T, k, br = path(ip, sd, x0s[ip % n0], y0s[ip % n0], kind, hc, xlo, xhi, uc, d1,
                            d2, bridge, kmax, inv_bmax, a, bcub, hh, ec, sd0, d1s2, d2s2, lo,
                            hi, flo, fhi, glo, ghi, has_d2, maxk, kinds, par, tab_u, tab_r,
                            rec)
            o = b * NFP
            if T >= 0.0:
                cuda.atomic.add(sh, o + 2, 1.0)
                kb = T * giw
                cuda.atomic.add(hT, (b, int(kb) if kb < ng - 1 else ng - 1), 1.0)
                if br > 0.0:
                    cuda.atomic.add(sh, o + 5, 1.0)
            else:
                cuda.atomic.add(sh, o + 3, 1.0)
                T = kmax * dt
            Ts[i] = T
            cuda.atomic.add(sh, o + 4, float(k))
        cuda.syncthreads()
        for c in range(t, nb * NFP, cuda.blockDim.x):
            v = sh[c]
            if v != 0.0:
                cuda.atomic.add(sums, (c // NFP, c % NFP), v)

    def fold(Ts, n, part):
        g = cuda.grid(1)
        G = part.shape[0]
        if g < G:
            s = 0.0
            q = 0.0
            for i in range(g, n, G):
                v = Ts[i]
                s += v
                q += v * v
            part[g, 0] = s
            part[g, 1] = q

    return cuda.jit(fp), cuda.jit(fold)
