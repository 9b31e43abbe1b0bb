"""The rtol ladder of ``fem.stationary``: its levels, its limits and its predicted cost.

``fem.stationary(system, rtol=...)``, and the default call (rtol = 1e-4, best effort),
solve a ladder of Galerkin levels (:func:`fpk_vibro.fem.adaptive.adaptive`).  A level's
estimate is its difference to richer levels (degree k + 1 on the same mesh; at
degree 4 the mesh refined in x and, separately, in y: :func:`richer_levels`), so
each level returned costs the level and its richer ones.  Its goal: the estimated
relative errors of E[H], E[x²], E[y²], P_impact *and* the L1 error of the density
below rtol (:data:`fpk_vibro.fem.compare.AIMED`, issue 31).

Where the ladder starts and how it climbs:

- degree: :func:`start_degree`, by rtol (:data:`START_DEGREE`): degree 2 for
  rtol ≥ 1e-2, 3 down to 3e-3, else 4 at once.  Measured on 12 random scenes of
  ``bench fem-scenes`` (wall grading 2, nx = 16): the L1 estimates at degree 2, 3,
  4 were 6e-4 – 1.6, 2.4e-4 – 7.7e-2 and 5.7e-5 – 9.3e-3, so below 3e-3 the lower
  degrees only cost their solves;
- the mesh: :func:`start_nx` cells across x from the system's scales (16, more
  where a wall layer needs it), ny from the aspect rule of ``Options.grid`` within
  :data:`FIRST_NY`;
- then, at degree 4, nx and ny grow each by the factor its own part of the estimate
  needs (:func:`next_grid`): a part falls like (n'/n)^−q, q measured from the last
  two degree-4 levels that refined that direction (:func:`measured_rates`), else
  :data:`RATE`; the next level aims at :data:`AIM` · rtol, each direction growing
  at most 4× (:data:`STEP`), and a direction far below its share is coarsened.
  Measured q (L1, Q4, nx 16 → 32): 1.3–4.4 on walls with r < 1, 4 and more
  without; the x part was 7–200 times the y part on five random scenes (ny = 4 nx
  by the aspect rule there), so refining both, as nx and ny doubled before, paid
  for DOFs the error did not need.  Before, a goal just missed at nx took the
  levels 2 nx and 4 nx (16 times the DOFs of nx); 1.3 nx with its two richer
  levels (3.4 times each) costs about a quarter of that.

Limits: a level whose solves (it and its richer ones) would take the whole solve
past :data:`MAX_SECONDS` (:data:`DEFAULT_SECONDS` for the default) or nx past
:data:`MAX_NX` is not solved.  Where even :data:`BEST_RATE` (or a measured rate,
once the estimates are below :data:`PREASYMPTOTIC`) puts the goal beyond those
limits, an explicit rtol is refused at once in one line naming the prediction; the
default goes on to the largest level that fits its time and returns its last
estimated level, flagged, with one RuntimeWarning.

:func:`ladder_cost` is what ``fem.Options.estimate`` (and so ``fpk-vibro check``)
gives for such a solve: the same plan under a convergence model on the slow side of
the measured ones (:data:`FIRST_ESTIMATE` at a first level of degree 2, a factor
:data:`PER_LEVEL` per degree, :data:`MODEL_RATE` in nx and ny), up to the levels
that fit.  The moment estimates stop falling at a floor of 1e-7 – 3e-6 (the mass
beyond the truncation, < 1e-8 of it, and the corners of walls with r < 1); the L1
error of densities with such corners converges slowly (q = 0.1–2: at r = 0.05 and
r = 0 it hardly converges at all): where rtol lies beyond the levels that fit, the
cost says so in its ``note``.
"""
from __future__ import annotations

import math
from typing import Any

from ..budget import Cost, available_memory, MEMORY_SHARE

__all__ = ["DEFAULT_RTOL", "WALL_GRADING", "MAX_NX", "MAX_SECONDS", "DEFAULT_SECONDS",
           "START_DEGREE", "RATE", "BEST_RATE", "RATE_RANGE", "AIM", "STEP", "FIRST_NY",
           "PREASYMPTOTIC", "COST_POWER",
           "FIRST_ESTIMATE", "PER_LEVEL", "MODEL_RATE", "FLOOR", "start_nx", "start_degree",
           "first_level", "richer_levels", "next_grid", "measured_rates", "is_best_effort",
           "uses_ladder", "levels", "ladder_cost"]

#: The accuracy goal of a stationary solve given no mesh, nx, ny, degree or
#: positivity (fem.adaptive; measured cost: docs/measurements.md).
DEFAULT_RTOL = 1e-4
#: The x-grading power toward walls with r < 1 that rtol's meshes use
#: (fem.mesh.wall_nodes; 2 against 3 and uniform on 20 random scenes:
#: docs/measurements.md, §FE error estimate and rtol; 3 and 4 helped the L1 of
#: some scenes and hurt others at nx = 16, issue 31).
WALL_GRADING = 2.0
#: Largest nx the ladder tries.
MAX_NX = 4096
#: Longest the ladder may take (s): a level is not solved when the time spent plus
#: the predicted time of the level and its richer one passes it.
MAX_SECONDS = 30.0
#: The same for the default rtol (best effort: the last level is returned, flagged).
DEFAULT_SECONDS = 3.0
#: (rtol at least, first degree); below the last rtol the ladder starts at degree 4.
START_DEGREE = ((1e-2, 2), (3e-3, 3))
#: The power of nx by which a degree-4 estimate falls before one is measured, the
#: one that decides whether a goal is out of reach before a rate is measured (Q4's
#: L1 order on smooth densities, 5 falling to 4), and the range a measured one is
#: clipped to.
RATE = 4.0
BEST_RATE = 5.0
RATE_RANGE = (0.1, 6.0)
#: The next level aims at an estimate of AIM · rtol.
AIM = 0.5
#: Smallest and largest growth of nx from one degree-4 level to the next.
STEP = (1.25, 4.0)
#: Cells across y of the first level: the rule of ``Options.grid`` (h_y ≈ 1.5 h_x,
#: at most 4 nx) clipped to this range.  Measured at Q4, nx = 16 on six random
#: scenes whose rule gave ny = 64: halving ny changed the L1 error by 1–1.7× on four
#: (x set it) and 2–4× on two (r < 1 corners), which the next level then refines.
FIRST_NY = (16, 32)
#: An estimate above this (relative, or L1) is taken as short of the asymptotic
#: range until a rate is measured: no level is judged out of reach from it.
PREASYMPTOTIC = 1e-2

#: A level's seconds scale with its DOFs to this power (the factorisation; measured
#: Q4 66 177 → 263 425 DOFs: 0.42 → 3.0 s, power 1.42).
COST_POWER = 1.4
#: The convergence model of the cost prediction (module docstring): the estimate of
#: a first level of degree 2, the factor per degree, the power of nx at degree 4.
FIRST_ESTIMATE = 3e-2
PER_LEVEL = 5.0
MODEL_RATE = 2.0
#: The lowest moment estimates the measured ladders reached before they stopped
#: falling (module docstring): an rtol below it is named in the cost's note.
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


def start_degree(rtol: float) -> int:
    """The degree of the first level for ``rtol`` (:data:`START_DEGREE`)."""
    for at_least, degree in START_DEGREE:
        if rtol >= at_least:
            return degree
    return 4


def first_level(system, opts, rtol: float) -> Any:
    """The options of the ladder's first level: :func:`start_degree`, :func:`start_nx`
    cells, Galerkin, wall-graded (:data:`WALL_GRADING` unless given)."""
    level = opts.replace(degree=start_degree(rtol), nx=start_nx(system, opts), ny=None,
                         positivity=False, wall_grading=opts.wall_grading or WALL_GRADING,
                         rtol=None)
    ny = min(max(level.grid(system)[2], FIRST_NY[0]), FIRST_NY[1])
    return level.replace(ny=ny)


def richer_levels(level) -> list:
    """The levels whose differences estimate ``level``'s: degree + 1 on the same
    mesh; at degree 4 the mesh refined in x (2 nx) and, separately, in y (2 ny)."""
    if level.degree < 4:
        return [level.replace(degree=level.degree + 1)]
    return [level.replace(nx=2 * level.nx), level.replace(ny=2 * level.ny)]


def measured_rates(history: list) -> dict[tuple[str, str], float]:
    """{(direction, quantity): q}: the power of nx (ny) by which the x (y) part of
    each quantity's degree-4 estimate fell between the last two degree-4 levels of
    ``history`` ((degree, nx, ny, {"x": parts, "y": parts}) tuples) that changed
    that direction, clipped to :data:`RATE_RANGE`."""
    fours = [h for h in history if h[0] == 4]
    out: dict[tuple[str, str], float] = {}
    for i, axis in ((1, "x"), (2, "y")):
        for (_, *n0, p0), (_, *n1, p1) in zip(fours, fours[1:]):
            m0, m1 = n0[i - 1], n1[i - 1]
            if m1 < 1.1 * m0 and m0 < 1.1 * m1:
                continue
            for k, b in p1[axis].items():
                a = p0[axis].get(k, math.nan)
                if 0 < a < math.inf and 0 < b < math.inf:
                    q = math.log(a / b) / math.log(m1 / m0)
                    out[(axis, k)] = min(max(q, RATE_RANGE[0]), RATE_RANGE[1])
    return out


def next_grid(nx: int, ny: int, est: dict[str, float], parts: dict[str, dict],
              rtol: float, rates: dict, rate: float = RATE, cap: float = STEP[1]
              ) -> tuple[int, int]:
    """(nx, ny) of the next degree-4 level (module docstring).

    Each quantity's estimate ``est[k]`` is split between x and y as its parts
    ``parts["x"][k]``, ``parts["y"][k]`` (the differences to the levels refined in x
    and in y); the two shares of :data:`AIM` · rtol are those that make the level
    cheapest, in the ratio q_y : q_x of the rates (measured, else ``rate``), and
    each direction grows by the factor its share needs (the largest over the
    quantities), at most ``cap``; a direction whose part is far below its share is
    coarsened (at most 2×, ny ≥ 8 cells).  Where a measured rate is below 1 (a
    direction that stalls when refined alone: the error is not the sum of the two
    parts there, e.g. the corner of an r < 1 wall at a fixed ny) both grow by the
    larger factor.  At least one direction grows by the first of :data:`STEP`; an
    unbounded estimate (levels 50 % apart) doubles both."""
    fx = fy = 0.0
    for k, e in est.items():
        e = float(e)
        px, py = float(parts["x"].get(k, 0.0)), float(parts["y"].get(k, 0.0))
        if not math.isfinite(e) or not math.isfinite(px + py):
            fx, fy = max(fx, 2.0), max(fy, 2.0)
            continue
        if px + py <= 0.0:
            continue
        qx, qy = rates.get(("x", k), rate), rates.get(("y", k), rate)
        ex, ey = e * px / (px + py), e * py / (px + py)
        goal = AIM * rtol
        sx, sy = goal * qy / (qx + qy), goal * qx / (qx + qy)
        if ey < sy:                   # y meets its share: x takes the rest
            sx = max(sx, goal - ey)
        elif ex < sx:
            sy = max(sy, goal - ex)
        fx = max(fx, (ex / sx) ** (1.0 / qx) if ex > 0 else 0.0)
        fy = max(fy, (ey / sy) ** (1.0 / qy) if ey > 0 else 0.0)
    if any(q < 1.0 for q in rates.values()):     # a direction that stalls alone: the
        fx = fy = max(fx, fy)                     # error is not a sum of the two parts
    if max(fx, fy) < STEP[0]:         # (progress: the larger factor grows)
        fx, fy = (STEP[0], fy) if fx >= fy else (fx, STEP[0])
    fx = min(fx, cap) if fx >= 1.0 else 1.0
    fy = min(fy, cap) if fy >= 0.75 else max(0.5, fy, 8.0 / ny)
    return (int(min(math.ceil(nx * fx / 2.0) * 2, 2 ** 31)),
            int(min(math.ceil(ny * fy / 2.0) * 2, 2 ** 31)))


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


def levels(system, opts) -> list[tuple[Any, float]]:
    """(options, modelled estimate) of the levels the ladder of ``opts`` is
    predicted to solve under the cost model (module docstring), each level followed
    by its richer one, up to the one that meets rtol or :data:`MAX_NX`."""
    rtol = opts.rtol if opts.rtol is not None else DEFAULT_RTOL
    level = first_level(system, opts, rtol)
    est = FIRST_ESTIMATE / PER_LEVEL ** (level.degree - 2)
    out: list[tuple[Any, float]] = []
    while level.nx <= MAX_NX:
        out.append((level, est))
        richer = richer_levels(level)
        if richer[0].nx > MAX_NX:
            break
        if level.degree == 4 or est <= rtol:     # (below 4 the richer is the next level)
            out += [(r, est) for r in richer]
        if est <= rtol:
            break
        if level.degree < 4:
            level, est = richer[0], est / PER_LEVEL
            continue
        half = {"L1": 0.5}             # (the model: x and y alike)
        nx, ny = next_grid(level.nx, level.ny, {"L1": est}, {"x": half, "y": half}, rtol,
                           {}, MODEL_RATE)
        est *= (level.nx / nx) ** MODEL_RATE
        level = level.replace(nx=nx, ny=ny)
    return out


def ladder_cost(system, opts) -> Cost:
    """The predicted cost of the ladder ``opts`` makes (module docstring): the levels
    of :func:`levels` that fit :data:`MAX_SECONDS` (:data:`DEFAULT_SECONDS` for the
    default), the memory budget and :data:`MAX_NX`; the memory is the largest of
    them.  ``note`` says where rtol is predicted beyond them."""
    best_effort = opts.rtol is None
    rtol = opts.rtol if opts.rtol is not None else DEFAULT_RTOL
    limit = DEFAULT_SECONDS if best_effort else MAX_SECONDS
    memory_limit = MEMORY_SHARE * available_memory()
    plan = levels(system, opts)
    fit: list[tuple[Any, Cost]] = []
    seconds = 0.0
    for level, _ in plan:
        cost = level.estimate(system, "stationary")
        if fit and (seconds + cost.seconds > limit or cost.memory > memory_limit):
            break
        seconds += cost.seconds
        fit.append((level, cost))
    total = fit[0][1]
    for _, cost in fit[1:]:
        total = total + cost
    memory = max(cost.memory for _, cost in fit)
    if len(fit) == len(plan) and plan[-1][1] <= rtol and rtol >= FLOOR:
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
