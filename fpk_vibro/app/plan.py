"""One method at one scene point: the solver's keywords, its checks and its cost.

:func:`solver_kwargs` is what the runner passes to a solver; :func:`plan` runs on
those very keywords every check the solver runs before its work (the method's
``Options`` declaration, ``validate_for`` with the system, the initial condition,
the budget) and returns the cost estimate.  ``fpk-vibro check`` and ``run`` both
call it, so a scene that passes the check passes the solver's own checks.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

from .._checks import InputError
from ..budget import Cost
from ..model import VibroImpactSystem

__all__ = ["solver_kwargs", "plan", "resolved_options", "SOLVER_QUANTITIES"]

#: The histograms a Monte Carlo run can accumulate.
SOLVER_QUANTITIES = ("energy", "x", "y", "joint", "impacts")


def solver_kwargs(scene: Any, method: str, *, progress: bool | None = False) -> dict[str, Any]:
    """The keywords of ``method``'s solver for ``scene`` (besides system, initial, times)."""
    if method == "exact":
        return {}
    kw = dict(scene.numerics.get(method, {}))
    declared = import_module(f"fpk_vibro.{method}.options").Options.declared()
    if "quantities" in declared:
        kw["quantities"] = tuple(q for q in scene.quantities if q in SOLVER_QUANTITIES)
    if "progress" in declared:
        kw["progress"] = progress
    return {k: v for k, v in kw.items() if scene.mode in declared[k].modes}


def resolved_options(scene: Any, method: str) -> dict[str, Any]:
    """Every option of ``method`` as the run uses it (defaults filled in), for the record."""
    if method == "exact":
        return {}
    import dataclasses
    Options = import_module(f"fpk_vibro.{method}.options").Options
    opts = Options.from_call(scene.mode, solver_kwargs(scene, method))
    return {k: v for k, v in dataclasses.asdict(opts).items()
            if scene.mode in Options.declared()[k].modes and k != "progress"}


def plan(scene: Any, method: str, system: VibroImpactSystem) -> Cost:
    """Run the checks of ``method`` on ``system`` with the scene's keywords; the cost.

    Raises
    ------
    fpk_vibro._checks.InputError
        As the solver would, before any work.
    """
    if method == "exact":
        from ..exact import require_gibbs
        require_gibbs(system)
        return Cost(50e6, 1.0, "quadratures", 0.05)
    Options = import_module(f"fpk_vibro.{method}.options").Options
    init = None
    if scene.transient:
        from ..initial import parse_initial
        init = parse_initial(scene.initial, system)
    _, cost = Options.prepare(system, scene.mode, solver_kwargs(scene, method), initial=init,
                              times=scene.times, probe=True)
    if method == "fem" and "energy" in scene.quantities:
        from ..fem.solution import FEMSolution
        if not FEMSolution.has_energy_density(system):
            raise InputError(f"fem: the energy density p(H) needs a > 0, or a = 0 < b (one "
                             f"orbit per energy level); got a={system.a}, b={system.b}: "
                             "remove 'energy' or fem", where="fem", name="quantities")
    return cost
