"""Impact statistics from the averaged density (docs/impacts.md).

An orbit of energy H > G(x_w) meets wall w once per quasi-period T(H) at the speed
u = sqrt(2 (H − G(x_w))).  With the stationary p(H):

    ν_w = ∫_{H > G(x_w)} p(H) / T(H) dH,   E[u^k] = ∫ p/T u^k dH / ν_w,
    f_w(u) = p(G(x_w) + u²/2) u / (T ν_w)   (H = G(x_w) + u²/2, dH = u du).

Where one orbit meets two walls the speed at the second is, strictly, that of the
energy left after the first impact; to first order in 1 − r (the order of averaging
itself) both walls see sqrt(2 (H − G(x_w))).
"""
from __future__ import annotations

import numpy as np

from ..orbits import orbit_nodes

__all__ = ["impact_statistics", "impact_speed_pdf"]

_T, _W = np.polynomial.legendre.leggauss(8)


def _top(sol) -> float:
    """An energy above which p(H) is negligible."""
    top = getattr(sol, "H_end", None)
    if top is None or not np.isfinite(top):
        m = sol.moments()["E_H"]
        top = 80.0 * max(m, 1e-12)
    return float(top)


def _rate_density(sol, H: np.ndarray) -> np.ndarray:
    """p(H)/T(H): the orbits of energy H that meet a wall, per unit time."""
    T = orbit_nodes(sol.system, H, getattr(sol, "n_theta", 48)).period
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(T > 0, sol.pdf_energy(H) / T, 0.0)


def impact_statistics(sol) -> dict[str, dict[str, float]]:
    """Per wall: ``rate``, ``mean_speed``, ``mean_square_speed``, ``energy_rate``."""
    out = {}
    for side, wall in sol.system.walls:
        Gw = float(sol.system.potential(wall.position))
        top = _top(sol)
        if top <= Gw:
            out[side] = {"rate": 0.0, "mean_speed": float("nan"),
                         "mean_square_speed": float("nan"), "energy_rate": 0.0}
            continue
        # in s = sqrt(H − G_w): p(H) ~ s near the wall energy, smooth in s
        edges = np.linspace(0.0, np.sqrt(top - Gw), 401)
        half = 0.5 * np.diff(edges)[:, None]
        s = ((0.5 * (edges[1:] + edges[:-1]))[:, None] + half * _T).ravel()
        w = (half * _W).ravel() * 2.0 * s             # dH = 2 s ds
        f = _rate_density(sol, Gw + s * s) * w
        u = np.sqrt(2.0) * s
        nu = float(f.sum())
        m1, m2 = float(f @ u), float(f @ (u * u))
        out[side] = {"rate": nu, "mean_speed": m1 / nu if nu > 0 else float("nan"),
                     "mean_square_speed": m2 / nu if nu > 0 else float("nan"),
                     "energy_rate": float(f @ wall.loss(u))}
    return out


def impact_speed_pdf(sol, wall: str, u) -> np.ndarray:
    """f_w(u), the density of the speed just before an impact on ``wall``; zero on a
    wall the density never reaches (rate 0), as FE and Monte Carlo give."""
    w = sol.wall_named(wall)
    u = np.asarray(u, dtype=float)
    nu = impact_statistics(sol)[wall]["rate"]
    if not nu > 0.0:
        return np.zeros_like(u)
    Gw = float(sol.system.potential(w.position))
    a = np.abs(u)
    f = _rate_density(sol, Gw + 0.5 * a * a) * a / nu
    return np.where(u >= 0, f, 0.0)
