"""Mean first-passage time and reliability from the discrete generator.

The safe set S = {H < H_c} on the strip is |y| < Y(x) = sqrt(2 (H_c − G(x))) over
the x where G(x) < H_c: one or more intervals (:func:`safe_set_components`; two for
a double well below its hump, one next to each wall for a softening spring whose
walls lie beyond its humps), each between the walls it reaches and turning points
G(A) = H_c (a turning-point end is pulled just inside).  Paths never leave their
part, so each part holding start mass is solved on its own: τ from a point is that
of its part; a spread start mixes the parts by their start mass.  Each part is
meshed by quadrilaterals fitted to it, the absorbing boundary H = H_c a mesh
boundary (:mod:`fpk_vibro.fem.safe_set`).  On the old uniform straight-edged mesh τ
converged erratically at order <= 2 (paper case c = 0.2, H_c = 0.15: 0.36 % off at
nx = 24; docs/fem_first_passage.md); on one not graded toward walls with r < 1 at
order <= 1 (0.35 % off at nx = 32 next to r = 0.05 and 0.36 walls; :data:`WALL_POWER`).
Error estimate: the same solve at nx/2, ny/2, n_steps/2 and at nx/4, ny/4
(:data:`ASSUMES`).
On it the same generator L and mass matrix M as for densities are assembled
(:func:`fpk_vibro.fem.generator.assemble`, impact coupling included), and the DOFs on
the absorbing boundary are fixed to zero.  Restricted to the free DOFs f:

- the killed density obeys M_ff dp/dt = L_ff p, and the survival probability is
  R(t) = unit_fᵀ p(t);
- hence ∫₀^∞ R dt = unit_fᵀ (−L_ff)⁻¹ M_ff p0 = τᵀ M_ff p0 with
  τ = (−L_ffᵀ)⁻¹ unit_f: τ is the nodal vector of the mean first-passage time
  τ(x, y) (the backward Kolmogorov equation L* τ = −1, τ = 0 on H = H_c, in the
  adjoint of the very matrix the densities use);
- likewise R(t | p0) = g(t)ᵀ M_ff p0 with M g' = L_ffᵀ g, g(0) = 1: one backward
  march gives the reliability from every start at once (from a point: g(t, x0, y0)).
  Its step is set by τ (5 τ / n_steps) and it runs to 5 τ or the largest requested
  time, at most :data:`HORIZON` τ; requested times are read from that grid.

Resolution (:mod:`fpk_vibro.fem.passage_parts`). τ grows like the inverse of the
slowest rate λ₁ of −L_ff, which a rounding of the matrix by eps |L| moves by about
eps 1ᵀ|L||v| / unitᵀ|v| (v the slowest mode, one inverse iteration with the same
factors). That relative error of τ is estimated on every solve
(``info["rounding_error"]``; measured against two orderings of the factorisation it
is 20–60 times the observed spread) and a value above :data:`RESOLVABLE`, a negative
τ or a solve that broke down is refused with the magnitude of τ from averaging.
Paper case r = 0.92, nx = 24: H_c = 2.5 gives τ = 1.6e10 (estimate 1e-4); H_c = 3 (τ
~ 10^13) is refused; H_c = 100 (τ ~ 10^796) returned −2.7e15 before.
Cost: the stationary solver's model
(:meth:`fpk_vibro.fem.Options.estimate`) through :func:`fpk_vibro.budget.enforce`.
"""
from __future__ import annotations

import math
import time
from typing import Any, Sequence

import numpy as np

from .. import budget
from ..budget import Cost
from ..first_passage import (FirstPassage, check_energy, check_times, merge_requested,
                             parse_start, survival_at)
from ..safe_sets import parse_safe_set
from ..model import VibroImpactSystem, check_system
from .options import PASSAGE_NX, Options, passage_cost
from .passage_parts import RESOLVABLE, TauField, solve_part, survival, unresolvable
from .passage_sets import SetTauField, solve_set, unresolvable_set
from .safe_set import WALL_POWER, safe_set_components, safe_set_mesh

__all__ = ["first_passage", "safe_set_components", "safe_set_mesh", "RESOLVABLE",
           "HORIZON", "DEFAULT_NX", "MAX_NX", "WALL_POWER", "COARSER_REDUCTION"]


#: The reliability march stops at this many mean times of the slowest start of the
#: part (R ~ e^-40 there) even if later times are requested; R is read beyond it
#: with its decay rate.
HORIZON = 40.0


def estimate(system: VibroImpactSystem, nx: int, ny: int, degree: int, n_steps: int,
             parts: int = 1) -> Cost:
    """Memory and time of a call (:func:`passage_cost`)."""
    return passage_cost(system, nx, ny, degree, n_steps, parts)


def first_passage(system: VibroImpactSystem, *, energy: float | None = None,
                  displacement: Any = None, impact_speed: float | None = None,
                  start: Any = (0.0, 0.0),
                  times: Sequence[float] | None = None, nx: int | None = None,
                  ny: int | None = None, degree: int = 2, n_steps: int = 200,
                  rtol: float | None = None) -> FirstPassage:
    """Mean first-passage time τ(x, y) and reliability R(t) out of a safe set:
    {H < energy}, a displacement band, or no impact faster than a speed.

    Parameters
    ----------
    system : VibroImpactSystem
    energy : float
        The critical energy H_c (above min G on the strip).
    displacement : float or (float, float)
        Instead of ``energy``: the set |x| < b, or x_lo < x < x_hi
        (:mod:`fpk_vibro.fem.passage_sets`: the strip cut there, absorbing where
        paths leave it, y > 0 at x_hi and y < 0 at x_lo).
    impact_speed : float
        Instead of ``energy``: the time of the first impact faster than u_c (the
        whole strip, its walls absorbing impacts faster than u_c and keeping their
        restitution law for slower ones).  Exactly one of the three.
    start : (x0, y0), dict or "stationary"
        Where paths start (:func:`fpk_vibro.first_passage.parse_start`); default the
        equilibrium at rest.
    times : sequence of float, optional
        Times at which R(t) must be known, in any order
        (:func:`fpk_vibro.first_passage.check_times`).  R is computed on the solver's
        own grid, up to 5 τ or the largest requested time but at most
        :data:`HORIZON` τ, and read at these times.
    nx, ny, degree : int
        Cells across x and y of each part of the safe set (nx default
        :data:`DEFAULT_NX`; ny default 2 nx, even) and the Lagrange degree (2: the
        isoparametric mesh of :func:`safe_set_mesh`).  With ``rtol`` nx is where the
        refinement starts.
    n_steps : int
        BDF2 steps of the reliability march per 5 τ (at most 8 n_steps in all).
        These numerical keywords are declared (range, default) by
        :class:`fpk_vibro.fem.Options`, mode "first_passage".
    rtol : float, optional
        Target of the error estimate: nx (and ny, n_steps) are doubled, up to
        :data:`MAX_NX`, until both ``error_estimate()["mean_time"]`` and
        ``["reliability"]`` are at most rtol.  A target the budget or MAX_NX does not
        allow is reported by a warning and ``info["rtol_met"] = False``.

    Returns
    -------
    FirstPassage
        ``mean_time(x0, y0)`` evaluates τ_h on the parts of the safe set that hold
        the start; ``reliability(t)`` for the start.  ``info["rounding_error"]``:
        the estimated relative error of τ from rounding.  ``error_estimate()``: from
        the same problem solved with nx/2, ny/2 and n_steps/2 and (τ only) nx/4,
        ny/4 (:data:`ASSUMES`; ``"levels"`` lists them, the answer's last).

    Raises
    ------
    InputError
        For an invalid argument (naming it), a mesh beyond the memory or time
        budget (:mod:`fpk_vibro.budget`, naming ``nx``), or an energy whose mean
        time double precision cannot resolve (naming ``energy``, with the estimated
        magnitude): the rounding error of τ, estimated from the factorisation, above
        :data:`RESOLVABLE`.

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem, fem
    >>> fp = fem.first_passage(VibroImpactSystem.paper(r=0.92), energy=0.5)
    >>> round(fp.mean_time(), -1) > 0
    True
    """
    where = "fem.first_passage"
    check_system(where, system)
    safe = parse_safe_set(where, system, energy=energy, displacement=displacement,
                          impact_speed=impact_speed)
    H_c = check_energy(where, system, energy) if safe.kind == "energy" else None
    kind, value = parse_start(where, system, start, safe if H_c is None else H_c)
    requested = check_times(where, times)
    opts, _ = Options.prepare(system, "first_passage", locals())
    nx = DEFAULT_NX if opts.nx is None else opts.nx
    ny = 2 * nx if opts.ny is None else opts.ny
    degree, n_steps, rtol = opts.degree, opts.n_steps, opts.rtol
    if H_c is None:
        parts = [safe]       # one rectangle of the strip (fem.passage_sets)
    else:
        parts = safe_set_components(system, H_c)
        if not parts:
            raise ValueError(f"{where}: the safe set H < {H_c:g} is empty on the strip")
        if kind == "point":
            parts = [p for p in parts if p[0] <= value[0] <= p[1]][:1]
    budget.enforce(estimate(system, nx, ny, degree, n_steps, len(parts)), where)
    t0 = time.perf_counter()
    coarser = _coarser_level(where, system, parts, H_c, nx, ny, degree, kind, value)
    coarse = _level(where, system, parts, H_c, max(2, nx // 2), _half_even(ny), degree,
                    kind, value)
    fine = _level(where, system, parts, H_c, nx, ny, degree, kind, value)
    met = None
    while rtol is not None:
        if coarser is not None and _mean_estimate(fine, coarse, coarser) <= rtol:
            break       # the reliability is checked after its march (below)
        if 2 * nx > MAX_NX or not _affordable(system, 2 * nx, 2 * ny, degree, n_steps,
                                              len(parts)):
            met = False
            break
        nx, ny = 2 * nx, 2 * ny
        coarser, coarse, fine = coarse, fine, _level(where, system, parts, H_c, nx, ny,
                                                     degree, kind, value)
    last_rel = math.inf
    while True:
        T, R, diff = _march_levels(fine, coarse, requested, n_steps)
        est_rel = diff / (2 ** ORDER - 1)
        est_mean = _mean_estimate(fine, coarse, coarser)
        if rtol is None or met is False or (est_rel <= rtol and est_mean <= rtol
                                            and coarser is not None):
            break
        # R's error is mostly the time step's (paper case, nx = 32: 3.6e-4, 1.3e-4,
        # 5e-5 at n_steps = 200, 400, 800; nx = 64 changes it by 4e-5): while τ is
        # resolved and doubling the steps still halves the estimate, only the
        # march is refined
        steps_only = est_mean <= rtol and est_rel < 0.6 * last_rel
        last_rel = est_rel
        if steps_only:
            if not _affordable(system, nx, ny, degree, 2 * n_steps, len(parts)):
                met = False
                break
            n_steps *= 2
            continue
        if 2 * nx > MAX_NX or not _affordable(system, 2 * nx, 2 * ny, degree,
                                              2 * n_steps, len(parts)):
            met = False
            break
        nx, ny, n_steps = 2 * nx, 2 * ny, 2 * n_steps
        coarser, coarse, fine = coarse, fine, _level(where, system, parts, H_c, nx, ny,
                                                     degree, kind, value)
    if rtol is not None:
        met = met is not False
        if not met:
            import warnings
            warnings.warn(f"{where}: rtol = {rtol:g} not reached (estimate: mean time "
                          f"{est_mean:.2g}, reliability {est_rel:.2g} at nx = {nx}); the "
                          f"next mesh is beyond MAX_NX = {MAX_NX} or the budget",
                          RuntimeWarning, stacklevel=2)
    T, R = merge_requested(T, R, requested)
    solved = fine["parts"]
    info = {"nx": nx, "ny": ny, "degree": degree, "n_steps": n_steps,
            "parts": len(solved),
            "ndofs": int(sum(p["ndofs"] for p in solved)),
            "free_dofs": int(sum(p["free"] for p in solved)),
            "rounding_error": fine["rounding"],
            "residual": float(max(p["residual"] for p in solved)),
            "seconds": time.perf_counter() - t0,
            "x_range": (float(min(p["mesh"].p[0].min() for p in solved)),
                        float(max(p["mesh"].p[0].max() for p in solved))),
            "mean_coarse": coarse["mean"],
            "mean_coarser": None if coarser is None else coarser["mean"]}
    if rtol is not None:
        info["rtol"], info["rtol_met"] = rtol, met
    levels = ((coarse["nx"], coarse["ny"], n_steps // 2), (nx, ny, n_steps))
    if coarser is not None:
        levels = ((coarser["nx"], coarser["ny"], None),) + levels
    estimate_ = {"mean_time": float(est_mean), "reliability": est_rel, "order": ORDER,
                 "coarser_reduction": COARSER_REDUCTION, "levels": levels,
                 "assumes": ASSUMES}
    if H_c is None:
        field = SetTauField(system, safe, solved[0]["tau_h"])
    else:
        field = TauField(system, H_c, [(p["tau_h"], p["mesh"], p["part"][:2])
                                       for p in solved])
    return FirstPassage("fem", system, H_c, (kind, value), fine["mean"], 0.0, T, R, None,
                        info, _mean_at=field, _estimate=estimate_, safe_set=safe)


#: Cells across x by default (:data:`fpk_vibro.fem.options.PASSAGE_NX`).
DEFAULT_NX = PASSAGE_NX
#: Largest nx the rtol refinement goes to.
MAX_NX = 512
#: The lowest order the two-level estimate assumes: error ≤ |fine − coarse| / (2^ORDER − 1).
#: Measured orders on the curved mesh are 2 to 3 before the finest levels, but the
#: paper case (c = 0.2, H_c = 0.15) showed 1.2 between nx = 32 and 64 and the double
#: well ~1 between 64 and 128 (at 1e-5): with ORDER = 1 the estimate stays an upper
#: bound there and is 3–7 times pessimistic where the order is 2–3.
ORDER = 1
#: The fine level's error is also taken as at least |coarse − coarser| / COARSER_REDUCTION,
#: coarser = (nx/4, ny/4): where the error stalls or changes sign between the two
#: fine levels they agree by accident (softening b = −0.2, r = 0.5: τ at nx = 16 and 32
#: 8e-6 apart, 1e-4 off; double well with walls: 2e-5 apart, 5e-5 off).  8 = 2³, the
#: coarser pair's change reduced at the fastest order measured; true/estimate on 27
#: random and measured systems: docs/fem_first_passage.md, §Inelastic walls.
COARSER_REDUCTION = 8.0
ASSUMES = ("the error of the fine level is at most max(|fine − coarse|, |coarse − coarser| "
           "/ 8), coarse = (nx/2, ny/2, n_steps/2), coarser = (nx/4, ny/4): convergence "
           "of order >= 1 in the mesh and the BDF2 step, the coarser pair's change "
           "falling at most 8-fold to the fine level, and the levels in the asymptotic "
           "range, nx >= 32 (below, the two fine levels alone; at nx = 16 true/estimate "
           "was 0.02 to 4); measured true/estimate 0.04 to 0.9 on random systems.  "
           "mean_time is relative and adds the rounding estimate; reliability is the "
           "largest absolute difference of R over the coarse time grid (requested times "
           "read beyond it are not covered).")


def _half_even(ny: int) -> int:
    h = max(2, ny // 2)
    return h + (h % 2)


def _affordable(system, nx, ny, degree, n_steps, parts) -> bool:
    cost = estimate(system, nx, ny, degree, n_steps, parts)
    try:
        budget.enforce(cost, "fem.first_passage")
    except Exception:
        return False
    return True


def _mean_estimate(fine, coarse, coarser) -> float:
    """The relative error estimate of the fine level's τ (:data:`ASSUMES`)."""
    diff = abs(fine["mean"] - coarse["mean"]) / (2 ** ORDER - 1)
    if coarser is not None:
        diff = max(diff, abs(coarse["mean"] - coarser["mean"]) / COARSER_REDUCTION)
    return diff / fine["mean"] + fine["rounding"]


def _coarser_level(where, system, parts, H_c, nx, ny, degree, kind, value):
    """The level (nx/4, ny/4) of the estimate, or None below nx/4 = 8 (coarser levels
    are not in the asymptotic range: at nx = 16 true/estimate was 0.02–4 on the
    measured cases) or where that mesh is refused (an undershoot or rounding there
    does not refuse the answer)."""
    if nx // 4 < 8:
        return None
    try:
        return _level(where, system, parts, H_c, nx // 4, _half_even(_half_even(ny)),
                      degree, kind, value)
    except ValueError:
        return None


def _level(where, system, parts, H_c, nx, ny, degree, kind, value) -> dict[str, Any]:
    """τ on every part at one resolution (refusing an unresolvable τ); ``H_c`` None:
    the one part is a displacement or impact-speed :class:`SafeSet`."""
    solved = [solve_part(system, part, H_c, nx, ny, degree, kind, value) if H_c is not None
              else solve_set(system, part, nx, ny, degree, kind, value) for part in parts]
    solved = [p for p in solved if p["weight"] > 0]
    if not solved:
        inside = f"H < {H_c:g}" if H_c is not None else parts[0].describe()
        raise ValueError(f"{where}: the start density has no mass inside the safe set "
                         f"{inside}")
    total = sum(p["weight"] for p in solved)
    for p in solved:
        p["weight"] /= total
        if p["error"] > RESOLVABLE or not (0 < p["mean"] < math.inf):
            if H_c is None:
                raise unresolvable_set(where, parts[0], p)
            raise unresolvable(where, system, H_c, kind, value, p)
    return {"parts": solved, "nx": nx, "ny": ny,
            "mean": float(sum(p["weight"] * p["mean"] for p in solved)),
            "rounding": float(max(p["error"] for p in solved))}


def _march_levels(fine, coarse, requested, n_steps):
    """(T, R) of the fine level (n_steps) and max |R_fine − R_coarse| (n_steps / 2)
    over the coarse level's time grid, both marched with the fine level's time scales (the
    grids are nested when n_steps is a multiple of 8)."""
    t_req = float(requested[-1]) if requested is not None else 0.0
    out = []
    for level, steps in ((fine, n_steps), (coarse, max(10, n_steps // 2))):
        grids = []
        for p, q in zip(level["parts"], fine["parts"]):
            t_end = min(max(5.0 * q["mean"], t_req), HORIZON * q["tau_max"])
            grids.append(survival(p["L"], p["M"], q["mean"],
                                   max(t_end, 5.0 * q["mean"]), steps, p["at_start"]))
        if len(grids) == 1:
            T, R = grids[0]
        else:
            T = np.unique(np.concatenate([g[0] for g in grids]))
            T = T[T <= min(g[0][-1] for g in grids)]
            R = sum(p["weight"] * survival_at(g[0], g[1], T)
                    for p, g in zip(level["parts"], grids))
        out.append((T, R))
    (T, R), (Tc, Rc) = out
    return T, R, float(np.max(np.abs(survival_at(T, R, Tc) - Rc)))

