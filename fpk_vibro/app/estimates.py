"""Every answer of a scene run with its error estimate, as ``study.error_estimates``
asks ("auto", "fem-check", "none"; :data:`fpk_vibro.app.scene_keys.ERROR_ESTIMATES`):
each method's own estimate, averaging's model error against the scene's own FE
answer (or its indicator model, or an FE check), per time for a transient and beside
each first passage; an estimate that fails or is interrupted is recorded with its
reason and the answers stay."""
from __future__ import annotations

import math
from typing import Any

from .._checks import InputError
from ..keys import ESTIMATE_KEYS, JUDGED
from .scenes import Scene

__all__ = ["add_estimates", "AVERAGING_WARN"]


#: Averaging's estimated model error above which a run warns (one line per point).
AVERAGING_WARN = 0.01
#: What an estimate that cannot be made raises (no estimate for the kind, refused by
#: the budget, a check solve that failed): recorded as ``not_computed``, the answer kept.
NOT_MADE = (NotImplementedError, InputError, ValueError, RuntimeError, MemoryError)


def _not_made(exc: BaseException) -> dict[str, Any]:
    return {"error_estimate": {"not_computed": f"{type(exc).__name__}: {exc}"}}


def _estimate_of(method: str, sol: Any, reference: Any, how: str) -> dict[str, Any]:
    """The estimate of one answer, as ``study.error_estimates`` (``how``) asks.

    Averaging's model error is measured against ``reference``, the scene's own FE
    answer at the same point (and time), when the scene runs fem; otherwise "auto"
    takes its indicator model (stationary; no FE solve: compute only what the scene
    asks for) and "fem-check" an FE solve of its own."""
    if method == "averaging":
        if reference is not None:
            return sol.error_estimate(reference=reference)
        if how == "fem-check":
            return sol.error_estimate()
        if getattr(sol, "time", None) is not None:
            raise NotImplementedError(
                f"{method}: a transient's model error needs an FE transient: add fem to the "
                "scene or set study.error_estimates = \"fem-check\"")
        return sol.error_estimate(by="indicators")
    return sol.error_estimate()


def _estimate_record(method: str, sol: Any, reference: Any = None, how: str = "auto"
                     ) -> dict[str, Any]:
    """``error_estimate`` (every figure, None where unbounded; ``not_computed`` with the
    reason where none could be made) and, for averaging beyond
    :data:`AVERAGING_WARN`, a ``warning`` naming its weakest assumption."""
    if how == "none":
        return {}
    try:
        est = _estimate_of(method, sol, reference, how)
    except NOT_MADE as exc:
        return _not_made(exc)
    rec = {k: (float(est[k]) if math.isfinite(float(est[k])) else None)
           for k in ESTIMATE_KEYS if k in est}
    rec["assumes"] = est.get("assumes", "")
    out: dict[str, Any] = {"error_estimate": rec}
    worst = max((float(est[k]) for k in JUDGED if k in est), default=0.0)
    if method == "averaging" and worst > AVERAGING_WARN:
        at = "" if getattr(sol, "time", None) is None else f" at t = {sol.time:g}"
        out["warning"] = (f"{method}: estimated model error {worst:.2g}{at} > "
                          f"{AVERAGING_WARN:g} (its weakest assumption: "
                          f"{sol.validity()['weakest']})")
    return out


def _passage_estimate(method: str, fp: Any, reference: Any, how: str) -> dict[str, Any]:
    """A first passage's estimate as ``study.error_estimates`` asks: averaging's model
    error against the scene's FE first passage, or ("fem-check") an FE solve of its
    own; with neither (as for a transient) none is made behind the scene's back."""
    if how == "none":
        return {}
    try:
        if method == "averaging" and reference is None and how != "fem-check":
            raise NotImplementedError(
                f"{method}: the first passage's model error needs an FE first passage: add "
                "fem to the scene or set study.error_estimates = \"fem-check\"")
        est = fp.error_estimate(reference=reference)
    except NOT_MADE as exc:
        return _not_made(exc)
    return {"error_estimate": {
        k: (None if isinstance(v, float) and not math.isfinite(v) else v)
        for k, v in est.items() if isinstance(v, (int, float, str))}}


def add_estimates(scene: Scene, record: dict[str, Any], solutions: dict[str, Any],
                   passages: dict[str, Any] | None = None) -> None:
    """Every answer's estimate into its record (per time for a transient; a first
    passage's beside it), once every method has run (averaging's against the
    scene's FE answers, whatever the order of study.methods)."""
    for method, fp in (passages or {}).items():
        ref = passages.get("fem") if method == "averaging" else None
        record["methods"][method]["first_passage"].update(
            _passage_estimate(method, fp, ref, scene.error_estimates))
    fem = solutions.get("fem")
    for method, sol in solutions.items():
        entry = record["methods"][method]
        if scene.periodic:         # the average's, then the phases' and the harmonic's
            from .periodic_records import periodic_estimates
            entry.update(_estimate_record(method, sol.average(), None, scene.error_estimates))
            entry["periodic"].update(periodic_estimates(sol, scene.error_estimates))
            continue
        if not scene.transient:
            entry.update(_estimate_record(method, sol, fem if method != "fem" else None,
                                          scene.error_estimates))
            _impact_estimates(method, sol, entry, fem if method != "fem" else None,
                              scene.error_estimates)
            continue
        for k, (rec, snap) in enumerate(zip(entry["at"], sol)):
            ref = fem[k] if fem is not None and method != "fem" else None
            rec.update(_estimate_record(method, snap, ref, scene.error_estimates))
            warning = rec.pop("warning", None)
            if warning and k == len(entry["at"]) - 1:      # one line per point
                entry["warning"] = warning


def _plain(est: dict[str, Any]) -> dict[str, Any]:
    """An estimate's JSON-able entries (inf → None: no bound follows)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in est.items() if isinstance(v, (int, float, str)) and k != "seconds"}


def _own_figures(sol: Any, entry: dict[str, Any]) -> dict[str, Any] | None:
    """The method's own estimate (made already for its moments), where it holds the
    impact figures (Monte Carlo: ``mean_inter_impact_time``, ``mean_impact_energy_<wall>``)."""
    if "not_computed" in entry.get("error_estimate", {"not_computed": ""}):
        return None
    try:
        return sol.error_estimate()     # made once, then kept on the solution
    except NOT_MADE:
        return None


def _impact_estimates(method: str, sol: Any, entry: dict[str, Any], reference: Any,
                      how: str) -> None:
    """The estimates of the inter-impact mean and of the mean energy per impact into
    their records (relative): Monte Carlo's own (statistics and time-step bias),
    averaging's against the scene's FE answer (or an FE solve for "fem-check"); a
    method without one says so (``not_computed``)."""
    gaps, energy = entry.get("inter_impact", {}), entry.get("impact_energy", {})
    wanted = ("mean" in gaps) or any("mean" in v for v in energy.values())
    if how == "none" or not wanted:
        return
    own = _own_figures(sol, entry) if method != "averaging" else None
    none = f"{method} gives no estimate of this figure"
    if "mean" in gaps:
        if own is not None and "mean_inter_impact_time" in own:
            gaps["error_estimate"] = _plain({"mean": float(own["mean_inter_impact_time"]),
                                             "assumes": own.get("assumes", "")})
        elif method == "averaging" and (reference is not None or how == "fem-check"):
            try:
                gaps["error_estimate"] = _plain(sol.inter_impact_estimate(reference))
            except NOT_MADE as exc:
                gaps.update(_not_made(exc))
        else:
            why = (f"{method}: the inter-impact model error needs an FE answer: add fem to "
                   "the scene or set study.error_estimates = \"fem-check\""
                   if method == "averaging" else none + " (its identity residual is "
                   "'identity')")
            gaps["error_estimate"] = {"not_computed": why}
    for side, rec in energy.items():
        if "mean" not in rec or rec.get("elastic"):
            continue
        key = f"mean_impact_energy_{side}"
        if own is not None and key in own:
            rec["error_estimate"] = _plain({"mean": float(own[key]),
                                            "assumes": own.get("assumes", "")})
        else:
            rec["error_estimate"] = {"not_computed": none}
