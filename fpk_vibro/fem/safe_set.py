"""The safe set {H < H_c} on the strip: its parts and their fitted meshes.

The safe set S = {H < H_c} on the strip is |y| < Y(x) = sqrt(2 (H_c − G(x))) over
the x where G(x) < H_c: one or more intervals (:func:`safe_set_components`; two for
a double well below its hump, one next to each wall for a softening spring whose
walls lie beyond its humps), each between the walls it reaches and turning points
G(A) = H_c (a turning-point end is pulled just inside).  Each part is meshed by
quadrilaterals fitted to it (:func:`safe_set_mesh`): nodes (x(s_i), η_j Y(x(s_i)))
for uniform grids in s ∈ [0, 1] and η ∈ [−1, 1], x(s) graded toward turning points
(:data:`TURNING_POWER`) and toward walls with r < 1 (:data:`WALL_POWER`), so that
the absorbing boundary H = H_c is a mesh boundary and y = 0 a mesh line; for
degree 2 the mesh is isoparametric (edge and centre nodes on the same map: the
curved boundary is followed).  Used by :func:`fpk_vibro.fem.first_passage`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import skfem
from scipy.special import betainc, betaincinv
from skfem.mapping import MappingIsoparametric

from ..model import VibroImpactSystem, Wall

__all__ = ["safe_set_components", "safe_set_mesh", "END_FRACTION", "TURNING_POWER",
           "WALL_POWER"]


#: A side without a reached wall ends where Y(x) is this fraction of Y(0)-ish: just
#: inside the turning point (the cells there stay non-degenerate).
END_FRACTION = 1e-3
#: x_A − x ∝ s^TURNING_POWER toward a turning point x_A: Y ∝ sqrt(x_A − x) is then
#: linear in s there.
TURNING_POWER = 2.0
#: x_w − x ∝ s^WALL_POWER toward a wall with r < 1.  There τ is discontinuous at the
#: corner where the wall meets H = H_c on its incoming side (a path arriving at
#: v → Y(x_w) leaves with −r v, inside the set: τ(x_w, v) → τ(x_w, −r Y) > 0 while
#: τ = 0 on H = H_c), and on the old uniform x grid τ converged at order ≤ 1, its
#: two-level estimate 25 times short (walls −0.1, r = 0.05 and 0.4, r = 0.36: 0.35 %
#: off at nx = 32, estimate 1.4e-4).  Power 3 against 2 and 4 on random systems:
#: docs/fem_first_passage.md, §Inelastic walls.  An end with r = 1 is not graded.
WALL_POWER = 3.0

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


def _powers(part) -> tuple[float, float]:
    """The grading power of each end of a part (x − x_end ∝ s^power near it): a
    turning point :data:`TURNING_POWER`, a wall with r < 1 :data:`WALL_POWER`, an
    elastic wall 1."""
    return tuple(TURNING_POWER if w is None else WALL_POWER if not w.elastic else 1.0
                 for w in part[2:4])


def _u_of_s(powers: tuple[float, float], s: np.ndarray) -> np.ndarray:
    """The x-grading on [0, 1]: the regularised incomplete beta function
    I_s(p_left, p_right), ∝ s^p_left at 0 and 1 − ∝ (1 − s)^p_right at 1 (s for
    (1, 1), 3 s² − 2 s³ for (2, 2))."""
    return betainc(powers[0], powers[1], np.clip(s, 0.0, 1.0))


def _s_of_u(powers: tuple[float, float], u: np.ndarray) -> np.ndarray:
    return betaincinv(powers[0], powers[1], np.clip(u, 0.0, 1.0))


class _SafeSetMap:
    """(s, η) ∈ [0, 1] × [−1, 1] ↦ (x(s), η Y(x(s))) and back: the fitted mesh is the
    image of a uniform nx × ny grid, so a point's cell is found in (s, η)."""

    def __init__(self, system, H_c, ends, powers, nx, ny, cells_param):
        self.system, self.H_c, self.ends, self.powers = system, H_c, ends, powers
        self.nx, self.ny = nx, ny
        i = np.rint(cells_param[0].min(axis=0) * nx).astype(int)
        j = np.rint((cells_param[1].min(axis=0) + 1.0) * 0.5 * ny).astype(int)
        self.table = np.full((nx, ny), -1, dtype=np.int64)
        self.table[i, j] = np.arange(i.size)

    def x(self, s):
        a, b = self.ends
        return np.where(s >= 1.0, b, np.where(s <= 0.0, a, a + (b - a) * _u_of_s(self.powers, s)))

    def Y(self, x):
        return np.sqrt(2.0 * np.maximum(self.H_c - self.system.potential(x), 0.0))

    def find(self, x, y):
        a, b = self.ends
        s = _s_of_u(self.powers, (np.asarray(x, float) - a) / (b - a))
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

    def _mapping(self):
        if not hasattr(self, "_cached_mapping"):
            self._cached_mapping = _ThinCellMapping(self, self.elem(), self.bndelem)
        return self._cached_mapping


class _ThinCellMapping(MappingIsoparametric):
    """skfem's isoparametric mapping, whose point location (Newton on the reference
    cell, to a step of 1e-12) falls back to a step of 1e-6 where rounding stalls it:
    next to a graded wall a cell is w = 1e-7 of the part wide at nx = 256, and x ≈ x_w
    is known to eps |x_w| / w ~ 1e-9 of the cell (an error of 1e-6 of a cell
    moves a point by 1e-13 there)."""

    def invF(self, x, tind=None, newton_max_iters=50, newton_tol=1e-12):
        try:
            return super().invF(x, tind, newton_max_iters, newton_tol)
        except Exception:   # skfem raises a bare Exception; one at 1e-6 is real
            return super().invF(x, tind, newton_max_iters, 1e-6)


def safe_set_mesh(system: VibroImpactSystem, part: tuple, H_c: float, nx: int, ny: int,
                  degree: int = 1) -> tuple[skfem.MeshQuad1, _Box, np.ndarray]:
    """(mesh of one part of {H < H_c} fitted to its boundary, the system with only the
    walls the part reaches, mask of the boundary facets that absorb).

    Nodes (x(s_i), η_j Y(x(s_i))) for uniform s_i ∈ [0, 1], η_j ∈ [−1, 1], with x(s)
    graded quadratically toward turning points and cubically toward walls with
    r < 1 (:func:`_u_of_s`, :data:`WALL_POWER`); for degree 2 the mesh is
    isoparametric (:class:`_CurvedQuad`), its cells next to a graded wall straight
    in x (a curved one's Jacobian vanishes or turns at the wall).  Why: on a uniform x
    grid Y ∝ sqrt(x_A − x) is not resolved near a turning point x_A and the straight
    edges cut the curved boundary, and τ converged erratically at second order at best
    (paper system c = 0.2, H_c = 0.15, Q2: 38.30, 38.22, 38.12, 38.086 for nx = 12 … 96
    against 38.0765); graded and curved: 38.094, 38.0817, 38.0787, 38.0774 for nx = 8 …
    64 (docs/fem_first_passage.md).
    """
    x_lo, x_hi, left, right = part
    half = 0.5 * (x_hi - x_lo)
    ends = (x_lo if left is not None else x_lo + END_FRACTION * half,
            x_hi if right is not None else x_hi - END_FRACTION * half)
    box = _Box(system.a, system.b, system.c, system.D1, system.D2, left, right)
    param = skfem.MeshQuad1.init_tensor(np.linspace(0.0, 1.0, nx + 1),
                                        np.linspace(-1.0, 1.0, ny + 1))
    powers = _powers(part)
    safe_map = _SafeSetMap(system, H_c, ends, powers, nx, ny, param.p[:, param.t])
    if degree >= 2:
        param = skfem.MeshQuad2.from_mesh(param)
        P = param.doflocs
    else:
        P = param.p
    X = safe_map.x(P[0])
    for k, w in enumerate((left, right)):
        if w is not None and powers[k] > 1.0:     # the first cell at a graded wall
            mid = 0.5 / nx if k == 0 else 1.0 - 0.5 / nx
            edges = safe_map.x(np.array([mid - 0.5 / nx, mid + 0.5 / nx]))
            X[np.abs(P[0] - mid) < 0.25 / nx] = edges.mean()
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
