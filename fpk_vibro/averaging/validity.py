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

Damping and impacts must be small (≪ 1) where averaging holds; the verdict names
those above :data:`LIMIT`.  The noise figure is reported but not judged: at
equilibrium the energy's spread is of the order of the energy itself whatever the
regime (measured 0.8 on the paper's case, where averaging is within 0.8 %).  The
verdict is a reading aid; the number that counts is the model error.  Without an FE
check, ``validity()`` adds the calibrated indicator model's estimate
(:mod:`fpk_vibro.averaging.error_model`: averages over p(H), not values at E[H]) as
``estimated_error`` and ``estimated_key``, which the verdict quotes.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from ..keys import JUDGED

__all__ = ["model_error", "indicators", "verdict", "weakest", "LIMIT", "JUDGED"]

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


def verdict(ind: dict[str, Any]) -> str:
    """Plain words: which small parameters are not small, and, where ``ind`` has it
    (``AveragedSolution.validity()``), the indicator model's estimated model error
    (``estimated_error`` of key ``estimated_key``, :mod:`.error_model`)."""
    est = ""
    if "estimated_error" in ind:
        est = (f"; estimated model error ~{100 * ind['estimated_error']:.2g} % "
               f"({ind['estimated_key']}, indicator model)")
    bad = [f"{k} per period {ind[k]:.2g}" for k in ("damping", "impacts") if ind[k] > LIMIT]
    if not bad:
        return (f"quasi-conservative at the mean energy (damping and impacts each take "
                f"< {LIMIT:g} of the energy per period): averaging applies" + est)
    return ("not quasi-conservative at the mean energy: " + ", ".join(bad) +
            f" (> {LIMIT:g}){est}; expect a model error, see error_estimate()")


def weakest(ind: dict[str, float]) -> str:
    """The indicator furthest from small, in words (for a one-line warning)."""
    name = max(("damping", "impacts"), key=lambda k: ind[k])
    return f"{name} takes {ind[name]:.2g} of the energy per period at E[H]"
