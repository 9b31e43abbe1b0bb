"""Mean first-passage time and reliability from the discrete generator.

The safe set S = {H < H_c} on the strip is |y| < Y(x) = sqrt(2 (H_c − G(x))) over
the x where G(x) < H_c: one or more intervals (:func:`safe_set_components`; two for
a double well below its hump, one next to each wall for a softening spring whose
walls lie beyond its humps), each between the walls it reaches and turning points
G(A) = H_c (a turning-point end is pulled just inside).  Paths never leave their
part, so each part holding start mass is solved on its own: τ from a point is that
of its part; a spread start mixes the parts by their start mass.  Each part is
meshed by quadrilaterals fitted to it: nodes
(x(s_i), η_j Y(x(s_i))) for uniform grids in s ∈ [0, 1] and η ∈ [−1, 1], x(s) graded
quadratically toward turning points, so that the absorbing boundary H = H_c is a
mesh boundary and y = 0 a mesh line; for degree 2 the mesh is isoparametric (edge
and centre nodes on the same map: the curved boundary is followed).  On the old
uniform straight-edged mesh τ converged erratically at order <= 2 (paper case
c = 0.2, H_c = 0.15: 0.36 % off at nx = 24; docs/fem_first_passage.md).  Error
estimate: the same solve at nx/2, ny/2, n_steps/2 (:data:`ASSUMES`).
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

Resolution.  τ grows like the inverse of the slowest rate λ₁ of −L_ff, which a
rounding of the matrix by eps |L| moves by about eps 1ᵀ|L||v| / unitᵀ|v| (v the
slowest mode, one inverse iteration with the same factors).  That relative error
of τ is estimated on every solve (``info["rounding_error"]``; measured against two
orderings of the factorisation it is 20–60 times the observed spread) and a value
above :data:`RESOLVABLE`, a negative τ or a solve that broke down is refused with
the magnitude of τ from averaging.  Paper case r = 0.92, nx = 24: H_c = 2.5 gives
τ = 1.6e10 (estimate 1e-4); H_c = 3 (τ ~ 10^13) is refused; H_c = 100 (τ ~ 10^796)
returned −2.7e15 before.  Cost: the stationary solver's model
(:meth:`fpk_vibro.fem.Options.estimate`) through :func:`fpk_vibro.budget.enforce`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem

from .. import budget
from .._checks import InputError, check_float, check_int
from ..budget import Cost
from ..first_passage import (FirstPassage, check_energy, check_times, merge_requested,
                             parse_start, survival_at)
from ..model import VibroImpactSystem, Wall, check_system
from .generator import assemble, element_for, quadrature_order
from .solution import FEMSolution

__all__ = ["first_passage", "safe_set_components", "safe_set_mesh", "RESOLVABLE",
           "HORIZON", "DEFAULT_NX", "MAX_NX"]


#: A side without a reached wall ends where Y(x) is this fraction of Y(0)-ish: just
#: inside the turning point (the cells there stay non-degenerate).
END_FRACTION = 1e-3
#: Largest accepted relative error of τ from rounding alone (module docstring).
RESOLVABLE = 1e-3
#: The reliability march stops at this many mean times of the slowest start of the
#: part (R ~ e^-40 there) even if later times are requested; R is read beyond it
#: with its decay rate.
HORIZON = 40.0
#: A τ_h below −NEGATIVE τ_max is a breakdown.  Milder undershoots are the
#: discretisation's (Q2 next to a turning point on coarse meshes: −3 % at nx = 8, one
#: wall at 0.6 and H_c = 0.25) and are measured by the two-level error estimate.
NEGATIVE = 0.1
#: Machine epsilon, with the growth of the sparse LU (measured: the estimate is
#: 20-60 times the spread of τ between two orderings of the factorisation).
_EPS = 1.1e-16


@dataclass(frozen=True)
class _Box:
    """The system as the assembly sees one part of the safe set: the same
    coefficients, only the walls the part reaches (no model check: a softening
    spring cut off before its walls is not a system on its own)."""
    a: float
    b: float
    c: float
    D1: float
    D2: float
    left: Wall | None
    right: Wall | None


def safe_set_components(system: VibroImpactSystem, H_c: float
                        ) -> list[tuple[float, float, Wall | None, Wall | None]]:
    """The connected parts of {G(x) < H_c} on the strip, left to right.

    Each is (x_lo, x_hi, left wall or None, right wall or None); a None end is a
    turning point G = H_c (the roots of the quartic, z = x² from its quadratic).  A
    double well below its hump has two parts; a softening spring whose walls lie
    beyond its humps has a part next to each wall.
    """
    a, b = system.a, system.b
    lo, hi = system.x_bounds
    z = []
    if b != 0:
        disc = a * a / 4.0 + b * H_c
        if disc >= 0:
            z = [(-a / 2.0 + sgn * math.sqrt(disc)) / (b / 2.0) for sgn in (-1.0, 1.0)]
    elif a != 0:
        z = [2.0 * H_c / a]
    roots = sorted({sgn * math.sqrt(v) for v in z if v >= 0 for sgn in (-1.0, 1.0)})
    finite = [r for r in roots if lo < r < hi]
    span = max([abs(r) for r in roots] + [1.0]) + 1.0
    points = [lo if math.isfinite(lo) else -span, *finite, hi if math.isfinite(hi) else span]
    out = []
    for p, q in zip(points[:-1], points[1:]):
        if q > p and float(system.potential(0.5 * (p + q))) < H_c:
            out.append((p, q, system.left if p == lo else None,
                        system.right if q == hi else None))
    return out


def _grading(part) -> str:
    """Which ends of a part are turning points: "both", "left", "right" or "none"."""
    tl, tr = part[2] is None, part[3] is None
    return "both" if tl and tr else "left" if tl else "right" if tr else "none"


def _u_of_s(kind: str, s: np.ndarray) -> np.ndarray:
    """The x-grading on [0, 1]: quadratic (x_A − x ∝ (1 − s)²) toward each turning
    point, so that Y(x) ∝ sqrt(x_A − x) is linear in s there."""
    if kind == "both":
        return 0.5 - 0.5 * np.cos(np.pi * s)
    if kind == "right":
        return np.sin(0.5 * np.pi * s)
    if kind == "left":
        return 1.0 - np.cos(0.5 * np.pi * s)
    return s


def _s_of_u(kind: str, u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    if kind == "both":
        return np.arccos(1.0 - 2.0 * u) / np.pi
    if kind == "right":
        return 2.0 * np.arcsin(u) / np.pi
    if kind == "left":
        return 2.0 * np.arccos(1.0 - u) / np.pi
    return u


class _SafeSetMap:
    """(s, η) ∈ [0, 1] × [−1, 1] ↦ (x(s), η Y(x(s))) and back: the fitted mesh is the
    image of a uniform nx × ny grid, so a point's cell is found in (s, η)."""

    def __init__(self, system, H_c, ends, kind, nx, ny, cells_param):
        self.system, self.H_c, self.ends, self.kind = system, H_c, ends, kind
        self.nx, self.ny = nx, ny
        i = np.rint(cells_param[0].min(axis=0) * nx).astype(int)
        j = np.rint((cells_param[1].min(axis=0) + 1.0) * 0.5 * ny).astype(int)
        self.table = np.full((nx, ny), -1, dtype=np.int64)
        self.table[i, j] = np.arange(i.size)

    def x(self, s):
        a, b = self.ends
        return np.where(s >= 1.0, b, np.where(s <= 0.0, a, a + (b - a) * _u_of_s(self.kind, s)))

    def Y(self, x):
        return np.sqrt(2.0 * np.maximum(self.H_c - self.system.potential(x), 0.0))

    def find(self, x, y):
        a, b = self.ends
        s = _s_of_u(self.kind, (np.asarray(x, float) - a) / (b - a))
        Y = self.Y(x)
        eta = np.clip(np.divide(y, Y, out=np.zeros_like(Y), where=Y > 0), -1.0, 1.0)
        i = np.clip(np.floor(s * self.nx).astype(int), 0, self.nx - 1)
        j = np.clip(np.floor((eta + 1.0) * 0.5 * self.ny).astype(int), 0, self.ny - 1)
        return self.table[i, j]


class _CurvedQuad(skfem.MeshQuad2):
    """The isoparametric (9-node) safe-set mesh: edge and centre nodes on the mapped
    grid, so that the absorbing boundary H = H_c is followed to third order (with
    straight edges τ converged at second order whatever the degree: the geometry
    error).  Points are located through the (s, η) grid (skfem has no element
    finder for quadratic meshes)."""

    _map: "_SafeSetMap | None" = None

    def element_finder(self, mapping=None):
        safe_map = self._map
        return lambda x, y: safe_map.find(x, y)


def safe_set_mesh(system: VibroImpactSystem, part: tuple, H_c: float, nx: int, ny: int,
                  degree: int = 1) -> tuple[skfem.MeshQuad1, _Box, np.ndarray]:
    """(mesh of one part of {H < H_c} fitted to its boundary, the system with only the
    walls the part reaches, mask of the boundary facets that absorb).

    Nodes (x(s_i), η_j Y(x(s_i))) for uniform s_i ∈ [0, 1], η_j ∈ [−1, 1], with x(s)
    graded quadratically toward turning points (:func:`_u_of_s`); for degree 2 the
    mesh is isoparametric (:class:`_CurvedQuad`).  Why: on a uniform x grid Y ∝
    sqrt(x_A − x) is not resolved near a turning point x_A and the straight edges cut
    the curved boundary, and τ converged erratically at second order at best (paper
    system c = 0.2, H_c = 0.15, Q2: 38.30, 38.22, 38.12, 38.086 for nx = 12 … 96
    against 38.0765); graded and curved: 38.094, 38.0817, 38.0787, 38.0774 for
    nx = 8 … 64 (docs/fem_first_passage.md).
    """
    x_lo, x_hi, left, right = part
    half = 0.5 * (x_hi - x_lo)
    ends = (x_lo if left is not None else x_lo + END_FRACTION * half,
            x_hi if right is not None else x_hi - END_FRACTION * half)
    box = _Box(system.a, system.b, system.c, system.D1, system.D2, left, right)
    param = skfem.MeshQuad1.init_tensor(np.linspace(0.0, 1.0, nx + 1),
                                        np.linspace(-1.0, 1.0, ny + 1))
    safe_map = _SafeSetMap(system, H_c, ends, _grading(part), nx, ny, param.p[:, param.t])
    if degree >= 2:
        param = skfem.MeshQuad2.from_mesh(param)
        P = param.doflocs
    else:
        P = param.p
    X = safe_map.x(P[0])
    pts = np.ascontiguousarray(np.vstack([X, P[1] * safe_map.Y(X)]))
    if degree >= 2:
        mesh = _CurvedQuad(pts, np.ascontiguousarray(param.t))
        object.__setattr__(mesh, "_map", safe_map)
    else:
        mesh = skfem.MeshQuad1(pts, np.ascontiguousarray(param.t))
    mid = mesh.p[:, mesh.facets].mean(axis=1)
    on_wall = np.zeros(mid.shape[1], dtype=bool)
    for w in (left, right):
        if w is not None:
            on_wall |= np.abs(mid[0] - w.position) <= 1e-12 * max(1.0, abs(w.position))
    absorbing = np.isin(np.arange(mesh.facets.shape[1]), mesh.boundary_facets()) & ~on_wall
    return mesh, box, absorbing


def estimate(system: VibroImpactSystem, nx: int, ny: int, degree: int, n_steps: int,
             parts: int = 1) -> Cost:
    """Memory and time of a call: the stationary solver's cost model
    (:meth:`fpk_vibro.fem.Options.estimate`, general assembly) for one factorisation
    per part, two factors alive at once in the reliability march (five in all) and
    at most 8 n_steps steps of two triangular solves."""
    from .options import Options
    one = Options(nx=nx, ny=ny, degree=degree, positivity=False,
                  assembly="general").estimate(system, "stationary")
    n = float((degree * nx + 1) * (degree * ny + 1))
    lu, factor_s = one.memory - 80e6, one.seconds - 0.2
    steps = 8.0 * n_steps
    return Cost(80e6 + 2.0 * lu, parts * n * steps, "DOF-steps",
                0.2 + parts * (5.0 * factor_s + steps * 2.0 * 3e-7 * n), "nx")


def first_passage(system: VibroImpactSystem, *, energy: float, start: Any = (0.0, 0.0),
                  times: Sequence[float] | None = None, nx: int | None = None,
                  ny: int | None = None, degree: int = 2, n_steps: int = 200,
                  rtol: float | None = None) -> FirstPassage:
    """Mean first-passage time τ(x, y) and reliability R(t) out of {H < energy}.

    Parameters
    ----------
    system : VibroImpactSystem
    energy : float
        The critical energy H_c (above min G on the strip).
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
        the estimated relative error of τ from rounding.  ``error_estimate()``: the
        two-level estimate (:func:`_two_level`): the same problem is solved with
        nx/2, ny/2 and n_steps/2.

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
    H_c = check_energy(where, system, energy)
    kind, value = parse_start(where, system, start, H_c)
    requested = check_times(where, times)
    nx = check_int("nx", DEFAULT_NX if nx is None else nx, 2, 4096, where=where)
    ny = check_int("ny", 2 * nx if ny is None else ny, 2, 8192, where=where)
    if ny % 2:
        raise ValueError(f"{where}: ny must be even (y = 0 is a mesh line); got {ny}")
    degree = check_int("degree", degree, 1, 2, where=where)
    n_steps = check_int("n_steps", n_steps, 10, 10 ** 6, where=where)
    if rtol is not None:
        rtol = check_float("rtol", rtol, lo=0.0, lo_open=True, where=where)
    parts = safe_set_components(system, H_c)
    if not parts:
        raise ValueError(f"{where}: the safe set H < {H_c:g} is empty on the strip")
    if kind == "point":
        parts = [p for p in parts if p[0] <= value[0] <= p[1]][:1]
    budget.enforce(estimate(system, nx, ny, degree, n_steps, len(parts)), where)
    t0 = time.perf_counter()
    coarse = _level(where, system, parts, H_c, max(2, nx // 2), _half_even(ny), degree,
                    kind, value)
    fine = _level(where, system, parts, H_c, nx, ny, degree, kind, value)
    met = None
    while rtol is not None:
        est = abs(fine["mean"] - coarse["mean"]) / (2 ** ORDER - 1) / fine["mean"] \
            + fine["rounding"]
        if est <= rtol:
            break       # the reliability is checked after its march (below)
        if 2 * nx > MAX_NX or not _affordable(system, 2 * nx, 2 * ny, degree, n_steps,
                                              len(parts)):
            met = False
            break
        nx, ny = 2 * nx, 2 * ny
        coarse, fine = fine, _level(where, system, parts, H_c, nx, ny, degree, kind, value)
    last_rel = math.inf
    while True:
        T, R, diff = _march_levels(fine, coarse, requested, n_steps)
        est_rel = diff / (2 ** ORDER - 1)
        est_mean = abs(fine["mean"] - coarse["mean"]) / (2 ** ORDER - 1) / fine["mean"] \
            + fine["rounding"]
        if rtol is None or met is False or (est_rel <= rtol and est_mean <= rtol):
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
        coarse, fine = fine, _level(where, system, parts, H_c, nx, ny, degree, kind, value)
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
            "mean_coarse": coarse["mean"]}
    if rtol is not None:
        info["rtol"], info["rtol_met"] = rtol, met
    estimate_ = {"mean_time": float(est_mean), "reliability": est_rel, "order": ORDER,
                 "levels": ((coarse["nx"], coarse["ny"], n_steps // 2), (nx, ny, n_steps)),
                 "assumes": ASSUMES}
    field = _TauField(system, H_c, [(p["tau_h"], p["mesh"], p["part"][:2]) for p in solved])
    return FirstPassage("fem", system, H_c, (kind, value), fine["mean"], 0.0, T, R, None,
                        info, _mean_at=field, _estimate=estimate_)


#: Cells across x by default: within 0.2 % of converged on the measured cases
#: (docs/fem_first_passage.md) in about a second.
DEFAULT_NX = 32
#: Largest nx the rtol refinement goes to.
MAX_NX = 512
#: The lowest order the two-level estimate assumes: error ≤ |fine − coarse| / (2^ORDER − 1).
#: Measured orders on the curved mesh are 2 to 3 before the finest levels, but the
#: paper case (c = 0.2, H_c = 0.15) showed 1.2 between nx = 32 and 64 and the double
#: well ~1 between 64 and 128 (at 1e-5): with ORDER = 1 the estimate stays an upper
#: bound there and is 3–7 times pessimistic where the order is 2–3.
ORDER = 1
ASSUMES = ("the error of the fine level is at most |fine − coarse|, coarse = (nx/2, ny/2, "
           "n_steps/2): convergence of order >= 1 in the mesh and the BDF2 step and both "
           "levels in the asymptotic range (nx >= 16); measured orders 1 to 3, so the "
           "estimate is 1–7 times the true error.  mean_time is relative and adds the "
           "rounding estimate; reliability is the largest absolute difference of R over "
           "the coarse time grid (requested times read beyond it are not covered).")


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


def _level(where, system, parts, H_c, nx, ny, degree, kind, value) -> dict[str, Any]:
    """τ on every part at one resolution (refusing an unresolvable τ)."""
    solved = [_solve_part(system, part, H_c, nx, ny, degree, kind, value) for part in parts]
    solved = [p for p in solved if p["weight"] > 0]
    if not solved:
        raise ValueError(f"{where}: the start density has no mass inside the safe set "
                         f"H < {H_c:g}")
    total = sum(p["weight"] for p in solved)
    for p in solved:
        p["weight"] /= total
        if p["error"] > RESOLVABLE or not (0 < p["mean"] < math.inf):
            raise _unresolvable(where, system, H_c, kind, value, p)
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
            grids.append(_survival(p["L"], p["M"], q["mean"],
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


def _solve_part(system, part, H_c, nx, ny, degree, kind, value) -> dict[str, Any]:
    """τ on one part of the safe set, the start's functional, and the estimated
    relative rounding error of τ."""
    mesh, box, absorbing = safe_set_mesh(system, part, H_c, nx, ny, degree)
    basis = skfem.CellBasis(mesh, element_for(mesh, degree), intorder=quadrature_order(degree))
    L, M = assemble(box, basis, only_walls=True)
    unit = np.asarray(M.sum(axis=0)).ravel()
    fixed = basis.get_dofs(np.flatnonzero(absorbing)).all()
    free = np.setdiff1d(np.arange(basis.N), fixed)
    L, M = L[free][:, free], M[free][:, free]
    lu = spla.splu((-L.T).tocsc(), permc_spec="MMD_AT_PLUS_A")
    tau = np.zeros(basis.N)
    with np.errstate(all="ignore"):
        tau[free] = lu.solve(unit[free])
        # rounding: the slowest mode v of −L_ff (one inverse iteration from 1) is
        # where the mean time lives; a perturbation eps |L| of the matrix moves its
        # rate by about eps 1ᵀ|L||v| / unitᵀ|v|, i.e. τ by that times τ.
        v = np.abs(lu.solve(M @ np.ones(free.size), trans="T"))
        tau_max = float(np.max(tau[free]))
        error = _EPS * float(np.ones(free.size) @ (abs(L) @ v)) / float(unit[free] @ v) \
            * abs(tau_max)
        # normwise backward error of the solve (a breakdown, not conditioning)
        residual = float(np.linalg.norm(unit[free] + L.T @ tau[free], np.inf)
                         / (spla.norm(L, np.inf) * np.linalg.norm(tau[free], np.inf)
                            + np.linalg.norm(unit[free], np.inf)))
    if not (np.all(np.isfinite(tau)) and math.isfinite(error)):
        error = math.inf
    elif np.min(tau[free]) < -NEGATIVE * tau_max or residual > 1e-8:
        error = max(error, 1.0)       # a negative mean time: a solver breakdown
    if kind == "point":
        probe = np.asarray(basis.probes(np.array([[value[0]], [value[1]]])).todense()).ravel()
        weights, weight = probe[free], 1.0
    else:
        p0 = _start_density(system, kind, value, basis.doflocs, H_c)[free]
        weight = float(unit[free] @ p0)
        weights = (M @ p0) / weight if weight > 0 else np.zeros(free.size)

    def at_start(v_free: np.ndarray, weights=weights) -> float:
        return float(weights @ v_free)

    return {"part": part, "mesh": mesh, "L": L, "M": M, "ndofs": int(basis.N),
            "free": int(free.size), "tau_h": FEMSolution(system, mesh, degree, tau, mass=1.0),
            "mean": at_start(tau[free]), "tau_max": tau_max, "error": error,
            "residual": residual, "weight": max(weight, 0.0), "at_start": at_start}


def _unresolvable(where, system, H_c, kind, value, part) -> InputError:
    """The one-line refusal of a mean time that double precision cannot resolve."""
    err, tau_max = part["error"], part["tau_max"]
    limit = RESOLVABLE / err * tau_max if math.isfinite(err) and err > 0 and tau_max > 0 \
        else math.nan
    est = ""
    try:
        from ..averaging.first_passage import log10_mean_time
        H0 = float(system.energy(*value)) if kind == "point" else None
        est = f"; averaging estimates τ ~ 10^{log10_mean_time(system, H_c, H0):.0f}"
    except Exception:  # averaging does not apply (e.g. two wells): no estimate
        pass
    bound = f"τ is beyond the ~{limit:.1g} this mesh resolves" if limit == limit else \
        "τ is beyond what this mesh resolves"
    return InputError(f"{where}: energy = {H_c:g} gives a mean first-passage time that "
                      f"double precision cannot resolve: rounding alone changes τ by an "
                      f"estimated {err:.2g} × τ ({bound}{est}); choose a lower energy",
                      where=where, name="energy")


class _TauField:
    """τ_h(x, y) on the solved parts (picklable: no closure)."""

    def __init__(self, system, H_c, parts) -> None:
        self.system, self.H_c, self.parts = system, H_c, parts

    def __call__(self, x, y) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        out = np.zeros(x.shape)
        inside = self.system.energy(x, y) < self.H_c
        covered = np.zeros(x.shape, dtype=bool)
        for tau_h, mesh, (lo, hi) in self.parts:
            sel = (x >= lo) & (x <= hi)
            covered |= sel
            out[sel] = _tau_at(tau_h, mesh, self.system, self.H_c, x[sel], y[sel])
        if np.any(inside & ~covered):
            spans = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for _, _, (lo, hi) in self.parts)
            raise ValueError(f"fem.first_passage: mean_time(x0, y0) is known on the part(s) "
                             f"of the safe set holding the start (x in {spans}); this point "
                             "lies in another one")
        return out


def _tau_at(tau_h: FEMSolution, mesh, system, H_c: float, x, y) -> np.ndarray:
    """τ_h(x, y): 0 outside the safe set; a point between the curved boundary and the
    mesh's straight edge (where τ is O(h²)) is read on the edge."""
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    inside = (system.energy(x, y) < H_c) & (x >= mesh.p[0].min()) & (x <= mesh.p[0].max())
    top = mesh.p[:, mesh.p[1] >= 0]
    order = np.lexsort((-top[1], top[0]))           # per x, the highest node first
    xs, first = np.unique(top[0][order], return_index=True)
    edge = np.interp(x, xs, top[1][order][first]) * (1.0 - 1e-9)
    yc = np.clip(y, -edge, edge)
    out = np.zeros(x.shape)
    if np.any(inside):
        out[inside] = tau_h.pdf_joint(x[inside], yc[inside])
    return out


def _start_density(system, kind, value, points, H_c) -> np.ndarray:
    """Nodal values of the start density (zero outside the safe set)."""
    x, y = points[0], points[1]
    if kind == "gaussian":
        (mx, my), (sx, sy) = value["mean"], value["std"]
        hx, hy = np.ptp(x) / 64, np.ptp(y) / 64
        p0 = (np.exp(-0.5 * ((x - mx) / max(sx, hx)) ** 2)
              * np.exp(-0.5 * ((y - my) / max(sy, hy)) ** 2))
    else:
        from . import stationary
        p0 = np.maximum(stationary(system).pdf_joint(x, y), 0.0)
    return np.where(system.energy(x, y) < H_c, p0, 0.0)


def _survival(L: sp.csr_matrix, M: sp.csr_matrix, scale: float, t_end: float,
              n_steps: int, at_start) -> tuple[np.ndarray, np.ndarray]:
    """R(t_k) on [0, t_end] from M g' = Lᵀ g, g(0) = 1 (BDF2).  The step is set by the
    mean time ``scale``: 5 scale / n_steps (n_steps/4 steps ten times smaller first,
    for the layer at the absorbing boundary), widened if t_end needs more than
    8 n_steps steps."""
    Lt = L.T.tocsc()
    h2 = max(5.0 * scale / n_steps, t_end / (8 * n_steps))
    h1, n1 = h2 / 10.0, n_steps // 4
    n2 = max(1, int(math.ceil((t_end - n1 * h1) / h2 - 1e-9)))
    g_prev, g = None, np.ones(L.shape[0])
    T, R = [0.0], [at_start(g)]
    for h, n in ((h1, n1), (h2, n2)):
        euler = spla.splu((M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A")
        bdf2 = spla.splu((1.5 * M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A")
        for k in range(n):
            if k == 0:                 # implicit Euler restarts each step size
                g_prev, g = g, euler.solve(M @ g)
            else:
                g_prev, g = g, bdf2.solve(M @ (2.0 * g - 0.5 * g_prev))
            T.append(T[-1] + h)
            R.append(at_start(g))
    return np.array(T), np.clip(np.array(R), 0.0, 1.0)
