"""The error estimate of a Monte Carlo answer: statistics and time-step bias together.

``MonteCarloSolution.error_estimate()`` gives, for E[H], E[x²], E[y²] and P_impact
(relative; P_impact absolute below 1e-3)::

    estimate = 2 SE + |bias| + 2 SE(bias)

The standard error SE comes from the spread between independent batches of paths.
The time-step bias of the scheme is O(dt²) (:mod:`fpk_vibro.montecarlo`), so a
second run at 2 dt with the same paths, times, burn-in and seed family gives
bias(dt) ≈ (m(2 dt) − m(dt)) / 3, with its own standard error
sqrt(SE² + SE₂²) / 3 (the two runs are independent samples).  Where 2 dt is refused
(beyond a stability limit of the system), the second run is at dt/2 and
bias(dt) ≈ 4 (m(dt) − m(dt/2)) / 3.  The second run costs about half (2 dt) or
twice (dt/2) the first.  Assumes the bias follows its leading order between the two
steps; a transient or a partial (interrupted) run has no second run: its estimate is
2 SE with ``bias`` NaN, and ``assumes`` says so.
"""
from __future__ import annotations

import math
import time
from typing import Any

from ..keys import JUDGED, moment_scale

__all__ = ["error_estimate", "JUDGED"]



def _scale(key: str, value: float) -> float:
    return max(moment_scale(key, value), 1e-300)        # (a zero moment: no division)


def error_estimate(sol) -> dict[str, Any]:
    """The estimate of the module docstring for a :class:`MonteCarloSolution`."""
    from .._checks import InputError
    stationary = type(sol).rerun     # the engine's solver (set by it: no import back)
    t0 = time.perf_counter()
    m, se = sol.moments(), sol.moments_se()
    keys = [k for k in JUDGED if k in m]
    out: dict[str, Any] = {}
    if sol.time is not None or sol.partial or not sol.dt or not sol.t_sample:
        for k in keys:
            out[k] = 2.0 * se[k] / _scale(k, m[k])
        out.update(bias=math.nan, assumes="2 standard errors only: the time-step bias of a "
                   "transient or interrupted run is not estimated", seconds=0.0)
        return out
    run = dict(n_paths=int(sol.n_paths), t_burn=float(sol.t_burn),
               t_sample=float(sol.t_sample), n_batches=int(sol.n_batches),
               seed=None if sol.seed_entropy is None else int(sol.seed_entropy),
               quantities=("x",), progress=False)
    try:
        other = stationary(sol.system, dt=2.0 * sol.dt, **run)
        factor, step = -1.0 / 3.0, "2 dt"
    except InputError:
        other = stationary(sol.system, dt=0.5 * sol.dt, **run)
        factor, step = 4.0 / 3.0, "dt/2"
    m2, se2 = other.moments(), other.moments_se()
    bias = {}
    for k in keys:
        b = factor * (m[k] - m2[k])
        b_se = abs(factor) * math.sqrt(se[k] ** 2 + se2[k] ** 2)
        bias[k] = b / _scale(k, m[k])
        out[k] = (2.0 * se[k] + abs(b) + 2.0 * b_se) / _scale(k, m[k])
    out.update(bias=bias, assumes=f"2 standard errors plus the time-step bias from a run at "
               f"{step} (O(dt²) scheme) and twice its standard error",
               seconds=time.perf_counter() - t0)
    return out
