"""The impact quantities of a run: the time between impacts and the energy per impact.

Per method and point, as the scene asks (``study.quantities``):

- ``"inter_impact"``: the mean time between successive impacts (any wall) by the
  method's own route, 1/ν (ν the total impact rate of ``impacts()``) beside it and
  their relative difference (the identity mean = 1/ν checks every engine), the
  per-wall-pair figures where the method gives them, and the density on a time grid
  shared by the methods of the point;
- ``"impact_energy"``: per wall, the mean energy one impact dissipates and
  energy_rate/rate (the same by the identity), and its density on an energy grid
  shared by the methods (an elastic wall dissipates nothing: no density).

Monte Carlo adds standard errors and its histograms (± SE per bin).  Each method's
error estimate is added by :mod:`fpk_vibro.app.estimates`.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["inter_impact_record", "impact_energy_record", "impact_arrays", "GRID_POINTS",
           "T_SPAN", "E_SPAN"]

#: Points of the time and energy grids of the densities.
GRID_POINTS = 400
#: The time grid reaches this many mean gaps (the largest mean of the methods).
T_SPAN = 6.0
#: The energy grid reaches this many mean energies per impact.
E_SPAN = 8.0
#: What a method that cannot give a quantity raises (recorded, the run goes on).
NOT_GIVEN = (NotImplementedError, ValueError)


def _not_given(exc: BaseException) -> dict[str, Any]:
    return {"not_computed": " ".join(f"{type(exc).__name__}: {exc}".split())}


def _call(sol: Any, name: str, *args: Any) -> float | None:
    f = getattr(sol, name, None)
    if f is None:
        return None
    try:
        v = float(f(*args))
    except NOT_GIVEN:
        return None
    return v if math.isfinite(v) else None


def inter_impact_record(sol: Any) -> dict[str, Any]:
    """``mean``, ``one_over_rate``, ``identity`` (|mean ν − 1|), ``mean_se`` (Monte
    Carlo) and ``pairs`` (where the method gives them); ``not_computed`` with the reason
    where the method gives none."""
    try:
        mean = float(sol.mean_inter_impact_time())
    except NOT_GIVEN as exc:
        return _not_given(exc)
    rate = sum(v["rate"] for v in sol.impacts().values())
    out: dict[str, Any] = {"mean": mean, "one_over_rate": 1.0 / rate if rate > 0 else None,
                           "identity": abs(mean * rate - 1.0) if rate > 0 else None}
    se = _call(sol, "mean_inter_impact_time_se")
    if se is not None:
        out["mean_se"] = se
    try:
        pairs = (sol.inter_impact_pairs() if hasattr(sol, "inter_impact_pairs")
                 else sol.inter_impact()["pairs"] if hasattr(sol, "inter_impact") else None)
    except NOT_GIVEN:
        pairs = None
    if pairs:
        out["pairs"] = {k: {kk: (float(vv) if isinstance(vv, (int, float)) else vv)
                            for kk, vv in v.items()} for k, v in pairs.items()}
    return out


def impact_energy_record(sol: Any) -> dict[str, Any]:
    """Per wall: ``mean`` (energy one impact dissipates), ``from_rates``
    (energy_rate/rate of ``impacts()``, the identity), ``mean_se`` (Monte Carlo),
    ``elastic``; ``not_computed`` with the reason where the method gives none."""
    out: dict[str, Any] = {}
    try:
        stats = sol.impacts()
    except NOT_GIVEN as exc:
        return {side: _not_given(exc) for side, _ in sol.system.walls}
    for side, wall in sol.system.walls:
        d = stats.get(side, {})
        rec: dict[str, Any] = {"elastic": bool(wall.elastic)}
        try:
            rec["mean"] = float(sol.mean_impact_energy(side))
        except NOT_GIVEN as exc:
            out[side] = {**rec, **_not_given(exc)}
            continue
        if d.get("rate", 0) > 0:
            rec["from_rates"] = float(d["energy_rate"] / d["rate"])
        se = _call(sol, "mean_impact_energy_se", side)
        if se is not None:
            rec["mean_se"] = se
        out[side] = rec
    return out


def _top(entries: list[dict[str, Any]], key: str, span: float) -> float | None:
    means = [e[key] for e in entries if isinstance(e, dict) and (e.get(key) or 0) > 0]
    return span * max(means) if means else None


def impact_arrays(quantities: tuple[str, ...], solutions: dict[str, Any],
                  entries: dict[str, dict[str, Any]], index: int, sampled: Any
                  ) -> dict[str, np.ndarray]:
    """The densities of one point, npz-keyed ``p{i}.{method}.inter_impact.{grid|pdf}``
    and ``p{i}.{method}.impact_energy_{wall}.{grid|pdf}`` (Monte Carlo adds
    ``.edges``, ``.hist``, ``.se``); ``sampled(method)`` says which methods sample."""
    out: dict[str, np.ndarray] = {}
    if "inter_impact" in quantities:
        top = _top([e.get("inter_impact") for e in entries.values()], "mean", T_SPAN)
        if top is not None:
            t = np.linspace(0.0, top, GRID_POINTS + 1)
            for m, sol in solutions.items():
                if "mean" not in entries[m].get("inter_impact", {}):
                    continue
                key = f"p{index}.{m}.inter_impact"
                _put(out, key, t, lambda g, s=sol: s.inter_impact_pdf(g),
                     getattr(sol, "inter_impact_histogram", None) if sampled(m) else None)
    if "impact_energy" in quantities:
        walls = next(iter(solutions.values())).system.walls
        for side, wall in walls:
            if wall.elastic:
                continue
            top = _top([e.get("impact_energy", {}).get(side) for e in entries.values()],
                       "mean", E_SPAN)
            if top is None:
                continue
            e = np.linspace(0.0, top, GRID_POINTS + 1)
            for m, sol in solutions.items():
                if "mean" not in entries[m].get("impact_energy", {}).get(side, {}):
                    continue
                hist = getattr(sol, "impact_energy_histogram", None) if sampled(m) else None
                _put(out, f"p{index}.{m}.impact_energy_{side}", e,
                     lambda g, s=sol, w=side: s.impact_energy_pdf(w, g),
                     None if hist is None else (lambda h=hist, w=side: h(w)))
    return out


def _put(out: dict, key: str, grid: np.ndarray, pdf: Any, hist: Any) -> None:
    try:
        values = np.asarray(pdf(grid), dtype=float)
    except NOT_GIVEN:
        return
    out[f"{key}.grid"], out[f"{key}.pdf"] = grid, values
    if hist is not None:
        try:
            out[f"{key}.edges"], out[f"{key}.hist"], out[f"{key}.se"] = hist()
        except NOT_GIVEN:
            pass
