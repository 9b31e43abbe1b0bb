"""The BAOAB step of the CPU engine: the scalar step with exact impacts and the
vectorised sweep of the paths that hit no wall (compiled, numba; :mod:`._kernel` has
the scheme, :mod:`._block` runs them over a block of paths).

The scalar step here is the CPU engine's own compilation of the scheme of
:mod:`._scalar_step` (that module's plain functions are the reference that the GPU
compiles, and the tests check these against them).
"""
from __future__ import annotations

import math

from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from ._flight import _flight
from ._rng import FASTMATH


@intrinsic
def _fma(typingctx, a, b, c):
    """a*b + c rounded once (``llvm.fma``: FMA instructions, vectorised; a libm
    call on a CPU without FMA, same result).

    Written out rather than left to contraction (``_rng.FASTMATH``), so that every
    compiled copy of a function rounds alike.
    """
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)
    return sig, codegen


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step_core(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi,
               has_d2, maxk, lo_t, hi_t, hu, iwl, iwr, law, ext, t0, i, gg):
    """One BAOAB step (module docstring); f = F(x) on entry and on return.

    Returns (x, y, f) and the wall statistics of the step as :func:`._flight._flight`
    gives them (impacts left, right, Σu left, right, Σu² left, right, Σe left, right,
    largest u); ``hu``, ``iwl``, ``iwr``, ``law``, ``ext``, ``i``: as there (``t0``
    the step's start time).  ``gg``: None, or (g0, g1): the kicks add the harmonic
    force, g0 at the step's start (opening kick, and the wall force of the first
    flight) and g1 at its end (second flight, closing kick); f stays F(x) alone.
    (At most 30 arguments: beyond, CPython 3.11 passes them as *args, which numba
    cannot inline.)
    """
    fo = f
    flo1 = flo
    fhi1 = fhi
    if gg is not None:
        g0 = gg[0]
        fo = f + g0
        flo1 = flo + g0
        fhi1 = fhi + g0
    y += hh * fo
    x, y, nl, nr, ul, ur, ql, qr, el, er, um = _flight(
        x, y, hh, -hh, lo, hi, flo1, fhi1, rlo, rhi, maxk, lo_t, hi_t, hu, iwl, iwr, law,
        ext, t0, i)
    if has_d2:
        y = ec * y + math.sqrt(d1s2 + d2s2 * x * x) * z
    else:
        y = ec * y + sd0 * z
    flo2 = flo
    fhi2 = fhi
    if gg is not None:
        flo2 = flo + gg[1]
        fhi2 = fhi + gg[1]
    x, y, nl2, nr2, ul2, ur2, ql2, qr2, el2, er2, um2 = _flight(
        x, y, hh, 0.0, lo, hi, flo2, fhi2, rlo, rhi, maxk, lo_t, hi_t, hu, iwl, iwr, law,
        ext, t0 + hh, i)
    f = -(a + bcub * x * x) * x
    fo = f
    if gg is not None:
        fo = f + gg[1]
    return (x, y + hh * fo, f, nl + nl2, nr + nr2, ul + ul2, ur + ur2, ql + ql2, qr + qr2,
            el + el2, er + er2, max(um, um2))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step_full(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi,
               has_d2, maxk, lo_t, hi_t, hu, iwl, iwr, law, ext, t0, i):
    """:func:`_step_core` without forcing: one BAOAB step, f = F(x) on entry and on
    return; the wall statistics as :func:`._flight._flight` gives them."""
    return _step_core(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo,
                      rhi, has_d2, maxk, lo_t, hi_t, hu, iwl, iwr, law, ext, t0, i, None)


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _step_walls(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi,
                has_d2, maxk, lo_t, hi_t, hu=None, iwl=0.0, iwr=0.0):
    """:func:`_step_full` with constant restitutions ``rlo``, ``rhi``, returning (x, y,
    f, impacts left, right, Σu left, right, Σu² left, right): the scalar reference
    of the tests."""
    (x, y, f, nl, nr, ul, ur, ql, qr, _, _, _) = _step_full(
        x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, rlo, rhi, has_d2,
        maxk, lo_t, hi_t, hu, iwl, iwr, None, None, 0.0, 0)
    return x, y, f, nl, nr, ul, ur, ql, qr


@njit(cache=True, fastmath=FASTMATH)
def _step(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub, lo, hi, flo, fhi, r, mode,
          has_d2, maxk, lo_t, hi_t):
    """:func:`_step_walls` with one restitution ``r`` on both walls, returning (x, y,
    f, impacts): the plain scalar scheme the vectorised sweep is checked against
    (``mode`` is not needed: an absent wall is at ∓inf)."""
    x, y, f, nl, nr, _, _, _, _ = _step_walls(x, y, f, z, hh, ec, sd0, d1s2, d2s2, a, bcub,
                                              lo, hi, flo, fhi, r, r, has_d2, maxk, lo_t,
                                              hi_t)
    return x, y, f, nl + nr


# paths advanced together in a block: the vectorised sweep's length, at most 64
# (one bit per path in the sweep's int64 mask)
CHUNK = 64


@njit(cache=True, fastmath=FASTMATH)
def _smooth_sweep(xa, va, xb, vb, xm, z, n, hh, ha, hb, ec, sd0, d1s2, d2s2, has_d2,
                  lo_t, hi_t):
    """One step of n paths from (xa, va) into (xb, vb), assuming no impact.

    The state is kept in kick-merged (leapfrog) form: v is the velocity before
    the closing half kick, y = v + (h/2) F(x), so the closing kick of one step
    and the opening kick of the next are one kick v + h F(x) (``ha`` = h a,
    ``hb`` = h b) and the force is evaluated once per step.

    Branch-free, so the compiler vectorises it (SIMD over paths).  Returns two
    bit masks (bit j for path j, n ≤ 64) of the paths where the assumption
    fails: ``bad1``, the first flight left [lo_t, hi_t] (or a NaN), and
    ``bad2``, only the second did.  :func:`_run_block` redoes the former with
    the exact :func:`_step` from (xa, va), which this sweep leaves untouched (it
    writes into separate arrays), and the latter from the midpoint it stores,
    x1 in ``xm`` and the velocity after the O step in ``vb``, by the second
    flight alone.
    """
    bad1 = 0
    bad2 = 0
    for j in range(n):
        x = xa[j]
        y1 = _fma(-_fma(hb * x, x, ha), x, va[j])             # v − (ha + hb x²) x
        x1 = _fma(hh, y1, x)
        if has_d2:
            y2 = _fma(math.sqrt(_fma(d2s2 * x1, x1, d1s2)), z[j], ec * y1)
        else:
            y2 = _fma(sd0, z[j], ec * y1)
        x2 = _fma(hh, y2, x1)
        ok1 = (x1 >= lo_t) & (x1 <= hi_t)
        ok2 = (x2 >= lo_t) & (x2 <= hi_t)
        xb[j] = x2
        vb[j] = y2
        xm[j] = x1
        bad1 |= (0 if ok1 else 1) << j
        bad2 |= (0 if ok2 else 1) << j
    return bad1, bad2 & ~bad1
