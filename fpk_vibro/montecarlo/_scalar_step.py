"""The scalar BAOAB step with exact impacts, written once for every target.

The functions below are plain Python; :func:`build` compiles them for one target:
``numba.njit`` (the CPU reference, :data:`CPU`) or ``numba.cuda.jit(device=True)``
(:mod:`._cuda_engine`).  A fix or a new restitution law therefore lands in both.
The only target-specific pieces are passed in: ``jit`` and ``add``, how a histogram
count is added (``h[i, k] += w`` on the CPU, an atomic add on a GPU).

The step is the engine's (:mod:`._kernel`; with coloured noise the kicks add κ ζ)::

    B  y += (h/2) F(x)
    A  x += (h/2) y      free flight, impacts at x = lo / hi located exactly
    O  y ← e^{−c h} y + sqrt(D(x)(1 − e^{−2ch})/c) ξ
    A  x += (h/2) y
    B  y += (h/2) F(x)

Walls carry a restitution law r(u) of the impact speed u (:mod:`._laws`): ``kinds``
int64[2], ``par`` float64[2, 3], ``tab_u``, ``tab_r`` float64[2, m] (side 0 left, 1
right; tables padded with their last point, which the law never distinguishes from
the end).  :func:`encode_walls` makes them from a system.

A flight also reports, per wall: impacts, Σu, Σu², the energy lost Σ ½(1 − r²)u², and
the largest impact speed of the step.  Each path carries the time ``tlast`` of its
last impact (< 0: none yet) and its wall ``wlast`` (0 left, 1 right).  ``rec`` = (hu,
he, hg, acc, iw) records what the CPU engine's ``ext`` does (:mod:`._flight`), with
``iw`` = (speed iw left, right, energy iw left, right, gap iw, track): each impact
speed in ``hu[side, k]`` and its energy loss in ``he[side, k]`` (bin k = ⌊v·iw⌋, last
column: beyond; no column: not kept); with ``track`` > 0 the gap back to the path's
previous impact per wall pair in ``acc[side, X_GL | X_GR]`` (count) and the next
column (sum), the longest in ``acc[side, X_GM]``, an impact with no earlier one in
``acc[side, X_G0]``, and the gap in ``hg[k]`` (:data:`._flight.X_GL` ...: the CPU's
columns of ``extra``).
"""
from __future__ import annotations

import math

import numpy as np

from ._flight import X_G0, X_GL, X_GM, X_GR
from ._laws import encode, restitution_py

__all__ = ["build", "encode_walls", "forcing_at", "CPU", "N_OUT"]

#: Length of the tuple :func:`build`'s ``step`` returns.
N_OUT = 16


def encode_walls(system, u_max: float = 1e3):
    """(kinds int64[2], par float64[2, 3], tab_u, tab_r float64[2, m]) of the system's
    walls (an absent wall: elastic, never hit)."""
    enc = [encode(system.left, u_max), encode(system.right, u_max)]
    m = max(e[2].size for e in enc)
    kinds = np.array([e[0] for e in enc], dtype=np.int64)
    par = np.array([e[1] for e in enc], dtype=np.float64)
    tab_u = np.empty((2, m))
    tab_r = np.empty((2, m))
    for s, e in enumerate(enc):
        n = e[2].size
        tab_u[s, :n], tab_u[s, n:] = e[2], e[2][-1]
        tab_r[s, :n], tab_r[s, n:] = e[3], e[3][-1]
    return kinds, par, tab_u, tab_r


def build(jit, add2, add1, counting=True):
    """The scalar functions compiled by ``jit``; ``add2(h, i, k, w)`` and
    ``add1(h, k, w)`` add w to a histogram cell.  ``counting=False``: a build that
    never touches ``rec`` (kernels without impact records).  Returns a namespace with
    ``restitution``, ``flight`` and ``step``."""
    restitution = jit(restitution_py)

    def count(rec, side, u, e, t, tlast, wlast):
        """One impact at time t, speed u, loss e into ``rec`` (module docstring)."""
        if not counting:
            return
        hu, he, hg, acc, iw = rec
        m = hu.shape[1]
        if m > 0:
            k = u * iw[side]
            add2(hu, side, int(k) if k < m - 1 else m - 1, 1.0)
        m = he.shape[1]
        if m > 0:
            k = e * iw[2 + side]
            add2(he, side, int(k) if k < m - 1 else m - 1, 1.0)
        if iw[5] > 0.0:
            if tlast >= 0.0:
                g = t - tlast
                col = X_GL if wlast == 0 else X_GR
                acc[side, col] += 1.0
                acc[side, col + 1] += g
                if g > acc[side, X_GM]:
                    acc[side, X_GM] = g
                mt = hg.shape[0]
                if mt > 0:
                    k = g * iw[4]
                    add1(hg, int(k) if k < mt - 1 else mt - 1, 1.0)
            else:
                acc[side, X_G0] += 1.0

    count = jit(count)

    def impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, kinds, par, tab_u, tab_r, maxk,
                t0, tlast, wlast, rec):
        nl = 0
        nr = 0
        ul = 0.0
        ur = 0.0
        ql = 0.0
        qr = 0.0
        el = 0.0
        er = 0.0
        um = 0.0
        s = 0.0
        v = y
        corr = 0.0
        while True:
            if xn > hi:
                s = min(s + (hi - x) / v, tau)          # v > 0 here
                off = s + off0
                vi = v + corr + off * fhi
                x = hi
                if vi > 0.0:
                    r = restitution(vi, kinds[1], par[1], tab_u[1], tab_r[1])
                    v = -r * vi
                    nr += 1
                    ur += vi
                    qr += vi * vi
                    e = 0.5 * (1.0 - r * r) * (vi * vi)
                    er += e
                    um = max(um, vi)
                    count(rec, 1, vi, e, t0 + s, tlast, wlast)
                    tlast = t0 + s
                    wlast = 1
                else:
                    v = 0.0
                corr = -off * fhi
            elif xn < lo:
                s = min(s + (lo - x) / v, tau)          # v < 0 here
                off = s + off0
                vi = v + corr + off * flo
                x = lo
                if vi < 0.0:
                    r = restitution(-vi, kinds[0], par[0], tab_u[0], tab_r[0])
                    v = -r * vi
                    nl += 1
                    ul -= vi
                    ql += vi * vi
                    e = 0.5 * (1.0 - r * r) * (vi * vi)
                    el += e
                    um = max(um, -vi)
                    count(rec, 0, -vi, e, t0 + s, tlast, wlast)
                    tlast = t0 + s
                    wlast = 0
                else:
                    v = 0.0
                corr = -off * flo
            else:
                return xn, v + corr, tlast, wlast, nl, nr, ul, ur, ql, qr, el, er, um
            if nl + nr >= maxk:
                return x, v + corr, tlast, wlast, nl, nr, ul, ur, ql, qr, el, er, um
            xn = x + (tau - s) * v

    impacts = jit(impacts)

    def flight(x, y, tau, off0, lo, hi, flo, fhi, kinds, par, tab_u, tab_r, maxk, t0,
               tlast, wlast, rec):
        """Free flight x += tau y with exact impacts (:func:`._flight._flight`; laws,
        losses, the largest speed and the impact records added)."""
        xn = x + tau * y
        if (xn >= lo) & (xn <= hi):
            return xn, y, tlast, wlast, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        return impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, kinds, par, tab_u, tab_r,
                       maxk, t0, tlast, wlast, rec)

    flight = jit(flight)

    def step(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, kinds, par,
             tab_u, tab_r, has_d2, maxk, t0, tlast, wlast, rec, g0, g1):
        """One step from time t0; f = F(x) on entry and on return (the restoring force
        alone).  ``g0``, ``g1``: the force added at the step's start and end, harmonic
        (F cos(Ω t + φ0)) or coloured (κ ζ_k, κ ζ_{k+1}: ζ advanced by the caller,
        :mod:`._kernel`), as the CPU engine's :func:`._sweep._step_core` (g0 in the
        opening kick and the first flight's wall force, g1 in the second flight's and
        the closing kick); −0.0 where there is none (x + (−0.0) is x bit for bit, so
        the unforced step is unchanged and a compiler drops the additions).  Returns (x, y, f, tlast,
        wlast, nl, nr, Σu l, Σu r, Σu² l, Σu² r, loss l, loss r, largest u, x after
        the first flight, y after the O step)."""
        y += hh * (f + g0)
        x, y, tlast, wlast, nl, nr, ul, ur, ql, qr, el, er, um = flight(
            x, y, hh, -hh, lo, hi, flo + g0, fhi + g0, kinds, par, tab_u, tab_r, maxk, t0,
            tlast, wlast, rec)
        xm = x
        if has_d2:
            y = ec * y + math.sqrt(d1s2 + d2s2 * x * x) * z
        else:
            y = ec * y + sd0 * z
        ym = y
        x, y, tlast, wlast, nl2, nr2, ul2, ur2, ql2, qr2, el2, er2, um2 = flight(
            x, y, hh, 0.0, lo, hi, flo + g1, fhi + g1, kinds, par, tab_u, tab_r, maxk,
            t0 + hh, tlast, wlast, rec)
        f = -(a + bcub * x * x) * x
        return (x, y + hh * (f + g1), f, tlast, wlast, nl + nl2, nr + nr2, ul + ul2,
                ur + ur2, ql + ql2, qr + qr2, el + el2, er + er2, max(um, um2), xm, ym)

    step = jit(step)

    class NS:
        pass

    ns = NS()
    ns.restitution, ns.flight, ns.step = restitution, flight, step
    return ns


def _cpu():
    from numba import njit

    def add2(h, i, k, w):
        h[i, k] += w

    def add1(h, k, w):
        h[k] += w

    return build(njit(cache=False, inline="always"), njit(inline="always")(add2),
                 njit(inline="always")(add1))


#: The CPU (``njit``) compilation: the reference the GPU kernels and the vectorised
#: sweep are checked against.
CPU = _cpu()
_cpu_step = CPU.step


def forcing_at(amp, omega, phase, t0, hh, k):
    """The harmonic force F cos(Ω t_k + φ0) at step k's start t_k = t0 + k h, computed
    as the CPU engine's ``advance`` does (t0 + 2 hh k, then Ω t + φ0), so every target
    evaluates the kicks at the same rounded times."""
    return amp * math.cos(omega * (t0 + 2.0 * hh * k) + phase)


def _compile_forcing():
    from numba import njit
    return njit(inline="always")(forcing_at)


_forcing_cpu = _compile_forcing()


def _given_cpu(xs, ys, tls, wls, zs, t0, pf, has_d2, maxk, kinds, par, tab_u, tab_r,
               out, hu, he, hg, accs, iw, ia, forced):
    """The CPU reference of the GPU's ``given`` kernel (:mod:`._cuda_kernels`): path j
    stepped with the normals ``zs[k, j]``, its gap records in ``accs[j]``; ``ia``:
    the positions of a, b, hh, ec, sd0, d1s2, d2s2, lo, hi, f_lo, f_hi, f_amp,
    f_omega, f_phase in ``pf``; ``forced``: the harmonic force (:func:`forcing_at`)."""
    for j in range(xs.shape[0]):
        a = pf[ia[0]]
        bcub = pf[ia[1]]
        hh = pf[ia[2]]
        x = xs[j]
        y = ys[j]
        tl = tls[j]
        wl = wls[j]
        f = -(a + bcub * x * x) * x
        t = t0
        rec = (hu, he, hg, accs[j], iw)
        for k in range(zs.shape[0]):
            g0 = -0.0
            g1 = -0.0
            if forced:
                g0 = _forcing_cpu(pf[ia[11]], pf[ia[12]], pf[ia[13]], t0, hh, k)
                g1 = _forcing_cpu(pf[ia[11]], pf[ia[12]], pf[ia[13]], t0, hh, k + 1)
            (x, y, f, tl, wl, nl, nr, ul, ur, ql, qr, el, er, um, xm, ym) = _cpu_step(
                x, y, f, zs[k, j], hh, pf[ia[3]], pf[ia[4]], pf[ia[5]], pf[ia[6]], a, bcub,
                pf[ia[7]], pf[ia[8]], pf[ia[9]], pf[ia[10]], kinds, par, tab_u, tab_r,
                has_d2, maxk, t, tl, wl, rec, g0, g1)
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


def _compile_given():
    from numba import njit
    return njit(_given_cpu)


given_cpu = _compile_given()
