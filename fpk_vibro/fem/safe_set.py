"""The safe set {H < H_c} on the strip: its parts and their fitted meshes.

The safe set S = {H < H_c} on the strip is |y| < Y(x) = sqrt(2 (H_c − G(x))) over
the x where G(x) < H_c: one or more intervals (:func:`safe_set_components`; two for
a double well below its hump, one next to each wall for a softening spring whose
walls lie beyond its humps), each between the walls it reaches and turning points
G(A) = H_c (a turning-point end is pulled just inside).  Each part is meshed by
quadrilaterals fitted to it (:func:`safe_set_mesh`): nodes (x(s_i), η_j Y(x(s_i)))
for uniform grids in s ∈ [0, 1] and η ∈ [−1, 1], x(s) graded quadratically toward
turning points, so that the absorbing boundary H = H_c is a mesh boundary and y = 0
a mesh line; for degree 2 the mesh is isoparametric (edge and centre nodes on the
same map: the curved boundary is followed).  Used by
:func:`fpk_vibro.fem.first_passage`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import skfem

from ..model import VibroImpactSystem, Wall

__all__ = ["safe_set_components", "safe_set_mesh", "END_FRACTION"]


#: A side without a reached wall ends where Y(x) is this fraction of Y(0)-ish: just
#: inside the turning point (the cells there stay non-degenerate).
END_FRACTION = 1e-3

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
