"""The error estimate of a Monte Carlo first passage: statistics and time-step bias
(:meth:`fpk_vibro.first_passage.FirstPassage.error_estimate` of a
:func:`~fpk_vibro.montecarlo.first_passage` result; the registry provides it)."""
from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np

from .. import _checks
from ..first_passage import FirstPassage, survival_at
from ._first_passage import first_passage
from .estimate import second_run

__all__ = ["error_estimate", "BIAS_ORDER"]


#: The order p of the time-step bias of τ and R the estimate takes (bias ∝ dt^p):
#: the measured local order between dt and 2 dt (module docstring of
#: :func:`error_estimate`).
BIAS_ORDER = 0.5
ESTIMATE_ASSUMES = (
    "2 standard errors of τ (the 95 % DKW band for R) plus the time-step bias from one "
    "second run at {step} with the same paths and seed, taken as of order dt^{p:g} "
    "(measured: about 1 or more without impacts, 0.4-0.6 with them, so the lower, "
    "conservative order is taken: the bias from the runs at dt and 2 dt is 2.4 times "
    "their difference) and twice its "
    "standard error; R's bias is the largest difference of the two empirical R on the "
    "time grid times the same factor (its sampling noise included)")


def safe_keyword(fp: FirstPassage) -> dict[str, Any]:
    """The keyword that gives ``fp``'s safe set again (energy, displacement or
    impact_speed; an open displacement bound as the wall that stops paths first)."""
    safe = fp.safe_set
    if safe.kind != "displacement":
        return {safe.kind: safe.value}
    lo, hi = fp.system.x_bounds
    return {"displacement": (safe.x_lo if math.isfinite(safe.x_lo) else lo,
                             safe.x_hi if math.isfinite(safe.x_hi) else hi)}


def error_estimate(fp: FirstPassage) -> dict[str, Any]:
    """The error estimate of a Monte Carlo first passage (:meth:`FirstPassage.error_estimate`).

    One second run with the same paths, start, horizon, times and seed at 2 dt (at
    dt/2 where 2 dt is refused: beyond the stability limit or the budget, or NaN
    paths) gives the time-step bias of the run at dt, taken of order dt^p with
    p = :data:`BIAS_ORDER` = 1/2::

        bias(dt) = (m(dt) − m(h')) / (1 − (h'/dt)^p)       (−2.41 × at 2 dt, 3.41 × at dt/2)
        mean_time   = (2 SE + |bias| + 2 |f| sqrt(SE² + SE'²)) / τ  (+ the censoring's share)
        reliability = ε_DKW + |f| max_t |R(t) − R'(t)|

    The crossing is monitored in discrete steps (a Brownian bridge of y between step
    ends, located impacts), so the bias is not the scheme's O(dt²); its measured
    order is not stable (about 1 or more without impacts, 0.4–0.6 with them:
    docs/measurements.md, §Monte Carlo first passage: the time-step bias), and order
    1 would miss the impacting cases, so the estimate takes the lower, conservative
    1/2 (where the true order is 1 it overstates the bias 2.4 times).

    Returns
    -------
    dict
        ``mean_time``, ``reliability``, ``bias`` (of τ, relative and signed; NaN
        where no second run could be made: then 2 SE only), ``order``, ``step``,
        ``seconds`` (the second run's), ``assumes``.
    """
    info, tau = fp.info, float(fp.mean)
    n = int(info.get("n_paths", 0)) or None
    eps = float(info.get("band_halfwidth", math.sqrt(math.log(40.0) / (2 * n)) if n else 0.0))
    censored = float(info.get("censored_bias_estimate", 0.0)) / tau if \
        info.get("censored", 0.0) and tau > 0 else 0.0
    stat = 2.0 * fp.mean_se / tau if tau > 0 else math.inf
    only = {"mean_time": stat + censored, "reliability": eps, "bias": math.nan,
            "order": BIAS_ORDER, "step": None, "seconds": 0.0}
    if "dt" not in info or "seed_entropy" not in info or not tau > 0:
        only["assumes"] = ("2 standard errors only: this result does not carry the run's "
                           "step and seed, so the time-step bias is not estimated")
        return only
    dt = float(info["dt"])
    kind, value = fp.start
    start = "stationary" if kind == "stationary" else \
        {"mean": tuple(value["mean"]), "std": tuple(value["std"])} if kind == "gaussian" \
        else tuple(value)
    kw = dict(**safe_keyword(fp), start=start, n_paths=int(info["n_paths"]),
              seed=int(info["seed_entropy"]), times=np.asarray(fp.times, float),
              t_max=float(info["t_max"]) if info.get("n_censored", 0) else None,
              bridge=info.get("crossing") != "step ends", progress=False)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)       # censoring: said once
            other, step = second_run(lambda h: first_passage(fp.system, dt=h, **kw), dt)
    except _checks.InputError as exc:
        only["assumes"] = f"2 standard errors only: {exc}, so the time-step bias is not estimated"
        only["seconds"] = time.perf_counter() - t0
        return only
    h = 2.0 * dt if step == "2 dt" else 0.5 * dt
    seconds = time.perf_counter() - t0
    f = 1.0 / (1.0 - (h / dt) ** BIAS_ORDER)
    bias = f * (tau - other.mean)
    bias_se = abs(f) * math.hypot(fp.mean_se, other.mean_se)
    R2 = survival_at(other.times, other.survival, np.asarray(fp.times, float))
    dR = float(np.max(np.abs(np.asarray(fp.survival) - R2)))
    assumes = ESTIMATE_ASSUMES.format(step=step, p=BIAS_ORDER)
    if censored:
        assumes += "; plus the censored paths' missing share of τ"
    return {"mean_time": stat + (abs(bias) + 2.0 * bias_se) / tau + censored,
            "reliability": min(eps + abs(f) * dR, 1.0), "bias": bias / tau,
            "order": BIAS_ORDER, "step": step, "seconds": seconds, "assumes": assumes}
