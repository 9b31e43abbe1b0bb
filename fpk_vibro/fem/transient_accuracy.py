"""``fem.transient(..., rtol=...)``: the transient to a requested accuracy in space and
time, with an error estimate at every output time.

Levels are those of the stationary rtol solve (:mod:`fpk_vibro.fem.estimate`):
degree 2 on the wall-graded mesh of ``start_nx`` cells, then degrees 3 and 4, then
nx doubled.  Each level marches with adaptive BDF2 steps whose local L1 error is
kept below ``rtol / 4`` at the first level and 4× smaller at each richer one, so a
level is richer in space and in time.  The estimate of a level at each output time
is its difference to the next level (L1 and the relative moments, the same
:func:`~fpk_vibro.fem.estimate.difference`), times 2, plus the tail beyond y_max;
when the largest estimate over all output times, of the L1 error of the density and
of the relative moments alike (:data:`~fpk_vibro.fem.compare.AIMED`, issue 31), is
below ``rtol`` the level is returned, each density carrying its estimate
(``sol.error_estimate()``) and ``info["rtol_decided_by"]``, the quantity that came
nearest to rtol.  Assumption: the richer level is the more accurate in
space and time.  Refused in one line naming ``rtol`` when the next level would
take the run past :data:`MAX_SECONDS` or the budget.

The densities are Galerkin (a transient's "auto"); ``info["min_density"]`` and the
estimate's L1 say how far below 0 they go.
"""
from __future__ import annotations

import time
from typing import Any

from .._checks import InputError
from ..model import VibroImpactSystem
from .compare import AIMED, decided_by
from .estimate import richer_options, start_nx, worst
from .transient_estimate import estimates, give

__all__ = ["adaptive_transient", "MAX_SECONDS", "TIME_SHARE"]

#: Longest run (s): the next level is refused when the time spent plus its predicted
#: time (the last level's, scaled by DOFs^1.3 × 4 for the smaller steps) passes it.
MAX_SECONDS = 60.0
#: The first level's BDF2 local tolerance is rtol times this.
TIME_SHARE = 0.25


def adaptive_transient(system: VibroImpactSystem, initial: Any, times: Any, rtol: float,
                       opts: Any, progress: bool | None = None, *, march: Any) -> list:
    """The solve of ``fem.transient(system, ..., rtol=...)`` (module docstring).

    ``march`` is :func:`fpk_vibro.fem.transient.transient` (given by it: this module
    lies below it), which each level calls with its mesh, degree and BDF2 tolerance.
    """
    from .options import WALL_GRADING
    where = "fem.transient"
    t0 = time.perf_counter()
    level = opts.replace(degree=2, nx=start_nx(system, opts), ny=None, rtol=None,
                         wall_grading=opts.wall_grading or WALL_GRADING)
    tol = TIME_SHARE * rtol
    history: list = []
    last: list = []

    def run(o, tol_step):
        if last:
            guess = last[0] * (o.ndofs(system) / last[1]) ** 1.3 * 4.0
            if time.perf_counter() - t0 + guess > MAX_SECONDS:
                reached = (f"the estimate is {history[-1][2]:.2g} at degree "
                           f"{history[-1][0]}, nx = {history[-1][1]}" if history
                           else "no estimate yet")
                raise InputError(f"{where}: rtol = {rtol:g} is not reached ({reached}) "
                                 f"within {MAX_SECONDS:g} s: the next level (degree "
                                 f"{o.degree}, nx = {o.nx}) would take ~{guess:.0f} s; give "
                                 "a larger rtol, or nx and degree", where=where, name="rtol")
        t1 = time.perf_counter()
        sols = march(system, initial=initial, times=times, degree=o.degree, nx=o.nx,
                     ny=o.ny, y_max=o.y_max, wall_grading=o.wall_grading, tol=tol_step,
                     progress=progress)
        last[:] = [time.perf_counter() - t1, o.ndofs(system)]
        return sols

    cur = run(level, tol)
    while True:
        nxt_opts = richer_options(level, cur[-1])
        nxt = run(nxt_opts, tol / 4.0)
        t1 = time.perf_counter()
        ests = estimates(cur, nxt)
        e = max(worst(est, AIMED) for est in ests)
        history.append((level.degree, level.nx, e))
        if e <= rtol:
            break
        cur, level, tol = nxt, nxt_opts, tol / 4.0
    # the estimate's seconds: the richer level's run and the comparisons
    give(cur, ests, in_time=f"the BDF2 local tolerance {tol:.2g} against {tol / 4:.2g}",
         richer=f"degree {nxt_opts.degree}, nx {nxt_opts.nx}, tol {tol / 4:.2g}",
         seconds=last[0] + time.perf_counter() - t1, rtol=rtol,
         adapt_seconds=time.perf_counter() - t0,
         adapt_levels="; ".join(f"degree {d}, nx {n}: {x:.2g}" for d, n, x in history),
         rtol_decided_by=decided_by(max(ests, key=lambda est: worst(est, AIMED))))
    return cur

