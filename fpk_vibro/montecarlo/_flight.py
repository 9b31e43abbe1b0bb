"""Free flight with exact impacts on the walls (compiled, numba).

Within a free-flight sub-step the motion is linear, x(s) = x + s v, so the time at
which a path reaches a wall is exact.  The strip is lo ≤ x ≤ hi; a side without a
wall has lo = −inf (hi = +inf), which no position crosses, so one code serves
walls on both sides, on one side (left or right) and none.  Each wall has its own
restitution, a number or a law of the impact speed u = |y_imp|
(:mod:`._laws`): y → −r_L(u) y at x = lo, y → −r_R(u) y at x = hi.

Besides the new state, a flight returns per wall the number of impacts and the
sums of the impact speed u and of u² (``W_N``, ``W_U``, ``W_Q`` columns of the
per-block wall statistics ``wimp[b, side, column]``, side 0 left, 1 right): the
impact rate, mean and mean-square impact speed of each wall follow from them.

Given ``ext`` (the stationary kernel always, the first passage for its scratch), a
flight also adds to ``extra[b, side, column]`` (``acc``), per wall hit: the energy each impact removes, ½ (1 − r(u)²) u²
(``X_E``: the energy removed per unit time follows the law), the largest impact
speed (``X_M``), and, where the path's last impact is tracked (``last[i]`` = its
time and wall), the time since it: counted per wall pair (``X_GL``/``X_TL``: gaps
from the left wall, count and sum; ``X_GR``/``X_TR`` from the right; ``X_GM`` the
longest), or ``X_G0`` for an impact with no earlier one.  Asked for, impact speeds
(``hu``), impact energies (``he``) and gaps (``hg``) are counted in histograms of
uniform bins from 0 (bin k = ⌊v · iw⌋, the last column counting the values beyond
the last bin; an array with no column: not kept).
"""
from __future__ import annotations

import math

from numba import njit

from ._laws import restitution_side
from ._rng import FASTMATH

#: Sides and columns of the per-block wall statistics ``wimp[b, side, column]``.
LEFT, RIGHT = 0, 1
W_N, W_U, W_Q = range(3)
NW = 3
#: Columns of the per-block further statistics ``extra[b, side, column]`` (``ext``).
X_E, X_M, X_GL, X_TL, X_GR, X_TR, X_GM, X_G0 = range(8)
NX = 8


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _count_speed(hu, side, u, iw):
    """Add the value u to row ``side`` of the histogram ``hu``."""
    if hu is not None:
        m = hu.shape[1]
        if m > 0:
            k = u * iw
            hu[side, int(k) if k < m - 1 else m - 1] += 1.0


@njit(cache=True, fastmath=FASTMATH)
def _record(side, u, e, t, ext, i):
    """The ``ext`` statistics of one impact at speed u on ``side`` removing the energy
    e (module docstring); ``t`` its time relative to the kernel call's start."""
    acc, he, hg, last, iwe_l, iwe_r, iwg = ext
    _count_speed(he, side, e, iwe_l if side == LEFT else iwe_r)
    if last.shape[0] > 0:
        tp = last[i, 0]
        if tp > -math.inf:
            g = t - tp
            col = X_GL if last[i, 1] == 0.0 else X_GR
            acc[side, col] += 1.0
            acc[side, col + 1] += g
            if g > acc[side, X_GM]:
                acc[side, X_GM] = g
            _count_speed(hg, 0, g, iwg)
        else:
            acc[side, X_G0] += 1.0
        last[i, 0] = t
        last[i, 1] = float(side)


@njit(cache=True, fastmath=FASTMATH)
def _impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, rlo, rhi, maxk, hu, iwl, iwr,
             law, ext, t0, i):
    """The impact part of :func:`_flight` (not inlined: rare)."""
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
            s = min(s + (hi - x) / v, tau)         # v > 0 here
            off = s + off0
            vi = v + corr + off * fhi
            x = hi
            if vi > 0.0:
                if law is None:
                    r = rhi
                else:
                    r = restitution_side(vi, law, RIGHT)
                v = -r * vi
                nr += 1
                ur += vi
                qr += vi * vi
                e = 0.5 * (1.0 - r * r) * (vi * vi)
                er += e
                um = max(um, vi)
                _count_speed(hu, RIGHT, vi, iwr)
                if ext is not None:
                    _record(RIGHT, vi, e, t0 + s, ext, i)
            else:
                v = 0.0
            corr = -off * fhi
        elif xn < lo:
            s = min(s + (lo - x) / v, tau)         # v < 0 here
            off = s + off0
            vi = v + corr + off * flo
            x = lo
            if vi < 0.0:
                if law is None:
                    r = rlo
                else:
                    r = restitution_side(-vi, law, LEFT)
                v = -r * vi
                nl += 1
                ul -= vi
                ql += vi * vi
                e = 0.5 * (1.0 - r * r) * (vi * vi)
                el += e
                um = max(um, -vi)
                _count_speed(hu, LEFT, -vi, iwl)
                if ext is not None:
                    _record(LEFT, -vi, e, t0 + s, ext, i)
            else:
                v = 0.0
            corr = -off * flo
        else:
            return xn, v + corr, nl, nr, ul, ur, ql, qr, el, er, um
        if nl + nr >= maxk:
            return x, v + corr, nl, nr, ul, ur, ql, qr, el, er, um
        xn = x + (tau - s) * v


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _flight(x, y, tau, off0, lo, hi, flo, fhi, rlo, rhi, maxk, lo_t, hi_t, hu=None,
            iwl=0.0, iwr=0.0, law=None, ext=None, t0=0.0, i=0):
    """Free flight x += tau*y with impacts located exactly at x = lo / hi.

    ``y`` is the splitting's stored velocity, which already holds the whole
    opening kick (h/2) F.  At an impact at local time s the physical velocity is
    y_imp = y + (s + off0) F_w (``off0`` = −h/2 in the first flight, 0 in the
    second; F_w the force at the wall); it is reflected, v = −r_w(|y_imp|) y_imp,
    the rest of the flight uses v, and the stored velocity returned is
    v − (s + off0) F_w, so that the closing kick completes the step correctly
    (the kick timing error at an impact is O(h²), not O(h)).  If y_imp does not
    point into the wall (a graze the true curved path would not make), the
    path touches the wall with v = 0 and no impact is counted.

    Parameters
    ----------
    x, y : float
        Position and stored velocity at the start of the flight.
    tau, off0 : float
        Flight duration and the kick offset above.
    lo, hi : float
        The walls (∓inf where there is none).
    flo, fhi : float
        The force at each wall (0 where there is none).
    rlo, rhi : float
        Restitution of each wall (used where ``law`` is None).
    maxk : int
        At most ``maxk`` impacts per call; if the bound is reached the path stays
        on the wall it hit last.
    lo_t, hi_t : float
        The interval whose flights need no impact test (``lo``, ``hi``).
    hu : float64[2, m] or None, optional
        Impact-speed histogram of the block (module docstring); None: not kept.
    iwl, iwr : float, optional
        Inverse bin widths of the left and right wall's speed histogram.
    law : float64 array or None, optional
        Both walls' laws packed (:func:`._laws.pack`); None: the constants ``rlo``,
        ``rhi``.
    ext : tuple or None, optional
        (acc float64[2, NX], he float64[2, m], hg float64[1, m], last float64[:, 2],
        iw of he left, right, iw of hg): the statistics of the module docstring;
        None: not kept.
    t0 : float, optional
        Time of the flight's start relative to the kernel call (gaps only).
    i : int, optional
        The path's row of ``last`` (gaps only).

    Returns
    -------
    tuple
        (x, stored y, impacts left, impacts right, Σu left, Σu right, Σu² left,
        Σu² right, Σe left, Σe right, largest u), u the speed just before each
        impact, e = ½ (1 − r(u)²) u² the energy it removes.
    """
    xn = x + tau * y
    # one test; a NaN goes to _impacts, which returns it unchanged
    if (xn >= lo_t) & (xn <= hi_t):
        return xn, y, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return _impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, rlo, rhi, maxk, hu, iwl, iwr,
                    law, ext, t0, i)
