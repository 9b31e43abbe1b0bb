"""Sampling the paths' states (compiled, numba): histograms, moment sums, x range.

:func:`_sample` adds a set of states as samples of one block; the per-block moment
sums ``mom[b, M_*]`` are the columns below.  :func:`snapshot` samples every path
once (transient densities).
"""
from __future__ import annotations

from numba import njit

from ._rng import FASTMATH

# moment accumulator columns (M_Z2, M_ZY: Σζ², Σζy of coloured external noise, 0 else)
(M_N, M_H, M_X2, M_Y2, M_X4, M_Y4, M_PIMP, M_OVH, M_OVX, M_OVY, M_OVJ, M_X, M_Z2,
 M_ZY) = range(14)
NM = 14


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
def _sample(xv, vv, n, kick, p, b, mom, xext, hH, hx, hy, hj, zv=None):
    """Add the states x = xv[:n], y = vv[:n] + kick F(x) (``kick`` = h/2 for the
    kick-merged state of :func:`_smooth_sweep`, 0 for plain states) as samples of
    block b: the requested
    histograms, the moment sums (``mom[b]``, overflow counts and Σx included) and
    the range of x (``xext[b]``); ``zv``: None, or the paths' coloured noise ζ
    (:mod:`fpk_vibro.noise`; ``vv`` then holds y − kick F(x)), whose Σζ² and Σζy go
    to ``mom[b, M_Z2]`` and ``mom[b, M_ZY]``.

    Called once per sweep, not per path, and written out without array-taking
    helpers: an inlined helper receiving arrays costs numba a reference-count
    increment and decrement per call (~30 ns per sample, measured).
    """
    a = p.a
    bb = p.b
    gd = p.barrier_energy
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
    cx = 0.0
    oH = 0.0
    ox = 0.0
    oy = 0.0
    oj = 0.0
    xmin = xext[b, 0]
    xmax = xext[b, 1]
    cz2 = 0.0
    czy = 0.0
    for j in range(n):
        x = xv[j]
        x2 = x * x
        y = vv[j] - kick * (a + bb * x2) * x
        y2 = y * y
        H = 0.5 * y2 + x2 * (0.5 * a + 0.25 * bb * x2)
        if nbh > 0:
            k = _hist_index(H, p.h0, p.h_iw, nbh)
            if k >= 0:
                hH[b, k] += 1.0
            else:
                oH += 1.0
        if nbx > 0:
            k = _hist_index(x, p.x0, p.x_iw, nbx)
            if k >= 0:
                hx[b, k] += 1.0
            else:
                ox += 1.0
        if nby > 0:
            k = _hist_index(y, p.y0, p.y_iw, nby)
            if k >= 0:
                hy[b, k] += 1.0
            else:
                oy += 1.0
        if njx > 0:
            kx = _hist_index(x, p.jx0, p.jx_iw, njx)
            ky = _hist_index(y, p.jy0, p.jy_iw, njy)
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
        cx += x
        xmin = min(xmin, x)
        xmax = max(xmax, x)
        if zv is not None:
            zt = zv[j]
            cz2 += zt * zt
            czy += zt * y
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
    mom[b, M_X] += cx
    if zv is not None:
        mom[b, M_Z2] += cz2
        mom[b, M_ZY] += czy
    xext[b, 0] = xmin
    xext[b, 1] = xmax



@njit(cache=True, fastmath=FASTMATH)
def snapshot(xs, ys, starts, p, mom, xext, hH, hx, hy, hj, zs=None):
    """Accumulate the current states of all paths once (transient densities;
    cheap, so serial); ``zs``: None, or the paths' coloured noise ζ."""
    for b in range(starts.shape[0] - 1):
        i0 = starts[b]
        i1 = starts[b + 1]
        if zs is None:
            _sample(xs[i0:i1], ys[i0:i1], i1 - i0, 0.0, p, b, mom, xext, hH, hx, hy, hj)
        else:
            _sample(xs[i0:i1], ys[i0:i1], i1 - i0, 0.0, p, b, mom, xext, hH, hx, hy, hj,
                    zs[i0:i1])
