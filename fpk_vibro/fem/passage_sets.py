"""τ and R out of a displacement or impact-speed safe set (:mod:`fpk_vibro.safe_sets`).

The domain is a rectangle of the strip, x_a < x < x_b, |y| < Y (Y the stationary
density's truncation, :func:`fpk_vibro.fem.mesh.domain`, widened to hold the start),
meshed by a tensor grid (y = 0 a node line, x graded as x_w − x ∝ s³ toward an
inelastic wall, :data:`~fpk_vibro.fem.safe_set.WALL_POWER`).  On it the interior of the
FE generator is assembled (:func:`fpk_vibro.fem.generator.assemble` with no wall) and
each end gets:

- **a cut** x = x_hi of ``displacement`` (x_lo likewise, mirrored): paths leave where
  the drift carries them out, ẋ = y > 0.  x has no diffusion, so the backward
  equation y ∂τ/∂x + … = −1 is first order in x: it takes the condition τ = 0 on the
  outflow half y ≥ 0 of the cut only (y = 0 included: from (x_hi, 0) the integrated
  noise crosses at once), and none on y < 0, where paths enter the set and τ is
  whatever the interior gives.  The forward form keeps the outflow term
  −∫_{y>0} y p q of the cut and re-injects nothing (:data:`WEAK_CUT`): its adjoint
  imposes τ = 0 there weakly, the upwind condition; x is graded toward the cut
  (:data:`CUT_POWER`), where τ is singular at (x_hi, 0);
- **a wall** (x_lo or x_hi at or beyond the wall, or ``impact_speed``): the impact
  coupling of :mod:`fpk_vibro.fem.impact` with the wall's law, L −= (P − P_r)ᵀ W P;
  for ``impact_speed=u_c`` the rows of P_r at incoming speeds u > u_c are dropped, so
  the coupling absorbs those impacts (their flux leaves, nothing re-enters; in the
  backward equation τ(x_w, v) = 0 for |v| > u_c, weakly, as the re-injection imposes
  τ(x_w, v) = τ(x_w, −φ(v)) for |v| ≤ u_c), with ±u_c a breakpoint of the wall's
  quadrature and a y node line;
- **the elastic cut** before a wall beyond the density's support: as a wall, r = 1.

τ, R and the rounding estimate are then those of the energy set
(:mod:`fpk_vibro.fem.passage_parts`): τ = (−L_ffᵀ)⁻¹ unit_f on the free DOFs f.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse as sp
import skfem

from .._checks import InputError
from ..safe_sets import SafeSet
from .generator import assemble_tensor, element_for, tensor_index
from .impact import wall_matrix_1d, wall_parts_1d
from .mesh import Domain, StripEnd, domain, wall_restitutions
from .passage_parts import mean_time_solve
from .safe_set import WALL_POWER, _Box, _u_of_s
from .solution import FEMSolution

__all__ = ["solve_set", "set_mesh", "SetTauField", "unresolvable_set"]

#: The cut absorbs weakly (its outflow term −∫ |y| p q, adjoint: τ = 0 upwind) rather
#: than by fixing the DOFs with y ≥ 0 to zero.  Paper system, (−0.2, 0.4), Q2, τ(0, 0)
#: at nx = 16, 32, 64, 128 (ny = 2 nx): weak and graded 6.77990, 6.76321, 6.76127,
#: 6.76097; fixed and graded 6.77374, 6.76137, 6.76077, 6.76084; fixed on a uniform x
#: grid 6.7992, 6.7904, 6.7798, 6.7724 (order < 1).
WEAK_CUT = True
#: x_cut − x ∝ s^CUT_POWER toward a cut: τ is singular at its corner (x_cut, 0).
CUT_POWER = 3.0


def _ends(system, safe: SafeSet) -> tuple[float, float, Any, Any, float]:
    """(x_a, x_b, left end, right end, Y): an end is None for a cut, else the StripEnd
    that couples there (the wall's law, or r = 1 at the cut before a wall beyond the
    support)."""
    dom = domain(system)
    rl, rr = wall_restitutions(system)
    ends = []
    for k, (bound, edge, wall, r, side) in enumerate((
            (safe.x_lo, dom.x0, system.left, rl, -1), (safe.x_hi, dom.x1, system.right, rr, +1))):
        if math.isfinite(bound) and (side * (edge - bound) > 0):
            ends.append((bound, None))
        else:
            real = wall is not None and abs(edge - wall.position) <= 1e-12 * max(1.0, abs(edge))
            # (a wall beyond the support: its elastic cut, side 2·side marks "no wall")
            ends.append((edge, StripEnd(edge, r, side) if real else StripEnd(edge, 1.0, 2 * side)))
    (xa, left), (xb, right) = ends
    return xa, xb, left, right, dom.y_max


def set_mesh(system, safe: SafeSet, nx: int, ny: int, y_start: float = 0.0):
    """(x-nodes, y-nodes, left end, right end, Y) of the rectangle of module docstring."""
    xa, xb, left, right, Y = _ends(system, safe)
    Y = max(Y, 1.25 * abs(y_start))
    powers = tuple(CUT_POWER if e is None else WALL_POWER if not e.elastic else 1.0
                   for e in (left, right))
    xs = xa + (xb - xa) * _u_of_s(powers, np.linspace(0.0, 1.0, nx + 1))
    xs[0], xs[-1] = xa, xb
    half = max(1, ny // 2)
    u_c = safe.speed if safe.kind == "impact_speed" else None
    if u_c is not None and u_c < Y:
        n_in = min(max(1, round(half * u_c / Y)), half - 1) if half > 1 else 1
        pos = np.concatenate([np.linspace(0.0, u_c, n_in + 1),
                              np.linspace(u_c, Y, half - n_in + 1)[1:]])
    else:
        pos = np.linspace(0.0, Y, half + 1)
    return xs, np.concatenate([-pos[:0:-1], pos]), left, right, Y


def _generator(system, xs, ys, degree, left, right, Y, speed_limit):
    """(L, M, unit, x-basis, y-basis) in Kronecker order: the interior of
    :func:`~fpk_vibro.fem.generator.assemble_tensor` and the ends' couplings."""
    box = _Box(system.a, system.b, system.c, system.D1, system.D2, None, None)
    elastic = (StripEnd(xs[0], 1.0, -1), StripEnd(xs[-1], 1.0, 1))
    op = assemble_tensor(box, xs, ys, degree, Domain(xs[0], xs[-1], Y, elastic))
    xb, yb = op.xbasis, op.ybasis
    q = 2 * degree + 1
    xd = xb.doflocs[0]
    L = op.L
    for k, (end, side) in enumerate(((left, -1), (right, 1))):
        iw = int(np.argmin(np.abs(xd - xs[0 if side < 0 else -1])))
        E = sp.csr_matrix(([1.0], ([iw], [iw])), shape=(xb.N, xb.N))
        L = L + sp.kron(E, wall_matrix_1d(yb, elastic[k], Y, q))   # undo the elastic end
        if end is None:
            if not WEAK_CUT:
                continue
            end = StripEnd(elastic[k].x, 0.0, side)       # absorbs its whole outflow
            P, _, w = wall_parts_1d(yb, end, Y, q)
            C = P.T @ sp.diags(w) @ P
        else:
            real = abs(end.side) == 1
            end = StripEnd(end.x, end.r, side)
            P, Pr, w = wall_parts_1d(yb, end, Y, q, speed_limit if real else None)
            if speed_limit is not None and real:
                v = P @ yb.doflocs[0]                  # the quadrature points' velocities
                Pr = sp.diags((np.abs(v) <= speed_limit * (1 + 1e-12)).astype(float)) @ Pr
            C = (P - Pr).T @ sp.diags(w) @ P
        L = L - sp.kron(E, C)
    return sp.csr_matrix(L), op.M, op.unit, xb, yb


def solve_set(system, safe: SafeSet, nx: int, ny: int, degree: int, kind: str,
              value: Any) -> dict[str, Any]:
    """τ on the set's rectangle (the dict of :func:`fpk_vibro.fem.passage_parts.solve_part`)."""
    y0 = value[1] if kind == "point" else 0.0
    xs, ys, left, right, Y = set_mesh(system, safe, nx, ny, y0)
    speed = safe.speed if safe.kind == "impact_speed" else None
    L, M, unit, xb, yb = _generator(system, xs, ys, degree, left, right, Y, speed)
    x, y = (a.ravel() for a in np.meshgrid(xb.doflocs[0], yb.doflocs[0], indexing="ij"))
    tol = 1e-12 * max(1.0, float(np.ptp(x)))
    fixed = np.zeros(x.size, dtype=bool)
    if left is None and not WEAK_CUT:
        fixed |= (np.abs(x - xs[0]) <= tol) & (y <= 0)
    if right is None and not WEAK_CUT:
        fixed |= (np.abs(x - xs[-1]) <= tol) & (y >= 0)
    free = np.flatnonzero(~fixed)
    L, M = L[free][:, free], M[free][:, free]
    tau = np.zeros(x.size)
    tau[free], error, tau_max, residual = mean_time_solve(L, M, unit[free])
    mesh = skfem.MeshQuad1.init_tensor(xs, ys)
    if degree > 2:
        tau_h = FEMSolution(system, mesh, degree, tau, mass=1.0, tensor=(xs, ys))
    else:
        k = tensor_index(xb, yb, skfem.CellBasis(mesh, element_for(mesh, degree), intorder=1))
        tau_h = FEMSolution(system, mesh, degree, tau[k], mass=1.0, tensor=(xs, ys))
    if kind == "point":
        pt = np.array([[value[0]], [value[1]]])
        weights = np.kron(xb.probes(pt[:1]).toarray().ravel(),
                          yb.probes(pt[1:]).toarray().ravel())[free]
        weight = 1.0
    else:
        p0 = _start_density(system, safe, kind, value, np.vstack([x, y]))[free]
        weight = float(unit[free] @ p0)
        weights = (M @ p0) / weight if weight > 0 else np.zeros(free.size)

    def at_start(v_free: np.ndarray, weights=weights) -> float:
        return float(weights @ v_free)

    return {"part": (float(xs[0]), float(xs[-1]), None, None), "mesh": mesh, "L": L,
            "M": M, "ndofs": int(x.size), "free": int(free.size), "tau_h": tau_h,
            "mean": at_start(tau[free]), "tau_max": tau_max, "error": error,
            "residual": residual, "weight": max(weight, 0.0), "at_start": at_start}


def _start_density(system, safe, kind, value, points) -> np.ndarray:
    """Nodal values of the start density (zero outside the safe set)."""
    x, y = points[0], points[1]
    if kind == "gaussian":
        (mx, my), (sx, sy) = value["mean"], value["std"]
        hx, hy = np.ptp(x) / 64, np.ptp(y) / 64
        p0 = (np.exp(-0.5 * ((x - mx) / max(sx, hx)) ** 2)
              * np.exp(-0.5 * ((y - my) / max(sy, hy)) ** 2))
    else:
        from .stationary import stationary
        p0 = np.maximum(stationary(system).pdf_joint(x, y), 0.0)
    return np.where(safe.contains(system, x, y), p0, 0.0)


class SetTauField:
    """τ_h(x, y) on the rectangle (0 outside the safe set; picklable)."""

    def __init__(self, system, safe: SafeSet, tau_h: FEMSolution) -> None:
        self.system, self.safe, self.tau_h = system, safe, tau_h

    def __call__(self, x, y) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        Y = self.tau_h.y_max
        inside = self.safe.contains(self.system, x, y) & (x >= self.tau_h._x0) \
            & (x <= self.tau_h._x1)
        out = np.zeros(x.shape)
        if np.any(inside):
            out[inside] = self.tau_h.pdf_joint(x[inside], np.clip(y[inside], -Y, Y))
        return out


def unresolvable_set(where: str, safe: SafeSet, part: dict) -> InputError:
    """The one-line refusal of a mean time double precision cannot resolve."""
    return InputError(f"{where}: the mean time to leave {safe.describe()} is beyond what "
                      f"double precision resolves on this mesh: rounding alone changes τ "
                      f"by an estimated {part['error']:.2g} × τ (τ up to "
                      f"{part['tau_max']:.3g}); choose a tighter safe set",
                      where=where, name=safe.kind)

