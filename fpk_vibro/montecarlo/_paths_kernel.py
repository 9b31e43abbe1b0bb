"""Stationary paths sampled on a fixed interval, with level crossings and excursion
peaks counted at every step (compiled, numba): the CPU kernel of :mod:`._paths`.

The paths advance by the engine's own step, in the engine's own order: a block of
paths draws its normals chunk by chunk (:data:`._sweep.CHUNK` paths), step by step,
path by path from its stream, the vectorised :func:`._sweep._smooth_sweep` moves
every path as if no wall were hit, and the few it flags are redone with exact
impacts by :func:`._flight._flight` (an impact in the second free flight only) or
:func:`._sweep._step_core` (one in the first) — the calls of :func:`._block._run_block`.
So a seed gives the very paths :func:`._kernel.advance` gives (tested bit for bit).
Coloured external noise ζ enters the kicks as there (:mod:`._block`).

Sampling: after every ``every``-th step the state (x, y) of each path is written to
the next column of ``outx`` / ``outy`` (no column: not kept).

Counting (the crossings): the scheme's path is piecewise linear in x — a free flight
x += (h/2) y from the step's start x₀ to its midpoint x_m, another to its end x₁ —
with the walls it touches in between (:mod:`._flight`: an impact reverses the
motion).  A level b is up-crossed where the path passes from x < b to x ≥ b between
two consecutive vertices x₀, [walls], x_m, [walls], x₁ (exact for that path: it is
monotone between them).  A level at the left wall is taken as the next float above
it, so that its "up-crossings" are the departures from the wall, and a level at the
right wall counts the arrivals on it: both the impacts (two touches of one wall
within a step count as two, the path having left it in between).  Where the first
free flight of a step hits a wall the step is redone whole (:func:`._sweep._step_core`)
and its midpoint is not known: its vertices are then x₀, the walls touched, x₁ —
what this can miss needs the velocity to reverse within that step's O kick.
Excursions: the path is "above" from an up-crossing of the reference m to the next
down-crossing; the largest vertex in between is the excursion's peak, counted in
the histogram of the levels it reaches (an excursion already under way when the
counting starts is not counted).

Counts go to ``cnt[b]``, the row of block b: ``[0, L)`` up-crossings of each level,
``[L, 2L]`` peaks by the number of levels at or below them, ``2L + 1`` excursions
started (up-crossings of m).  Each path carries its counting state in ``pst[i]``:
the number of levels at or below x, the excursion state (0 below m, 1 above, 2 above
since before the counting), the running peak, and the bracket of levels around x;
a chunk holds them field by field while it runs, so that the test of the paths that
hit no wall — do x_m, x₁ leave the bracket or cross m? — is one branch-free,
vectorised loop (:func:`_count_smooth`), and only the few that do are counted one by
one.  Counting six levels on the paper's case (one thread, load average 7 on two
cores) ran at 3.4–4·10⁷ path-steps/s against 0.9–1.1·10⁸ without: each crossing
event is branchy work (~0.1 events a path-step there).

:func:`visit` and :func:`touches` are plain functions, compiled here by ``njit`` and
for the GPU by :mod:`._cuda_paths`: one definition of the counting.  The helpers that
take arrays in the hot loop are inlined (``inline="always"``): a call passing arrays
costs numba a reference-count increment and decrement each (about 150 ns per
counted event measured before inlining).
"""
from __future__ import annotations

import math
import types

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from ._flight import LEFT, RIGHT, _flight
from ._rng import FASTMATH, _normal
from ._sweep import CHUNK, _smooth_sweep, _step_core, _step_full

__all__ = ["visit_py", "touches_py", "build", "paths_block", "PST", "bracket"]

#: Columns of a path's counting state ``pst[i]``.
P_IDX, P_ST, P_MAX, P_LO, P_HI = range(5)
PST = 5


def visit_py(v, idx, st, pmax, lev, L, m, cb):
    """The path moves monotonically on to x = v: the level up-crossings and the
    excursion bookkeeping of the module docstring; returns (idx, st, pmax)."""
    while idx < L and lev[idx] <= v:
        cb[idx] += 1.0
        idx += 1
    while idx > 0 and lev[idx - 1] > v:
        idx -= 1
    if st == 0:
        if v >= m:
            st = 1
            pmax = v
            cb[2 * L + 1] += 1.0
    elif v < m:
        if st == 1:
            k = 0
            while k < L and lev[k] <= pmax:
                k += 1
            cb[L + k] += 1.0
        st = 0
    elif v > pmax:
        pmax = v
    return idx, st, pmax


def touches_py(nl, nr, right, lo, hi, lo_in, hi_in, idx, st, pmax, lev, L, m, cb):
    """The walls touched in one free flight (``nl`` left, ``nr`` right impacts,
    ``right`` 1 when the flight moves right first), each a vertex: in a linear flight
    they alternate; a second touch of the same wall (the counts of two flights taken
    together) is preceded by a vertex just off that wall (``lo_in``, ``hi_in``).
    ``visit`` is the target's compilation of :func:`visit_py` (:func:`build`)."""
    prev = -1
    while nl + nr > 0:
        if right == 1 and nr == 0:
            right = 0
        elif right == 0 and nl == 0:
            right = 1
        if right == prev:
            idx, st, pmax = visit(hi_in if right == 1 else lo_in, idx, st, pmax, lev, L,
                                  m, cb)
        if right == 1:
            idx, st, pmax = visit(hi, idx, st, pmax, lev, L, m, cb)
            nr -= 1
        else:
            idx, st, pmax = visit(lo, idx, st, pmax, lev, L, m, cb)
            nl -= 1
        prev = right
        right = 1 - right
    return idx, st, pmax


def build(jit):
    """(visit, touches) compiled by ``jit`` (the GPU's ``cuda.jit(device=True)``):
    :func:`touches_py` rebound to that target's ``visit``."""
    v = jit(visit_py)
    fn = touches_py
    g = dict(fn.__globals__, visit=v)
    t = types.FunctionType(fn.__code__, g, fn.__name__, fn.__defaults__, fn.__closure__)
    return v, jit(t)


visit = njit(cache=True, fastmath=FASTMATH, inline="always")(visit_py)
touches = njit(cache=True, fastmath=FASTMATH)(touches_py)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def bracket(cs, j, idx, st, pmax, lev, L):
    """Store path j's counting state (column j of the chunk's ``cs``) and the levels
    around it."""
    cs[P_IDX, j] = idx
    cs[P_ST, j] = st
    cs[P_MAX, j] = pmax
    cs[P_LO, j] = lev[idx - 1] if idx > 0 else -math.inf
    cs[P_HI, j] = lev[idx] if idx < L else math.inf


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _slow(cs, j, v1, v2, lev, L, m, cb):
    """Path j moves through v1 then v2, crossing a level or m (the general count)."""
    idx, st, pmax = visit(v1, int(cs[P_IDX, j]), int(cs[P_ST, j]), cs[P_MAX, j], lev, L,
                          m, cb)
    idx, st, pmax = visit(v2, idx, st, pmax, lev, L, m, cb)
    bracket(cs, j, idx, st, pmax, lev, L)


@njit(cache=True, fastmath=FASTMATH)
def _impact_step(cs, j, xm, x1, nl, nr, right, whole, lo, hi, lo_in, hi_in, lev, L, m,
                 cb):
    """Count a step with impacts: ``whole`` (the first flight hit: x₀, walls, x₁) or
    not (x₀, x_m, walls of the second flight, x₁)."""
    idx = int(cs[P_IDX, j])
    st = int(cs[P_ST, j])
    pmax = cs[P_MAX, j]
    if not whole:
        idx, st, pmax = visit(xm, idx, st, pmax, lev, L, m, cb)
    idx, st, pmax = touches(nl, nr, right, lo, hi, lo_in, hi_in, idx, st, pmax, lev, L,
                            m, cb)
    idx, st, pmax = visit(x1, idx, st, pmax, lev, L, m, cb)
    bracket(cs, j, idx, st, pmax, lev, L)


@njit(cache=True, fastmath=FASTMATH)
def _count_smooth(cs, xm, xb, n, skip, m):
    """The paths of a chunk that hit no wall: a bit mask of those whose vertices x_m,
    x₁ cross a level or m (for :func:`_slow`); the others only raise their running
    peak.  Branch-free over the chunk (vectorised)."""
    flag = 0
    for j in range(n):
        v1 = xm[j]
        v2 = xb[j]
        vmin = min(v1, v2)
        vmax = max(v1, v2)
        st = cs[P_ST, j]
        out = (vmin < cs[P_LO, j]) | (vmax >= cs[P_HI, j]) | \
            ((st == 0.0) & (vmax >= m)) | ((st != 0.0) & (vmin < m)) | \
            (((skip >> j) & 1) != 0)
        pm = cs[P_MAX, j]
        cs[P_MAX, j] = pm if out else max(pm, vmax)
        flag |= (1 if out else 0) << j
    return flag & ~skip


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def paths_block(b, xs, ys, zeta, rng, starts, n_steps, every, p, ip, law, wcnt, outx,
                outy, lev, m, cnt, pst, lo_in, hi_in):
    """Block b: ``n_steps`` steps of its paths (module docstring), sampling after every
    ``every``-th step into ``outx``/``outy`` (0 columns: none) and counting into
    ``cnt[b]`` with the path states ``pst`` (0 rows: no counting); ``wcnt[b]`` += left
    and right impacts and the path-steps.  ``zeta``: the paths' ζ (empty: white)."""
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
    hu = np.zeros((2, 0))
    has_d2 = ip.has_d2 != 0
    maxk = ip.max_impacts
    col = zeta.shape[0] > 0
    ze = p.z_e
    zsd = p.z_s
    kz = p.z_k
    h = 2.0 * hh
    ha = h * a
    hb = h * bcub
    sample = outx.shape[1] > 0
    with_y = outy.shape[1] > 0
    count = pst.shape[0] > 0
    L = lev.shape[0]
    cb = cnt[b]
    s0 = rng[b, 0]
    s1 = rng[b, 1]
    s2 = rng[b, 2]
    s3 = rng[b, 3]
    nl = 0
    nr = 0
    xa = np.empty(CHUNK)
    va = np.empty(CHUNK)
    xb = np.empty(CHUNK)
    vb = np.empty(CHUNK)
    xm = np.empty(CHUNK)
    vk = np.empty(CHUNK)
    z = np.zeros(CHUNK)
    zc = np.empty(CHUNK)
    zn = np.empty(CHUNK)
    cs = np.empty((PST, CHUNK))     # the chunk's counting states, field by field
    end = starts[b + 1]
    for i0 in range(starts[b], end, CHUNK):
        n = min(CHUNK, end - i0)
        if count:
            for j in range(n):
                for c in range(PST):
                    cs[c, j] = pst[i0 + j, c]
        for j in range(n):
            x = xs[i0 + j]
            xa[j] = x
            va[j] = ys[i0 + j] + hh * (a + bcub * x * x) * x      # v = y − (h/2) F(x)
            if col:
                zc[j] = zeta[i0 + j]
                va[j] -= hh * (kz * zc[j])
        cnt_s = every
        col_s = 0
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
            bad1, bad2 = _smooth_sweep(xa, vin, xb, vb, xm, z, n, hh, ha, hb, ec, sd0,
                                       d1s2, d2s2, has_d2, lo, hi)
            skip = bad1 | bad2
            while bad2 != 0:                # an impact in the second flight only
                j = trailing_zeros(bad2)
                bad2 &= bad2 - 1
                flo2 = flo
                fhi2 = fhi
                if col:
                    flo2 = flo + kz * zn[j]
                    fhi2 = fhi + kz * zn[j]
                right = 1 if vb[j] > 0.0 else 0
                x, y, ml, mr, _, _, _, _, _, _, _ = _flight(
                    xm[j], vb[j], hh, 0.0, lo, hi, flo2, fhi2, rlo, rhi, maxk, lo, hi, hu,
                    0.0, 0.0, law, None, 0.0, 0)
                xb[j] = x
                vb[j] = y
                nl += ml
                nr += mr
                if count:
                    _impact_step(cs, j, xm[j], x, ml, mr, right, False, lo, hi,
                                 lo_in, hi_in, lev, L, m, cb)
            while bad1 != 0:                # in the first flight (or a NaN): whole step
                j = trailing_zeros(bad1)
                bad1 &= bad1 - 1
                x = xa[j]
                right = 1 if xm[j] > hi else 0
                f = -(a + bcub * x * x) * x
                if col:
                    g0 = kz * zc[j]
                    g1 = kz * zn[j]
                    x, y, f, ml, mr, _, _, _, _, _, _, _ = _step_core(
                        x, va[j] + hh * (f + g0), f, z[j], hh, ec, sd0, d1s2, d2s2, a, bcub,
                        lo, hi, flo, fhi, rlo, rhi, has_d2, maxk, lo, hi, hu, 0.0, 0.0, law,
                        None, 0.0, 0, (g0, g1))
                    vb[j] = y - hh * (f + g1)
                else:
                    x, y, f, ml, mr, _, _, _, _, _, _, _ = _step_full(
                        x, va[j] + hh * f, f, z[j], hh, ec, sd0, d1s2, d2s2, a, bcub, lo,
                        hi, flo, fhi, rlo, rhi, has_d2, maxk, lo, hi, hu, 0.0, 0.0, law,
                        None, 0.0, 0)
                    vb[j] = y - hh * f
                xb[j] = x
                nl += ml
                nr += mr
                if count:
                    _impact_step(cs, j, xm[j], x, ml, mr, right, True, lo, hi,
                                 lo_in, hi_in, lev, L, m, cb)
            if count:
                flag = _count_smooth(cs, xm, xb, n, skip, m)
                while flag != 0:
                    j = trailing_zeros(flag)
                    flag &= flag - 1
                    _slow(cs, j, xm[j], xb[j], lev, L, m, cb)
            xa, xb = xb, xa
            va, vb = vb, va
            if col:
                zc, zn = zn, zc
            if sample:
                cnt_s -= 1
                if cnt_s == 0:
                    cnt_s = every
                    for j in range(n):
                        x = xa[j]
                        outx[i0 + j, col_s] = x
                        if with_y:
                            y = va[j] - hh * (a + bcub * x * x) * x
                            if col:
                                y += hh * (kz * zc[j])
                            outy[i0 + j, col_s] = y
                    col_s += 1
        if count:
            for j in range(n):
                for c in range(PST):
                    pst[i0 + j, c] = cs[c, j]
        for j in range(n):
            x = xa[j]
            xs[i0 + j] = x
            ys[i0 + j] = va[j] - hh * (a + bcub * x * x) * x
            if col:
                ys[i0 + j] += hh * (kz * zc[j])
                zeta[i0 + j] = zc[j]
    wcnt[b, LEFT] += nl
    wcnt[b, RIGHT] += nr
    wcnt[b, 2] += (starts[b + 1] - starts[b]) * float(n_steps)
    rng[b, 0] = s0
    rng[b, 1] = s1
    rng[b, 2] = s2
    rng[b, 3] = s3
