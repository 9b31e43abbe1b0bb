"""Impact statistics from the density's trace on each wall, and the power balance.

At a wall x = x_w the paths that hit it per unit time with a velocity in (v, v + dv)
are the flux |v| p(x_w, v) dv over the half that moves into the wall (v > 0 at the
right wall, v < 0 at the left one).  So, with u = |v| the speed just before impact,

    rate        ν_w   = ∫ u p(x_w, ±u) du,
    mean speed  E[u]  = ∫ u² p(x_w, ±u) du / ν_w,   E[u²] = ∫ u³ p du / ν_w,
    energy removed per unit time  P_w = ½ (1 − r_w²) ∫ u³ p(x_w, ±u) du,
    impact-speed density          f_w(u) = u p(x_w, ±u) / ν_w.

Power balance (docs/impacts.md).  Itô's formula for H = y²/2 + G(x)
between impacts gives dH = (D1 + D2 x² − c y²) dt + y sqrt(2 D1 + 2 D2 x²) dW, and an
impact at wall w changes H by −½ (1 − r_w²) u².  In a stationary state E[dH] = 0:

    D1 + D2 E[x²]  =  c E[y²]  +  Σ_w P_w          (noise in = damping + impacts).

Its relative residual (:meth:`fpk_vibro.Solution.power_balance`, from the statistics
here) is a check on the discrete density that no single moment gives: it ties the
interior (E[x²], E[y²]) to the trace on the walls.

The integrals run on the breakpoints of the trace (the mesh nodes on the wall) with a
Gauss rule exact for the polynomial trace times u³.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import skfem

__all__ = ["impact_statistics", "impact_speed_pdf"]


def _wall_trace(sol, side: str) -> tuple[float, np.ndarray, np.ndarray]:
    """(x_w, speeds u_k, weights w_k) of the quadrature on the incoming half."""
    p = sol.mesh.p
    x_w = _edge(sol, side)
    on = np.abs(p[0] - x_w) <= 1e-9 * max(1.0, abs(x_w), sol.y_max)
    nodes = np.unique(np.abs(p[1][on]))
    bp = np.unique(np.concatenate([[0.0], nodes[nodes <= sol.y_max], [sol.y_max]]))
    qb = skfem.CellBasis(skfem.MeshLine(bp), skfem.ElementLineP0(),
                         intorder=2 * sol.degree + 6)
    u = np.asarray(qb.global_coordinates())[0].ravel()
    return x_w, u, qb.dx.ravel()


def _edge(sol, side: str) -> float:
    """The mesh's x at the wall (the wall's position to round-off of the mesh)."""
    return float(sol.mesh.p[0].max() if side == "right" else sol.mesh.p[0].min())


def _trace(sol, side: str, u: np.ndarray) -> np.ndarray:
    """p(x_w, v) at speeds u on the incoming half (v = u right, v = −u left); ≥ 0."""
    x_w = _edge(sol, side)
    v = u if side == "right" else -u
    return np.maximum(sol.pdf_joint(np.full_like(u, x_w), v), 0.0)


def impact_statistics(sol) -> dict[str, dict[str, float]]:
    """Per wall: ``rate``, ``mean_speed``, ``mean_square_speed``, ``energy_rate``.

    Computed from the (clipped non-negative) trace of p_h on each wall of the system;
    a truncated side without a wall has no impacts and no entry; a wall beyond the
    density's support, where the strip ends short of it (:mod:`fpk_vibro.fem.mesh`),
    has none either: rate and energy rate 0, mean speeds nan.
    """
    out: dict[str, dict[str, float]] = {}
    for side, wall in sol.system.walls:
        if abs(_edge(sol, side) - wall.position) > 1e-9 * max(1.0, sol._x1 - sol._x0):
            out[side] = {"rate": 0.0, "mean_speed": float("nan"),
                         "mean_square_speed": float("nan"), "energy_rate": 0.0}
            continue
        _, u, w = _wall_trace(sol, side)
        p = _trace(sol, side, u)
        m1, m2, m3 = (float(np.sum(w * u ** k * p)) for k in (1, 2, 3))
        out[side] = {"rate": m1, "mean_speed": m2 / m1 if m1 > 0 else float("nan"),
                     "mean_square_speed": m3 / m1 if m1 > 0 else float("nan"),
                     "energy_rate": float(np.sum(w * u * wall.loss(u) * p))}
    return out


def impact_speed_pdf(sol, wall: str, u: Any) -> np.ndarray:
    """f_w(u) = u p(x_w, ±u) / ν_w, the density of the speed just before impact."""
    sol.wall_named(wall)
    u = np.asarray(u, dtype=float)
    rate = impact_statistics(sol)[wall]["rate"]
    if rate == 0.0:
        from .._checks import invalid
        raise invalid("impact_speed_pdf", "wall", "a wall the density reaches", wall,
                      "it lies beyond the density's support (sol.info"
                      "['walls_beyond_support']): no impacts")
    flat = np.abs(u.ravel())
    f = flat * _trace(sol, wall, flat) / rate
    return np.where(u.ravel() >= 0, f, 0.0).reshape(u.shape)

