"""The periodic response of a forced scene (``[forcing]``, no ``study.times``) in a run's
records: results.json, densities.npz and the estimates.

Per method and point the entry holds, beside the period-averaged moments under the
usual ``moments`` / ``moments_se`` (so that every reader of a stationary run reads a
periodic one's averages), a ``periodic`` record:

- ``phases``: the scene's phases φ = (Ωt + φ0) mod 2π (radians; the forcing there is
  F cos φ);
- ``moments``: E_x, E_x2, E_y2, E_H, P_impact (with walls), E_x4, E_y4 at each phase
  (lists in the order of ``phases``), ``moments_se`` for a sampled method;
- ``impact_rates``: impacts per unit time on each wall at each phase (``_se``
  sampled);
- ``mean_x``, ``amplitude``, ``lag``: the first harmonic of the mean, E[x](t) ≈ x̄ +
  A cos(Ωt + φ0 − θ), with ``harmonic_se`` where the method has standard errors;
- ``error_estimate``: ``phases`` (each phase's relative estimate of E_H, E_x2, E_y2,
  P_impact), and the absolute estimates of ``mean_x``, ``amplitude`` and ``lag``
  (radians), from :meth:`fpk_vibro.periodic.PeriodicResponse.error_estimate`.

The densities go to densities.npz as a transient's do, with the phase ``k`` as the
tag ``.ph{k}`` (``p{i}.{method}.{quantity}.ph{k}.{grid|pdf|...}``) and the period
average under the plain keys.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._checks import InputError
from ..keys import ESTIMATE_KEYS

__all__ = ["periodic_record", "periodic_estimates", "snapshots_at", "four_phases",
           "HARMONIC_KEYS"]

#: The scalars of the first harmonic of E[x](t).
HARMONIC_KEYS = ("mean_x", "amplitude", "lag")
#: What an estimate that cannot be made raises (recorded, the answer kept).
NOT_MADE = (NotImplementedError, InputError, ValueError, RuntimeError, MemoryError)


def _finite(v: Any) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def periodic_record(response: Any, sampled: bool) -> dict[str, Any]:
    """The ``periodic`` record of one method's :class:`~fpk_vibro.periodic.PeriodicResponse`
    (module docstring), without its estimate (:func:`periodic_estimates`)."""
    sols = [response.at(i) for i in range(len(response))]
    per_phase = [{"E_x": float(s.mean_x()), **{k: float(v) for k, v in s.moments().items()}}
                 for s in sols]
    keys = list(per_phase[0])
    rec: dict[str, Any] = {"phases": response.phases.tolist(),
                           "moments": {k: [m[k] for m in per_phase] for k in keys}}
    if sampled and hasattr(sols[0], "moments_se"):
        se = [{"E_x": float(s.mean_x_se()) if hasattr(s, "mean_x_se") else math.nan,
               **{k: float(v) for k, v in s.moments_se().items()}} for s in sols]
        rec["moments_se"] = {k: [_finite(m.get(k, math.nan)) for m in se] for k in keys}
    walls = [side for side, _ in response.system.walls]
    if walls:
        stats = [s.impacts() for s in sols]
        rec["impact_rates"] = {w: [float(st[w]["rate"]) for st in stats] for w in walls}
        if sampled and all("rate_se" in st[w] for st in stats for w in walls):
            rec["impact_rates_se"] = {w: [float(st[w]["rate_se"]) for st in stats]
                                      for w in walls}
    for k in HARMONIC_KEYS:
        rec[k] = float(getattr(response, k))
    info = getattr(response, "info", {}) or {}
    se = {k: _finite(info[f"{k}_se"]) for k in HARMONIC_KEYS if f"{k}_se" in info}
    if se:
        rec["harmonic_se"] = se
    return rec


def periodic_estimates(response: Any, how: str) -> dict[str, Any]:
    """``{"error_estimate": ...}`` of the ``periodic`` record (module docstring), or the
    reason none was made (``not_computed``); nothing for ``how`` = "none"."""
    if how == "none":
        return {}
    try:
        est = response.error_estimate()
    except NOT_MADE as exc:
        return {"error_estimate": {"not_computed": f"{type(exc).__name__}: {exc}"}}
    out: dict[str, Any] = {k: _finite(est[k]) for k in HARMONIC_KEYS if k in est}
    out["phases"] = [{k: _finite(e[k]) for k in ESTIMATE_KEYS if k in e}
                     for e in est.get("phases", [])]
    if isinstance(est.get("assumes"), str):
        out["assumes"] = est["assumes"]
    return {"error_estimate": out}


def snapshots_at(solutions: dict[str, Any], k: int | None) -> dict[str, Any]:
    """Each method's density at phase ``k`` (None: the period average)."""
    return {m: (r.average() if k is None else r.at(k)) for m, r in solutions.items()}


def four_phases(phases: Any) -> list[int]:
    """Indices of (at most) four phases spread over the period, in increasing phase:
    0, π/2, π, 3π/2 of the default eight.

    >>> import math
    >>> four_phases([k * math.pi / 4 for k in range(8)])
    [0, 2, 4, 6]
    >>> four_phases([3.0, 1.0])
    [1, 0]
    """
    order = np.argsort(np.asarray(phases, float), kind="stable")
    n = order.size
    if n <= 4:
        return [int(i) for i in order]
    return [int(order[j * n // 4]) for j in range(4)]
