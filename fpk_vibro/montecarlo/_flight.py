"""Free flight with exact impacts on the walls (compiled, numba).

Within a free-flight sub-step the motion is linear, x(s) = x + s v, so the time at
which a path reaches a wall is exact.  The strip is lo ≤ x ≤ hi; a side without a
wall has lo = −inf (hi = +inf), which no position crosses, so one code serves
walls on both sides, on one side (left or right) and none.  Each wall has its own
restitution: y → −r_L y at x = lo, y → −r_R y at x = hi.

Besides the new state, a flight returns per wall the number of impacts and the
sums of the impact speed u = |y_imp| and of u² (``W_*`` columns of the per-block
wall statistics ``wimp[b, side, column]``, side 0 left, 1 right): the impact rate,
mean and mean-square impact speed and the energy removed per unit time
(½ (1 − r²) Σ u² / time) of each wall follow from them.

Asked for (``hu``), a flight also counts each impact speed in a histogram per wall,
``hu[side, k]`` for the bin k = ⌊u · iw_side⌋ of width 1/iw_side from u = 0, the
last column ``hu[side, -1]`` counting the speeds beyond the last bin.  Left out
(``hu=None``, the default), the compiled code has no histogram at all; an array
with no column (the kernel's "not requested") costs one comparison per impact.
"""
from __future__ import annotations

from numba import njit

from ._rng import FASTMATH

#: Sides and columns of the per-block wall statistics ``wimp[b, side, column]``.
LEFT, RIGHT = 0, 1
W_N, W_U, W_Q = range(3)
NW = 3


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _count_speed(hu, side, u, iw):
    """Add the impact speed u to row ``side`` of the speed histogram ``hu``."""
    if hu is not None:
        m = hu.shape[1]
        if m > 0:
            k = u * iw
            hu[side, int(k) if k < m - 1 else m - 1] += 1.0


@njit(cache=True, fastmath=FASTMATH)
def _impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, rlo, rhi, maxk, hu, iwl, iwr):
    """The impact part of :func:`_flight` (not inlined: rare)."""
    nl = 0
    nr = 0
    ul = 0.0
    ur = 0.0
    ql = 0.0
    qr = 0.0
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
                v = -rhi * vi
                nr += 1
                ur += vi
                qr += vi * vi
                _count_speed(hu, RIGHT, vi, iwr)
            else:
                v = 0.0
            corr = -off * fhi
        elif xn < lo:
            s = min(s + (lo - x) / v, tau)         # v < 0 here
            off = s + off0
            vi = v + corr + off * flo
            x = lo
            if vi < 0.0:
                v = -rlo * vi
                nl += 1
                ul -= vi
                ql += vi * vi
                _count_speed(hu, LEFT, -vi, iwl)
            else:
                v = 0.0
            corr = -off * flo
        else:
            return xn, v + corr, nl, nr, ul, ur, ql, qr
        if nl + nr >= maxk:
            return x, v + corr, nl, nr, ul, ur, ql, qr
        xn = x + (tau - s) * v


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _flight(x, y, tau, off0, lo, hi, flo, fhi, rlo, rhi, maxk, lo_t, hi_t, hu=None,
            iwl=0.0, iwr=0.0):
    """Free flight x += tau*y with impacts located exactly at x = lo / hi.

    ``y`` is the splitting's stored velocity, which already holds the whole
    opening kick (h/2) F.  At an impact at local time s the physical velocity is
    y_imp = y + (s + off0) F_w (``off0`` = −h/2 in the first flight, 0 in the
    second; F_w the force at the wall); it is reflected, v = −r_w y_imp, the
    rest of the flight uses v, and the stored velocity returned is
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
        Restitution of each wall.
    maxk : int
        At most ``maxk`` impacts per call; if the bound is reached the path stays
        on the wall it hit last.
    lo_t, hi_t : float
        The interval whose flights need no impact test (``lo``, ``hi``).
    hu : float64[2, m] or None, optional
        Impact-speed histogram of the block (module docstring); None: not kept.
    iwl, iwr : float, optional
        Inverse bin widths of the left and right wall's speed histogram.

    Returns
    -------
    tuple
        (x, stored y, impacts left, impacts right, Σu left, Σu right, Σu² left,
        Σu² right), u the speed just before each impact.
    """
    xn = x + tau * y
    # one test; a NaN goes to _impacts, which returns it unchanged
    if (xn >= lo_t) & (xn <= hi_t):
        return xn, y, 0, 0, 0.0, 0.0, 0.0, 0.0
    return _impacts(x, y, xn, tau, off0, lo, hi, flo, fhi, rlo, rhi, maxk, hu, iwl, iwr)
