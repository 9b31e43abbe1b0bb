"""One method at one scene point: the solver's keywords, its checks and its cost.

:func:`solver_kwargs` is what the runner passes to a solver; :func:`plan` runs on
those very keywords every check the solver runs before its work (the method's
``Options`` declaration, ``validate_for`` with the system, the initial condition,
the budget) and returns the cost estimate; with the quantity "first_passage" it
checks the method's first-passage keywords (:func:`first_passage_kwargs`) too.
``fpk-vibro check`` and ``run`` both call it, so a scene that passes the check passes
the solver's own checks.
"""
from __future__ import annotations

from typing import Any

from .._checks import InputError
from ..budget import Cost
from ..model import VibroImpactSystem
from ..registry import methods

__all__ = ["solver_kwargs", "first_passage_kwargs", "plan", "resolved_options",
           "SOLVER_QUANTITIES"]

#: The quantities a method is asked to have densities for (the others are derived, or
#: skipped for a method without that mode: first passage).
DENSITIES = ("energy", "x", "y", "joint")


def __getattr__(name: str) -> Any:
    if name == "SOLVER_QUANTITIES":
        return _solver_quantities()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _solver_quantities() -> tuple[str, ...]:
    """SOLVER_QUANTITIES: the histograms a sampled run can accumulate (declared by the
    Monte Carlo solution, imported only when asked: a scene without Monte Carlo
    does not import it)."""
    from ..montecarlo.solution import ALL_QUANTITIES
    return ALL_QUANTITIES


def _options(method: str):
    """The method's Options class, or None (a method without numerical options)."""
    return methods()[method].options_class()


def solver_kwargs(scene: Any, method: str, *, progress: bool | None = False) -> dict[str, Any]:
    """The keywords of ``method``'s solver for ``scene`` (besides system, initial, times)."""
    Options = _options(method)
    if Options is None:
        return {}
    kw = dict(scene.numerics.get(method, {}))
    declared = Options.declared()
    if "quantities" in declared:      # a periodic run samples the densities only
        kw["quantities"] = tuple(q for q in scene.quantities if q in (
            DENSITIES if scene.mode == "periodic" else _solver_quantities()))
        if "crossings" in scene.quantities and "joint" not in kw["quantities"]:
            kw["quantities"] += ("joint",)      # ν⁺(b) integrates the joint density
    if "progress" in declared:
        kw["progress"] = progress
    return {k: v for k, v in kw.items() if scene.mode in declared[k].modes}


def first_passage_kwargs(scene: Any, method: str) -> dict[str, Any]:
    """The numerical keywords of ``method``'s ``first_passage`` for ``scene`` (besides
    system, energy, start, times): the keys of its table declared for first passage
    (``Options.for_mode("first_passage")``)."""
    Options = _options(method)
    if Options is None:
        return {}
    declared = Options.for_mode("first_passage")
    return {k: v for k, v in scene.numerics.get(method, {}).items() if k in declared}


def _check_first_passage(scene: Any, method: str, system: VibroImpactSystem,
                         Options: Any) -> None:
    """The first-passage keywords as the solver checks them (range, rules, budget);
    a key of first passage alone in a scene that does not ask for it is refused."""
    if scene.first_passage is not None and "first_passage" in methods()[method].modes:
        Options.prepare(system, "first_passage", first_passage_kwargs(scene, method),
                        probe=True)
        return
    declared = Options.declared()
    for key in scene.numerics.get(method, {}):
        if scene.mode not in declared[key].modes:
            runs = " or ".join(m.replace("_", " ") for m in declared[key].modes)
            raise InputError(f"{method}: {key}: only used by {runs} runs (first passage: "
                             "the quantity \"first_passage\" with a [first_passage] "
                             "table); remove it", where=method, name=key)


def resolved_options(scene: Any, method: str) -> dict[str, Any]:
    """Every option of ``method`` as the run uses it (defaults filled in), for the record."""
    Options = _options(method)
    if Options is None:
        return {}
    import dataclasses
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
    methods()[method].supports(system, scene.mode,
                               [q for q in scene.quantities if q in DENSITIES])
    Options = _options(method)
    if Options is None:                    # a closed form: nothing to size
        return Cost(50e6, 1.0, "quadratures", 0.05)
    if scene.mode == "periodic" and "periodic" not in Options.FORCED_MODES:
        # its periodic solver checks its keywords itself (no declaration to size by)
        return Cost(0.0, 0.0, "periodic solve", 1.0, note="not sized before the run")
    init = None
    if scene.transient:
        from ..initial import parse_initial
        init = parse_initial(scene.initial, system)
    _, cost = Options.prepare(system, scene.mode, solver_kwargs(scene, method), initial=init,
                              times=scene.times, probe=True)
    _check_first_passage(scene, method, system, Options)
    return cost
