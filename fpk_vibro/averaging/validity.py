"""Where stochastic averaging holds, and how far off it is: the model error of an
averaged density and its small-parameter indicators.

Model error (:func:`model_error`, ``AveragedSolution.error_estimate()``)
-----------------------------------------------------------------------
Averaging replaces the 2-D dynamics by a 1-D diffusion of the energy; its error is a
*model* error (the averaged density is computed to 1e-8; what it lacks is the physics
averaging drops), which no refinement of averaging reveals.  The estimate is a check
against the finite-element density of the same system: ``fem.stationary(system)``
(rtol 1e-4, best effort), so

    estimate_k = |q_k(averaging) − q_k(FE)| / |q_k(FE)| + estimate_k(FE),

for k = E[H], E[x²], E[y²], P_impact (absolute below P = 1e-3), and the L1 distance
of the joint densities plus FE's own L1 estimate.  It assumes the FE answer is
resolved (its estimate says so; where it is not, the figure is infinite, and where FE
refuses the system, averaging's estimate is infinite with FE's reason).  It costs one
FE solve (0.1–0.5 s on ordinary scenes, at most ~10 s).

Indicators (:func:`indicators`, ``AveragedSolution.validity()``)
----------------------------------------------------------------
Averaging assumes the energy changes little over one (quasi-)period.  At the mean
energy E = E[H] with quasi-period T(E):

- ``damping``: c T(E), the share of the energy damping takes in a period;
- ``impacts``: δ(E)/E, the share the impacts take in a quasi-period;
- ``noise``: sqrt(σ²(E) T(E))/E with σ² the averaged diffusion of the energy, the
  change the noise makes to the energy in a period relative to E.

The noise figure is reported but not judged: at equilibrium the energy's spread is
of the order of the energy itself whatever the regime (measured 0.8 on the paper's
case, where averaging is within 0.8 %).  These values at E[H] are a reading aid.
``validity()`` of a stationary density adds the calibrated indicator model
(:mod:`fpk_vibro.averaging.error_model`: averages over p(H), not values at E[H]):
its features (``model``), its estimate (``estimated_error`` of ``estimated_key``),
the verdict that follows it (averaging is off above :data:`TOLERABLE`) and the
weakest assumption, the larger of the model's two terms (:func:`weakest`).  A
transient's density has only the values at E[H]; its verdict names those above
:data:`LIMIT`.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from ..keys import JUDGED

__all__ = ["estimate", "report", "model_error", "indicators", "verdict", "weakest", "LIMIT",
           "TOLERABLE", "JUDGED"]

#: An indicator above this is named by the verdict.
LIMIT = 0.3
ASSUMES = ("the difference to the finite-element density of the same system (rtol 1e-4, "
           "best effort) plus FE's own estimate; assumes the FE answer is resolved")


def model_error(sol, reference: Any = None) -> dict[str, Any]:
    """The model-error estimate of an :class:`AveragedSolution` (module docstring; the
    per-key formula is :func:`fpk_vibro.averaging.model_error.against`, shared with
    the transient's); ``reference``: an FE solution of the same system already at
    hand (a scene that runs fem too), else one is solved."""
    from .._checks import InputError
    from ..references import reference as solve_reference
    from .model_error import against, judged_keys, unbounded
    t0 = time.perf_counter()
    if reference is not None:
        from .model_error import check_reference
        check_reference(sol, reference, "AveragedSolution.error_estimate")
    try:
        ref = reference if reference is not None else solve_reference("fem", sol.system)
    except (InputError, ValueError) as exc:
        out: dict[str, Any] = unbounded(sol)
        out.update(assumes=ASSUMES, reference=f"none: fem refused the system ({exc})",
                   seconds=time.perf_counter() - t0)
        return out
    fe_est = ref.error_estimate()
    out = against(sol, ref, fe_est)
    out.update(assumes=ASSUMES, reference=f"fem degree {ref.degree}, {ref.dofs.size} DOFs "
               f"(its estimate {max(fe_est[k] for k in judged_keys(sol)):.1g})",
               seconds=time.perf_counter() - t0)
    return out


def estimate(sol, reference: Any = None, by: str = "fem") -> dict[str, Any]:
    """``AveragedSolution.error_estimate``: by an FE check (:func:`model_error`) or
    by the indicator model (:func:`fpk_vibro.averaging.error_model.estimate`),
    recorded in ``sol.info`` ("error_estimate": the largest judged figure, an FE
    check's taking precedence)."""
    if by not in ("fem", "indicators"):
        from .._checks import invalid
        raise invalid("AveragedSolution.error_estimate", "by", 'one of "fem", "indicators"', by)
    if by == "indicators":
        if reference is not None:
            from .._checks import InputError
            raise InputError("AveragedSolution.error_estimate: reference is for by=\"fem\" "
                             "only (by=\"indicators\" makes no comparison); drop it or "
                             "use by=\"fem\"", where="AveragedSolution.error_estimate",
                             name="reference")
        from .error_model import estimate as by_indicators
        est = by_indicators(sol)
        worst = max(float(est[k]) for k in JUDGED if k in est)
        sol.info["error_estimate_indicators"] = worst
        sol.info.setdefault("error_estimate", worst)
        return est
    est = model_error(sol, reference)
    sol.info["error_estimate"] = max(float(est[k]) for k in JUDGED if k in est)
    return est


def report(sol) -> dict[str, Any]:
    """``AveragedSolution.validity()``: the indicators at E[H], the indicator model's
    features (``model``) and estimate (``estimated_error`` of ``estimated_key``), a
    verdict and the weakest assumption."""
    ind: dict[str, Any] = indicators(sol)
    est = sol.error_estimate(by="indicators")
    key = max((k for k in JUDGED if k in est), key=lambda k: est[k])
    ind.update(estimated_error=float(est[key]), estimated_key=key, model=est["indicators"])
    return {**ind, "verdict": verdict(ind), "weakest": weakest(ind)}


def indicators(sol) -> dict[str, float]:
    """The small parameters of averaging at the mean energy (module docstring)."""
    from ..orbits import energy_loss
    from .coefficients import coefficients
    s = sol.system
    E = float(sol.moments()["E_H"])
    T, m, sigma2 = (float(np.asarray(v).ravel()[0]) for v in coefficients(s, np.array([E])))
    return {"damping": s.c * T,
            "impacts": float(np.asarray(energy_loss(s, np.array([E]))).ravel()[0]) / E
            if s.has_barrier and E > 0 else 0.0,
            "noise": math.sqrt(max(sigma2, 0.0) * T) / E if E > 0 else math.inf,
            "mean_energy": E, "period": T}


#: The estimated model error (relative) above which the verdict says averaging is off.
TOLERABLE = 0.01


def verdict(ind: dict[str, Any]) -> str:
    """Plain words: whether averaging applies.  With the indicator model's estimate
    (``estimated_error`` of ``estimated_key``, a stationary density's
    ``validity()``) the verdict follows it (off where it passes :data:`TOLERABLE`,
    naming the weakest assumption); otherwise (a transient's density) it names the
    small parameters at E[H] above :data:`LIMIT`."""
    if "estimated_error" in ind:
        est = (f"estimated model error ~{100 * ind['estimated_error']:.2g} % "
               f"({ind['estimated_key']}, indicator model)")
        if ind["estimated_error"] <= TOLERABLE:
            return f"averaging applies: {est}"
        return (f"averaging is off: {est}; {weakest(ind)}; an FE check: "
                "error_estimate()")
    bad = [f"{k} per period {ind[k]:.2g}" for k in ("damping", "impacts") if ind[k] > LIMIT]
    if not bad:
        return (f"quasi-conservative at the mean energy (damping and impacts each take "
                f"< {LIMIT:g} of the energy per period): averaging applies")
    return ("not quasi-conservative at the mean energy: " + ", ".join(bad) +
            f" (> {LIMIT:g}); expect a model error, see error_estimate()")


def weakest(ind: dict[str, Any]) -> str:
    """The assumption furthest from holding, in words (for a one-line warning).

    Averaging is exact for r = 1 and D2 = 0 whatever the damping, so what fails is
    either the impacts' loss per quasi-period or damping together with parametric
    noise: with the indicator model's features (``ind["model"]``, a stationary
    density), the larger of its two terms (:func:`.error_model.terms`); otherwise
    (a transient's density) the impacts where they take energy, else damping, at
    E[H]."""
    model = ind.get("model")
    if model is not None:
        from .error_model import terms
        impact, parametric = terms(model)
        if max(impact.values(), default=0.0) >= parametric and model["kr"] > 0:
            return (f"impacts take {model['kr']:.2g} of the energy per quasi-period, on "
                    f"{model['P']:.2g} of the mass")
        return (f"damping with parametric noise: damping takes {model['damping']:.2g} of "
                f"the energy per period, parametric noise {model['parametric']:.2g} of "
                "the noise's input")
    if ind["impacts"] > 0:
        return f"impacts take {ind['impacts']:.2g} of the energy per quasi-period at E[H]"
    return f"damping takes {ind['damping']:.2g} of the energy per period at E[H]"
