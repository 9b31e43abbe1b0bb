"""``fem.stationary(system, rtol=...)``: the accuracy-driven solve.

It solves Galerkin levels until the error estimate of one (its difference to the
next richer level, :mod:`fpk_vibro.fem.estimate`, with its non-negative correction)
is below ``rtol`` for every quantity rtol bounds: E[H], E[x²], E[y²], P_impact
(relative) and the L1 error of the density (:data:`~fpk_vibro.fem.compare.AIMED`);
that level is returned, made non-negative, carrying the estimate.  The levels, where
they start and how nx grows from the measured convergence rate, and the limits:
:mod:`fpk_vibro.fem.ladder`.

Where the goal is beyond the limits (the time, the budget of
:mod:`fpk_vibro.budget`, nx = 4096) the solve stops before it spends them: an
explicit rtol is refused in one line naming rtol, the estimate reached and the
level that would be needed; the default (best effort) returns its last estimated
level, flagged ``under_resolved``, with one RuntimeWarning naming its estimate and
what to give instead.  ``info``: ``rtol``, ``rtol_decided_by`` (the quantity whose
estimate came nearest to rtol at the level returned: the one that decided it),
``adapt_levels`` (each level's largest estimate and its quantity),
``adapt_seconds``.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from .compare import AIMED, KEYS, decided_by, difference, worst
from .estimate import ASSUMES, SAFETY, add_correction, error_estimate
from .ladder import (BEST_RATE, COST_POWER, DEFAULT_SECONDS, MAX_NX, MAX_SECONDS,
                     PREASYMPTOTIC, STEP, first_level, measured_rates, next_grid,
                     richer_levels)

__all__ = ["adaptive"]


class _Ladder:
    """The levels solved so far, their seconds and estimates, and the limits."""

    def __init__(self, system, rtol: float, limit: float) -> None:
        self.system, self.rtol, self.limit = system, rtol, limit
        self.t0 = time.perf_counter()
        self.solved: dict[tuple[int, int, int], Any] = {}
        self.timing: list[tuple[float, int]] = []        # (seconds, DOFs) of each solve
        #: (degree, nx, ny, {"x": parts, "y": parts}) and (degree, nx, ny, estimate)
        #: of each estimated level
        self.history: list[tuple] = []
        self.estimates: list[tuple] = []
        self.best_effort = False
        #: why the goal is out of reach, where best effort goes on within the limit
        self.short: str | None = None

    def spent(self) -> float:
        return time.perf_counter() - self.t0

    def seconds(self, o) -> float:
        """Predicted seconds of solving level ``o``: the cost model before any solve,
        then the median of the recent solves (at least half the DOFs of the largest
        so far) scaled by DOFs^COST_POWER.  (Not the largest: the first solve of a
        process carries one-off costs, 0.17 s against 0.03 s warm at 6 837 DOFs, and
        the default stopped at nx = 16 on it.)"""
        if not self.timing:
            return o.estimate(self.system, "stationary").seconds
        n, top = o.ndofs(self.system), max(m for _, m in self.timing)
        return float(np.median([s * (n / m) ** COST_POWER for s, m in self.timing
                                if 2 * m >= top]))

    def reached(self) -> str:
        if not self.estimates:
            return "nothing estimated yet"
        d, n, m, e = self.estimates[-1]
        return (f"the estimate is {worst(e, AIMED):.2g} ({decided_by(e)}) at degree {d}, "
                f"nx = {n}, ny = {m}")

    def solve(self, o):
        """The Galerkin solution of level ``o`` (once), within the budget and the
        time limit (else an InputError naming rtol)."""
        from .._checks import InputError
        from ..budget import enforce, forced
        from .discretisation import build
        key = _key(o)
        if key not in self.solved:
            where = f"the next level (degree {o.degree}, nx = {o.nx})"
            if o.nx > MAX_NX:
                raise _beyond(self, f"{where} passes nx = {MAX_NX}")
            guess = self.seconds(o)
            if not forced() and self.spent() + guess > self.limit:
                raise _beyond(self, f"{where} would take the solve to ~"
                                    f"{self.spent() + guess:.0f} s > {self.limit:g} s")
            try:
                enforce(o.estimate(self.system, "stationary"), "fem.stationary")
            except InputError as exc:
                raise _beyond(self, f"{where} is beyond the budget "
                                    f"({str(exc).split(': ', 1)[-1]})") from None
            t1 = time.perf_counter()
            sol = build(self.system, o).stationary(o.solver)
            sol._options = o
            self.timing.append((time.perf_counter() - t1, o.ndofs(self.system)))
            self.solved[key] = sol
        return self.solved[key]


def _beyond(lad: _Ladder, why: str):
    from .._checks import InputError
    where = "fem.stationary"
    return InputError(f"{where}: rtol = {lad.rtol:g} is not reached: {lad.reached()}, and "
                      f"{why}; give a larger rtol, or nx and degree", where=where, name="rtol")


def _key(o) -> tuple[int, int, int]:
    return (o.degree, o.nx, o.ny)


def _step(level) -> list:
    """``level`` and the richer levels that estimate it: degree + 1 on the same mesh,
    or at degree 4 the mesh refined in x and, separately, in y."""
    return [level, *richer_levels(level)]


def _plan(lad: _Ladder, level, est: dict, parts: dict) -> list:
    """The next level to estimate after ``level`` missed rtol with ``est``
    (``parts``: its x and y parts at degree 4), or raise where the goal is beyond
    the limits (module docstring)."""
    from ..budget import forced
    if level.degree < 4:                   # the richer level, solved: climb the degree
        return _step(richer_levels(level)[0])
    aimed = {k: float(est[k]) for k in AIMED if k in est}
    rates = measured_rates(lad.history)
    # a direction that stalled while refined alone may only wait for the other one:
    # judged out of reach by its rate only after a step that refined both
    both = _refined_both(lad.history)
    trusted = {key: q for key, q in rates.items() if q >= 1.0 or both}
    best = next_grid(level.nx, level.ny, aimed, parts, lad.rtol, trusted, BEST_RATE,
                     cap=math.inf)
    nx, ny = next_grid(level.nx, level.ny, aimed, parts, lad.rtol, rates)
    nx = max(nx, min(best[0], int(STEP[1] * level.nx)))
    ny = max(ny, min(best[1], int(STEP[1] * level.ny)))
    # judged out of reach only in the asymptotic range (a rate measured, or the
    # estimate below PREASYMPTOTIC): coarse levels often converge faster than that
    asymptotic = bool(rates) or worst(est, AIMED) <= PREASYMPTOTIC

    def step(n, m):
        return _step(level.replace(nx=n, ny=m))

    def seconds(levels: list) -> float:
        return sum(lad.seconds(o) for o in levels if _key(o) not in lad.solved)

    left = math.inf if forced() else lad.limit - lad.spent()
    reach = 2 * best[0] <= MAX_NX and seconds(step(*best)) <= left
    if asymptotic and not reach:
        why = (f"nx = {best[0]} would be needed (at most {MAX_NX // 2} with its richer "
               "levels)" if 2 * best[0] > MAX_NX else
               f"the next level (degree 4, nx = {best[0]}, ny = {best[1]}) and its richer "
               f"ones would take ~{seconds(step(*best)):.0f} s, beyond the {lad.limit:g} s "
               "limit")
        if not lad.best_effort:
            raise _beyond(lad, why)
        lad.short = why                     # (best effort: the largest that fits)
    while seconds(step(nx, ny)) > left or 2 * nx > MAX_NX:     # the largest that fits
        nx = max(level.nx, int(nx / STEP[0]) // 2 * 2) if nx > level.nx else nx
        ny = max(level.ny, int(ny / STEP[0]) // 2 * 2) if ny > level.ny else ny
        if max(nx / level.nx, ny / level.ny) < STEP[0]:
            raise _beyond(lad, lad.short or f"no finer level fits the {lad.limit:g} s limit")
    for r in richer_levels(level):         # (solved: one may serve as the next level)
        if abs(nx - r.nx) <= 0.1 * r.nx and abs(ny - r.ny) <= 0.1 * r.ny:
            return _step(r)
    return step(nx, ny)


def _refined_both(history: list) -> bool:
    """Whether the last step between degree-4 levels of ``history`` refined x and y
    (each by 1.2× at least): only then is a slow measured rate the direction's own."""
    fours = [h for h in history if h[0] == 4]
    return len(fours) > 1 and min(fours[-1][1] / fours[-2][1],
                                  fours[-1][2] / fours[-2][2]) >= 1.2


def _directions(lad: _Ladder, level, cur, richer: list) -> tuple[dict, dict]:
    """(summed differences, {"x": aimed parts, "y": ...}) of ``cur`` to its richer
    levels (a single richer level, of the degree: no parts).  Where a direction's
    part of a quantity fell slowly since the last degree-4 level that refined it
    (q = :func:`~fpk_vibro.fem.ladder.measured_rates`, ρ = 2^−q per halving of h),
    the part is taken as the sum of the geometric tail it stands for, ρ/(1 − ρ) of
    it, where that exceeds SAFETY/2: the difference to h/2 bounds the error by
    2 · difference only while ρ ≤ 3/4.  Only after a step that refined both
    directions: refined alone, a part can stall on the other direction's error
    (one-sided r = 0.6 wall, D1 = 0.01: the x part 1.0e-4 → 9.4e-5 from nx 36 to 90
    at ny = 30, the error 7e-5; inflated, the estimate was 38× the error).  Measured at r = 0.05 (softening, c = 0.02,
    Q4 at nx 16 → 128): L1 differences 5.4e-2, 4.4e-2, 3.9e-2 per halving, ρ = 0.87."""
    diffs = [difference(cur, r) for r in richer]
    total = {k: sum(float(d[k]) for d in diffs) for k in diffs[0]}
    if len(diffs) < 2:
        return total, {}
    parts = {a: {k: float(d[k]) for k in AIMED if k in d} for a, d in zip(("x", "y"), diffs)}
    history = lad.history + [(level.degree, level.nx, level.ny, parts)]
    rates = measured_rates(history)
    if not _refined_both(history):      # a part that stalled while its direction was
        rates = {}                      # refined alone may wait for the other one
    for (a, k), q in rates.items():
        rho = 2.0 ** -q
        factor = max(1.0, rho / (1.0 - rho) / (SAFETY / 2.0))
        total[k] += (factor - 1.0) * parts[a][k]
    return total, parts


def adaptive(system, opts, rtol: float, *, best_effort: bool = False):
    """The solve of ``fem.stationary(system, rtol=...)`` (module docstring).

    ``best_effort`` (the default rtol, no option given): where the goal is beyond the
    limits the last level with an estimate is returned, flagged ``under_resolved``,
    instead of refused, and one RuntimeWarning says so.
    """
    from .._checks import InputError
    from .nonnegative import correct
    limit = DEFAULT_SECONDS if best_effort else MAX_SECONDS
    lad = _Ladder(system, rtol, limit)
    lad.best_effort = best_effort
    unbounded = {**{k: math.inf for k in KEYS}, "assumes": ASSUMES.format(safety=SAFETY),
                 "richer": "none (the next level is beyond the budget)"}
    best = None
    step = _step(first_level(system, opts, rtol))
    while True:
        try:
            cur = lad.solve(step[0])
            if best is None:
                best = (correct(cur), dict(unbounded))
            richer = [lad.solve(o) for o in step[1:]]
            level = step[0]
            diff, parts = _directions(lad, level, cur, richer)
            est = error_estimate(cur, richer=tuple(richer), diff=diff)
            fixed = correct(cur)
            if fixed is not cur:
                est = add_correction(est, fixed.info["correction"])
            # (the estimate of the answer this level gives: its correction included)
            lad.history.append((level.degree, level.nx, level.ny, parts))
            lad.estimates.append((level.degree, level.nx, level.ny,
                                  {k: float(est[k]) for k in AIMED if k in est}))
            best = (fixed, est)
            if worst(est, AIMED) <= rtol:
                cur = fixed
                break
            step = _plan(lad, level, est, parts)
        except InputError as exc:
            if not best_effort or best is None:
                raise
            cur, est = best
            est["not_reached"] = str(exc)
            break
    est["levels"] = "; ".join(f"degree {d}, nx {n}, ny {m}: {worst(e, AIMED):.2g} "
                              f"({decided_by(e)})" for d, n, m, e in lad.estimates)
    cur._estimate = est
    cur.info.update(rtol=rtol, adapt_seconds=lad.spent(), adapt_levels=est["levels"],
                    positivity="auto", rtol_decided_by=decided_by(est))
    if "not_reached" in est:
        cur.info["rtol_not_reached"] = est["not_reached"]
    cur._apply_estimate()
    if best_effort and worst(est, AIMED) > rtol:
        _warn_shortfall(cur, est, rtol, limit)
    return cur


def _warn_shortfall(sol, est: dict[str, Any], rtol: float, limit: float) -> None:
    """The one RuntimeWarning of a best-effort solve that missed ``rtol``: the
    estimate of what it returns, and what to do."""
    import warnings
    e = worst(est, AIMED)
    key = decided_by(est)
    nx = int(sol._tensor[0].size - 1) if sol._tensor is not None else None
    how = ("may be wrong by more than 100 % (unbounded: its levels disagree)"
           if not math.isfinite(e) else "may be wrong by more than 100 %" if e > 1.0
           else "misses rtol")
    warnings.warn(f"fem.stationary: the default solve (rtol = {rtol:g}, best effort within "
                  f"{limit:g} s) stopped at degree {sol.degree}, nx = {nx} with an estimated "
                  f"error of {e:.2g} ({key}): the answer {how}; give nx and degree (e.g. "
                  f"degree=4, nx={2 * nx if nx else 64}, then sol.error_estimate()) or "
                  f"rtol for up to {MAX_SECONDS:g} s (info['rtol_not_reached'] says why it "
                  "stopped)", RuntimeWarning, stacklevel=4)
