"""The rtol ladder of ``fem.stationary``: its levels, its limits and its predicted cost.

``fem.stationary(system, rtol=...)``, and the default call (rtol = 1e-4, best effort),
solve a ladder of levels (:func:`fpk_vibro.fem.estimate.adaptive`): Galerkin degree 2
on :func:`start_nx` cells, degrees 3 and 4 on the same mesh, then nx and ny doubled
at degree 4.  A level's estimate is its difference to the next one, so the ladder
solves one level beyond the one it returns.  A level that would take the whole solve
past :data:`MAX_SECONDS` (:data:`DEFAULT_SECONDS` for the default) or nx past
:data:`MAX_NX` is not solved.

:func:`ladder_cost` is what ``fem.Options.estimate`` (and so ``fpk-vibro check``)
gives for such a solve: the summed cost model of the levels the ladder is predicted
to solve, capped where the ladder stops.  Which level meets rtol is not known before
solving; the prediction takes a convergence model on the slow side of the measured
ones: :data:`FIRST_ESTIMATE` at the first level and a factor :data:`PER_LEVEL` less
per level.  Measured on 20 systems (tests/test_fem_default_hostile.py and the
README's cases): first-level estimates 7.5e-7 – 2.5e-2 (above 1e-3 on a third of
them: walls near the equilibrium, low noise, r near 0), a factor 1.1 – 50 per level
(mostly 5 – 30), and then a floor of 1e-7 – 3e-6 that refinement does not pass (the
mass beyond the truncation, < 1e-8 of it, and the corners of walls with r < 1; e.g.
paper r = 0.92: 9.7e-8 at degree 4, nx = 32, 9.4e-8 at nx = 64).  Where rtol lies
beyond the levels that fit, the cost says so in its ``note``: a scene with
rtol = 1e-10 was announced at 0.5 s, then ran 21 s and failed.
"""
from __future__ import annotations

import math
from typing import Any

from ..budget import Cost, available_memory, MEMORY_SHARE

__all__ = ["DEFAULT_RTOL", "WALL_GRADING", "MAX_NX", "MAX_SECONDS", "DEFAULT_SECONDS", "FIRST_ESTIMATE", "PER_LEVEL",
           "FLOOR", "start_nx", "is_best_effort", "uses_ladder", "levels", "ladder_cost"]

#: The accuracy goal of a stationary solve given no mesh, nx, ny, degree or
#: positivity (fem.estimate.adaptive; measured cost: docs/measurements.md).
DEFAULT_RTOL = 1e-4
#: The x-grading power toward walls with r < 1 that rtol's meshes use
#: (fem.mesh.wall_nodes; 2 against 3 and uniform on 20 random scenes:
#: docs/measurements.md, §FE error estimate and rtol).
WALL_GRADING = 2.0
#: Largest nx the ladder tries.
MAX_NX = 4096
#: Longest the ladder may take (s): the next level is refused when the time spent plus
#: its predicted time (the last solve's, scaled by DOFs^1.4) passes it.
MAX_SECONDS = 30.0
#: The same for the default rtol (best effort: the last level is returned, flagged).
DEFAULT_SECONDS = 10.0
#: The convergence model of the prediction (module docstring): the first level's
#: estimate, and the factor each further level divides it by.
FIRST_ESTIMATE = 1e-3
PER_LEVEL = 10.0
#: The lowest estimates the measured ladders reached before they stopped falling
#: (module docstring): an rtol below it is named in the cost's note.
FLOOR = 1e-7


def start_nx(system, opts) -> int:
    """Cells across x of the first level: 16, more where a wall layer needs it
    (a node spacing at most the layer width at degree 2)."""
    from .wall_layers import wall_layers
    dom, _, _ = opts.replace(nx=16).grid(system)
    width = dom.x1 - dom.x0
    need = 16
    for *_, ell in wall_layers(system):
        need = max(need, math.ceil(width / (2 * ell)))
    return int(min(need, MAX_NX))


def is_best_effort(opts: Any) -> bool:
    """Whether stationary options make the default call's ladder: no rtol, mesh, nx,
    ny, positivity or degree (other than 1) given, the structured quadrilateral mesh
    with tensor assembly (as :func:`fpk_vibro.fem.stationary` decides)."""
    return (opts.rtol is None and opts.mesh is None and opts.nx is None and opts.ny is None
            and opts.degree == 1 and opts.positivity == "auto" and opts.element == "quad"
            and opts.assembly != "general")


def uses_ladder(opts: Any, mode: str) -> bool:
    """Whether stationary options make this ladder of solves (rtol given, or the
    default call) rather than one solve (not the ladder's own levels: nx given)."""
    return (mode == "stationary" and opts.nx is None
            and (opts.rtol is not None or is_best_effort(opts)))


def levels(system, opts) -> list[Any]:
    """The options of the ladder's levels for ``opts``, up to :data:`MAX_NX` (the
    first one as :func:`fpk_vibro.fem.estimate.adaptive` makes it)."""
    grading = opts.wall_grading or WALL_GRADING
    first = opts.replace(degree=2, nx=start_nx(system, opts), ny=None, positivity=False,
                         wall_grading=grading, rtol=None)
    _, nx, ny = first.grid(system)
    out = [first.replace(ny=ny)]
    while True:
        last = out[-1]
        if last.degree < 4:
            out.append(last.replace(degree=last.degree + 1))
        elif 2 * last.nx <= MAX_NX:
            out.append(last.replace(nx=2 * last.nx, ny=2 * last.ny))
        else:
            return out


def ladder_cost(system, opts) -> Cost:
    """The predicted cost of the ladder ``opts`` makes (module docstring): the levels
    up to the one after the first whose modelled estimate meets rtol, at most those
    that fit :data:`MAX_SECONDS` (:data:`DEFAULT_SECONDS` for the default), the
    memory budget and :data:`MAX_NX`; the memory is the largest of the levels that
    fit (a slowly converging system climbs to them).  ``note`` says where rtol is
    predicted beyond them."""
    best_effort = opts.rtol is None
    rtol = opts.rtol if opts.rtol is not None else DEFAULT_RTOL
    limit = DEFAULT_SECONDS if best_effort else MAX_SECONDS
    # the level whose estimate is modelled to meet rtol, and the one solved after it
    need = max(0, math.ceil(math.log(FIRST_ESTIMATE / rtol) / math.log(PER_LEVEL) - 1e-9))
    memory_limit = MEMORY_SHARE * available_memory()
    fit: list[tuple[Any, Cost]] = []
    seconds = 0.0
    for level in levels(system, opts):
        cost = level.estimate(system, "stationary")
        if fit and (seconds + cost.seconds > limit or cost.memory > memory_limit):
            break
        seconds += cost.seconds
        fit.append((level, cost))
    total = fit[0][1]
    for _, cost in fit[1:need + 2]:
        total = total + cost
    memory = max(cost.memory for _, cost in fit)
    if len(fit) >= need + 2 and rtol >= FLOOR:
        return Cost(memory, total.work, total.unit, total.seconds, "rtol")
    top = fit[-1][0]
    where = f"degree {top.degree}, nx = {top.nx}"
    if best_effort:
        why = (f"the default (rtol = {rtol:g}, best effort) may stop short of it: the "
               f"levels up to {where} fit {limit:g} s; a shortfall is flagged with a "
               "RuntimeWarning")
    else:
        why = (f"rtol = {rtol:g} may not be reached: the levels up to {where} fit "
               f"{limit:g} s" + (f", and estimates below ~{FLOOR:g} are rarely reached "
                                 "(the truncation, wall corners)" if rtol < FLOOR else "")
               + "; the run then refuses naming rtol: give a larger rtol, or nx and degree")
    return Cost(memory, total.work, total.unit, total.seconds, "rtol", note=why)
