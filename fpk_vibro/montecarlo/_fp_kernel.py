"""Compiled (numba) kernel of the Monte Carlo first passage out of {H < H_c}.

Each block of paths (one random stream, as in :mod:`._kernel`) keeps up to CHUNK
paths in flight in slots 0..n-1.  A step advances the n slots with the stationary
kernel's own step: its normals (:func:`._rng._normal`), its vectorised sweep
(:func:`._sweep._smooth_sweep`) and, for the paths the sweep flags, its exact
impact handling (:func:`._flight._flight`, :func:`._sweep._step_walls`).  Then
:func:`_monitor` compares the new states with H_c and flags

- the paths with H ≥ H_c: exited in this step (time by linear interpolation of H
  within the step);
- the paths still inside but near enough to the boundary that a crossing between
  the two step ends is not negligible.  The safe set is the band |y| < Y(x) =
  sqrt(2 (H_c − G(x))); within a step the noise moves y alone, as a Brownian
  motion of variance rate 2 D(x), while x moves by y dt.  Given its values at the
  step ends, y is a Brownian bridge, and it leaves the band with the probability
  exp(−2 (Y0 − y0)(Y1 − y1) / (2 D̄ dt)) + exp(−2 (Y0 + y0)(Y1 + y1) / (2 D̄ dt))
  (the exact probability for each side of a barrier linear in time, Y going from
  Y(x0) to Y(x1); D̄ the mean of D at the two ends).  Such a path is stopped with
  that probability (one uniform from the block's stream) at the middle of the
  step.  Where |y| ≫ sqrt(D dt) this is the bridge of H itself (σ_H² = 2 D y²);
  near the turning points of the boundary (y ≈ 0, where H gains energy by the
  noise's drift D rather than by diffusion) an H-bridge would miss the crossings.
- the paths whose step had an impact: the energy just before it (from the impact
  speed u: G(x_w) + u²/2, the larger wall's over the step; exact for one impact)
  is the step's peak, as an impact only removes energy: a peak ≥ H_c is an exit,
  else the bridge runs to the impact (y0 → the velocity before it) and from it
  (the reflected velocity → y1), each over the whole step (an upper bound).
- the paths that reached the step horizon ``kmax``: parked (state written back)
  so that a later call can resume them.

Monitoring the step ends alone would detect every exit late (an O(sqrt(dt)) bias
of the mean time); measured: :mod:`._first_passage`.  An exited or parked path
leaves its slot to the next path of the block's queue; when the queue is empty the
last slot moves into the gap.  Everything happens in one fixed order per block, so
a seed gives the same numbers for any number of threads.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from . import _kernel as K
from ._flight import LEFT, RIGHT, _flight
from ._laws import restitution_side
from ._rng import FASTMATH, _next, _normal

#: ``status`` of a path: still inside at the horizon (parked), exited, or NaN state.
ALIVE, EXITED, FAILED = 0, 1, 2
#: The safe set a block's paths leave (:mod:`fpk_vibro.safe_sets`): {H < H_c},
#: {x_lo < x < x_hi}, or no impact faster than u_c.
ENERGY, DISPLACEMENT, IMPACT_SPEED = 0, 1, 2
#: Bridge exponents beyond this (crossing probability below e⁻¹⁶ ≈ 1.1e-7 in the step)
#: are not drawn: a path spends a few steps per unit of exponent near the cut, so the
#: exits left out are ~1e-6 of the paths.
BRIDGE_CUT = 16.0
P_CUT = math.exp(-BRIDGE_CUT)
_TWO_M53 = 2.0 ** -53
_U11 = np.uint64(11)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _state(x, v, hh, a, bcub, hc):
    """(y, G(x), barrier Y = sqrt(2 (H_c − G(x)))) of the kick-merged state (x, v)."""
    x2 = x * x
    y = v - hh * (a + bcub * x2) * x
    g = x2 * (0.5 * a + 0.25 * bcub * x2)
    return y, g, math.sqrt(max(2.0 * (hc - g), 0.0))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _exponents(y0, b0, y1, b1, s, dt):
    """The exponents e₊, e₋ of :func:`_cross` (upper and lower side of the band)."""
    k = 2.0 / (s * dt)
    return (k * max(b0 - y0, 0.0) * max(b1 - y1, 0.0),
            k * max(b0 + y0, 0.0) * max(b1 + y1, 0.0))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _cross(y0, b0, y1, b1, s, dt):
    """Probability that a Brownian bridge of variance rate s from y0 to y1 over dt
    leaves the band |y| < b, b linear in time from b0 to b1: exp(−e₊) + exp(−e₋),
    the exact probability for each side (double crossings neglected)."""
    ep, em = _exponents(y0, b0, y1, b1, s, dt)
    return math.exp(-ep) + math.exp(-em)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _crossed(u, y0, b0, y1, b1, s, dt):
    """u < :func:`_cross`, for a uniform u: first against the bound
    exp(−e) ≤ 1/(1 + e + e²/2), which settles most draws without an exponential."""
    ep, em = _exponents(y0, b0, y1, b1, s, dt)
    if u >= 1.0 / (1.0 + ep * (1.0 + 0.5 * ep)) + 1.0 / (1.0 + em * (1.0 + 0.5 * em)):
        return False
    return u < math.exp(-ep) + math.exp(-em)


@njit(cache=True, fastmath=FASTMATH)
def _monitor(xa, va, xb, n, hh, a, bcub, d1, d2, hc, cut2, bridge, yo, bo, yn, bn):
    """The new states (xa, va) of n slots (kick-merged velocities) against H_c.

    ``yo``, ``bo``: y and the band's half-width Y(x) = sqrt(2 (H_c − G(x))) at the
    step's start (x there: ``xb``); the new ones are written into ``yn``, ``bn``.
    Branch-free and without division (numba checks every division for zero, which
    stops vectorisation), so it compiles to SIMD code.  Returns bit masks (bit j for
    slot j) of the exits (H ≥ H_c, or NaN) and of the paths to test by the bridge:
    a bridge exponent 2 (Y0 ∓ y0)(Y1 ∓ y1) / (σ̄² dt) below BRIDGE_CUT, i.e.
    (Y0 ∓ y0)(Y1 ∓ y1) < ``cut2`` σ̄² with cut2 = BRIDGE_CUT dt / 2 (none if
    ``bridge`` is False).
    """
    ex = 0
    br = 0
    for j in range(n):
        x1 = xa[j]
        x0 = xb[j]
        y1, g1, b1 = _state(x1, va[j], hh, a, bcub, hc)
        y0 = yo[j]
        b0 = bo[j]
        yn[j] = y1
        bn[j] = b1
        out = not (0.5 * y1 * y1 + g1 < hc)
        lim = cut2 * (2.0 * d1 + d2 * (x0 * x0 + x1 * x1))
        near = ((b0 - y0) * (b1 - y1) < lim) | ((b0 + y0) * (b1 + y1) < lim)
        ex |= (1 if out else 0) << j
        br |= (1 if near & (not out) & bridge else 0) << j
    return ex, br


@njit(cache=True, fastmath=FASTMATH)
def _peak(j, ml, mr, tl, tr, glo, ghi, law, Hp, Up, Gw, Rw):
    """Slot j's impact(s) in this step: the energy just before the larger one (from
    Σu² per wall, exact for one impact), the velocity then and the wall's G, r(u)."""
    hl = glo + 0.5 * tl if ml > 0 else -np.inf
    hr = ghi + 0.5 * tr if mr > 0 else -np.inf
    if hr >= hl:
        u = math.sqrt(tr)
        Hp[j], Up[j], Gw[j] = hr, u, ghi
        Rw[j] = restitution_side(u, law, RIGHT)
    else:
        u = math.sqrt(tl)
        Hp[j], Up[j], Gw[j] = hl, -u, glo
        Rw[j] = restitution_side(u, law, LEFT)


@njit(cache=True, fastmath=FASTMATH)
def _monitor_x(xa, xm, n, xlo, xhi):
    """Bit mask of the slots whose step left {xlo < x < xhi} (or is NaN): the
    scheme's path is linear between the step's start, its midpoint ``xm`` and its
    end ``xa``, so a crossing shows at the midpoint or the end."""
    ex = 0
    for j in range(n):
        x1 = xa[j]
        x2 = xm[j]
        inside = (x1 > xlo) & (x1 < xhi) & (x2 > xlo) & (x2 < xhi)
        ex |= (0 if inside else 1) << j
    return ex


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _cross_time(x0, x1, xlo, xhi):
    """Fraction of the linear move x0 → x1 (x0 inside) at which it leaves (xlo, xhi)."""
    b = xlo if x1 <= xlo else xhi
    return min(max((b - x0) / (x1 - x0), 0.0), 1.0)


@njit(cache=True, fastmath=FASTMATH)
def _load(j, i, xs, ys, xa, va, ids, hh, a, bcub, hc, yo, bo):
    """Put path i (state xs[i], ys[i]) into slot j."""
    x = xs[i]
    y = ys[i]
    xa[j] = x
    va[j] = y + hh * (a + bcub * x * x) * x          # v = y − (h/2) F(x)
    yo[j] = y
    bo[j] = math.sqrt(max(2.0 * (hc - x * x * (0.5 * a + 0.25 * bcub * x * x)), 0.0))
    ids[j] = i


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def _fp_block(b, b0, order, starts, xs, ys, ks, tout, status, rng, p, ip, d1, d2, hc,
              kmax, bridge, counts, kind, xlo, xhi, uc, law):
    """Block b0 + b of :func:`._first_passage.simulate`: its queue
    ``order[starts[b0+b]:starts[b0+b+1]]`` of path indices, each simulated from
    (xs, ys) after ks steps until it exits or reaches ``kmax`` steps (module
    docstring).  ``counts[b0+b]`` gets the path-steps done, the exits seen at a step
    end or an impact, and those by the bridge.

    ``kind`` the safe set: :data:`ENERGY` (H < ``hc``, the module docstring),
    :data:`DISPLACEMENT` (``xlo`` < x < ``xhi``: the scheme's path is piecewise
    linear in a step, through its midpoint, so the crossing is located exactly on it,
    a flight towards a wall beyond a bound included) or :data:`IMPACT_SPEED` (an
    impact faster than ``uc``: the fastest impact of each step, timed at the step's
    middle).  ``law``: the walls' restitution (:func:`._params.wall_laws`).
    """
    bb = b0 + b
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
    has_d2 = ip.has_d2 != 0
    maxk = ip.max_impacts
    dt = 2.0 * hh
    cut2 = 0.5 * BRIDGE_CUT * dt
    ha = 2.0 * hh * a
    hb = 2.0 * hh * bcub
    glo = lo * lo * (0.5 * a + 0.25 * bcub * lo * lo) if lo > -np.inf else 0.0
    ghi = hi * hi * (0.5 * a + 0.25 * bcub * hi * hi) if hi < np.inf else 0.0
    s0 = rng[bb, 0]
    s1 = rng[bb, 1]
    s2 = rng[bb, 2]
    s3 = rng[bb, 3]
    C = K.CHUNK
    xa = np.empty(C)
    va = np.empty(C)
    xb = np.empty(C)
    vb = np.empty(C)
    xm = np.empty(C)
    z = np.empty(C)
    yo = np.empty(C)                     # y and the band's half-width Y(x): at the
    bo = np.empty(C)                     # step's start and end
    yn = np.empty(C)
    bn = np.empty(C)
    Hp = np.empty(C)                     # a step's impact: energy just before it,
    Up = np.empty(C)                     # the velocity then, the wall's G and r
    Gw = np.empty(C)
    Rw = np.empty(C)
    Tq = np.empty(C)                     # a crossing before an impact: time in the step
    st = np.empty(C, dtype=np.int64)     # slot j has done kstep − st[j] steps
    ids = np.empty(C, dtype=np.int64)
    q = starts[bb]
    qend = starts[bb + 1]
    n = 0
    kstep = 0
    due = np.iinfo(np.int64).max         # the first step at which a slot reaches kmax
    steps = 0.0
    n_end = 0.0
    n_bridge = 0.0
    while n < C and q < qend:
        i = order[q]
        _load(n, i, xs, ys, xa, va, ids, hh, a, bcub, hc, yo, bo)
        st[n] = -ks[i]
        due = min(due, kmax - ks[i])
        n += 1
        q += 1
    pk = 0                               # slots whose bridge goes through an impact
    while n > 0:
        for j in range(n):
            z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
        bad1, bad2 = K._smooth_sweep(xa, va, xb, vb, xm, z, n, hh, ha, hb, ec, sd0, d1s2,
                                     d2s2, has_d2, lo, hi)
        hit = 0
        pre = 0                         # displacement: crossed before an impact
        fast = 0                        # impact speed: an impact faster than uc
        while bad2 != 0:                # an impact in the second flight only
            j = trailing_zeros(bad2)
            bad2 &= bad2 - 1
            if kind == DISPLACEMENT:
                x0 = xm[j]
                xt = x0 + hh * vb[j]    # the flight up to the wall is this line
                if (x0 > xlo) & (x0 < xhi) & ((xt <= xlo) | (xt >= xhi)):
                    Tq[j] = hh * (1.0 + _cross_time(x0, xt, xlo, xhi))
                    pre |= 1 << j
            x, y, ml, mr, _, _, tl, tr, _, _, um = _flight(
                xm[j], vb[j], hh, 0.0, lo, hi, flo, fhi, rlo, rhi, maxk, lo, hi, None, 0.0,
                0.0, law, None, 0.0, 0)
            xb[j] = x
            vb[j] = y
            if ml + mr > 0:
                hit |= 1 << j
                _peak(j, ml, mr, tl, tr, glo, ghi, law, Hp, Up, Gw, Rw)
                if um > uc:
                    fast |= 1 << j
        while bad1 != 0:                # in the first flight (or a NaN): whole step
            j = trailing_zeros(bad1)
            bad1 &= bad1 - 1
            x = xa[j]
            f = -(a + bcub * x * x) * x
            x, y, f, ml, mr, _, _, tl, tr, _, _, um = K._step_full(
                x, va[j] + hh * f, f, z[j], hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo,
                fhi, rlo, rhi, has_d2, maxk, lo, hi, None, 0.0, 0.0, law, None, 0.0, 0)
            xb[j] = x
            vb[j] = y - hh * f
            if ml + mr > 0:
                hit |= 1 << j
                _peak(j, ml, mr, tl, tr, glo, ghi, law, Hp, Up, Gw, Rw)
                if um > uc:
                    fast |= 1 << j
        xa, xb = xb, xa                 # (xa, va) the new states, (xb, vb) the old
        va, vb = vb, va
        kstep += 1
        steps += n
        mid = 0                         # exits at an impact: timed at the middle
        if kind == ENERGY:
            ex, br = _monitor(xa, va, xb, n, hh, a, bcub, d1, d2, hc, cut2, bridge, yo, bo,
                              yn, bn)
        elif kind == DISPLACEMENT:
            ex = _monitor_x(xa, xm, n, xlo, xhi) | pre
            br = 0
            hit = 0
        else:
            ex = fast
            for j in range(n):
                if not (xa[j] == xa[j]):
                    ex |= 1 << j
            mid = fast
            br = 0
            hit = 0
        hit &= ~ex
        while hit != 0:
            j = trailing_zeros(hit)
            hit &= hit - 1
            if Hp[j] >= hc:
                ex |= 1 << j
                mid |= 1 << j
            elif bridge:                # bridge to the impact and from it (rare)
                x0 = xb[j]
                x1 = xa[j]
                sy = 2.0 * d1 + d2 * (x0 * x0 + x1 * x1)
                bw = math.sqrt(max(2.0 * (hc - Gw[j]), 0.0))
                pa = min(_cross(yo[j], bo[j], Up[j], bw, sy, dt), 1.0)
                pb = min(_cross(-Rw[j] * Up[j], bw, yn[j], bn[j], sy, dt), 1.0)
                Hp[j] = 1.0 - (1.0 - pa) * (1.0 - pb)      # now the crossing probability
                pk |= 1 << j
                if Hp[j] > P_CUT:
                    br |= 1 << j
        done = ex
        while ex != 0:
            j = trailing_zeros(ex)
            ex &= ex - 1
            i = ids[j]
            k = kstep - st[j]
            if kind == DISPLACEMENT:
                x1 = xa[j]
                if not (x1 == x1):
                    tout[i] = (k - 1) * dt
                    status[i] = FAILED
                    continue
                x0 = xb[j]
                x2 = xm[j]
                if (pre >> j) & 1:
                    s_ = Tq[j]
                elif not ((x2 > xlo) & (x2 < xhi)):
                    s_ = hh * _cross_time(x0, x2, xlo, xhi)
                else:
                    s_ = hh * (1.0 + _cross_time(x2, x1, xlo, xhi))
                tout[i] = (k - 1) * dt + s_
                status[i] = EXITED
                n_end += 1.0
                continue
            if kind == IMPACT_SPEED and not (xa[j] == xa[j]):
                tout[i] = (k - 1) * dt
                status[i] = FAILED
                continue
            if (mid >> j) & 1:
                tout[i] = (k - 0.5) * dt
                status[i] = EXITED
                n_end += 1.0
                continue
            y0, g0, _ = _state(xb[j], vb[j], hh, a, bcub, hc)
            y1, g1, _ = _state(xa[j], va[j], hh, a, bcub, hc)
            h0 = 0.5 * y0 * y0 + g0
            h1 = 0.5 * y1 * y1 + g1
            if h1 == h1:                # within the step, H linear between its ends
                tout[i] = (k - 1 + min((hc - h0) / (h1 - h0), 1.0)) * dt
                status[i] = EXITED
                n_end += 1.0
            else:
                tout[i] = (k - 1) * dt
                status[i] = FAILED
        while br != 0:
            j = trailing_zeros(br)
            br &= br - 1
            r, s0, s1, s2, s3 = _next(s0, s1, s2, s3)
            u = np.float64(np.int64(r >> _U11)) * _TWO_M53
            if (pk >> j) & 1:
                out = u < Hp[j]
            else:
                x0 = xb[j]
                x1 = xa[j]
                out = _crossed(u, yo[j], bo[j], yn[j], bn[j],
                               2.0 * d1 + d2 * (x0 * x0 + x1 * x1), dt)
            if out:
                i = ids[j]
                tout[i] = (kstep - st[j] - 0.5) * dt
                status[i] = EXITED
                n_bridge += 1.0
                done |= 1 << j
        pk = 0
        yo, yn = yn, yo
        bo, bn = bn, bo
        if kstep >= due:                # some slot at the horizon: park it
            due = np.iinfo(np.int64).max
            for j in range(n):
                k = kstep - st[j]
                if k >= kmax and not (done >> j) & 1:
                    done |= 1 << j
                    i = ids[j]
                    x = xa[j]
                    xs[i] = x
                    ys[i] = va[j] - hh * (a + bcub * x * x) * x
                    ks[i] = k
                elif not (done >> j) & 1:
                    due = min(due, st[j] + kmax)
        # refill the freed slots from the queue, then close the gaps from the end
        free = 0
        while done != 0:
            j = trailing_zeros(done)
            done &= done - 1
            if q < qend:
                i = order[q]
                _load(j, i, xs, ys, xa, va, ids, hh, a, bcub, hc, yo, bo)
                st[j] = kstep - ks[i]
                due = min(due, st[j] + kmax)
                q += 1
            else:
                free |= 1 << j
        while free != 0:
            j = trailing_zeros(free)
            free &= free - 1
            last = n - 1
            while last > j and (free >> last) & 1:
                free &= ~(1 << last)
                last -= 1
            n = last
            if last > j:
                xa[j] = xa[last]
                va[j] = va[last]
                yo[j] = yo[last]
                bo[j] = bo[last]
                st[j] = st[last]
                ids[j] = ids[last]
    rng[bb, 0] = s0
    rng[bb, 1] = s1
    rng[bb, 2] = s2
    rng[bb, 3] = s3
    counts[bb, 0] += steps
    counts[bb, 1] += n_end
    counts[bb, 2] += n_bridge
