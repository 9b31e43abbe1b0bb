"""The energy one impact dissipates, from the impact-speed density and the wall's law.

An impact at speed u on a wall with restitution r(u) removes
e = g(u) = (1 − r(u)²) u²/2 (docs/impacts.md).  Among impacts on that wall u has the
density p_u (``Solution.impact_speed_pdf``), so e has the density

    p_e(e) = Σ_{u : g(u) = e} p_u(u) / |g'(u)|,

a sum over the branches of g (one for a constant r < 1; a law r(u) may fold g).
:func:`energy_density` evaluates it with g piecewise linear on a fine speed grid, each
grid cell's probability spread evenly over the energies the cell maps to: exact for
the piecewise-linear g, so the total mass is the mass of p_u on the grid.  An elastic
wall (r ≡ 1) dissipates nothing: its e is the point mass at 0, and the density is
zero at every e > 0 (:func:`energy_density` returns zeros there).

Examples
--------
>>> import numpy as np
>>> from fpk_vibro import Wall
>>> w = Wall(0.5, r=0.8)
>>> u = np.linspace(0, 8, 2001)
>>> pu = lambda s: s * np.exp(-s * s / 2)              # a Rayleigh impact speed
>>> e = np.array([0.1, 0.5])
>>> k = 0.5 * (1 - 0.8 ** 2)                           # e = k u²: exponential law
>>> np.round(energy_density(w, pu, e, u_max=8.0) * k / np.exp(-e / (2 * k)) * 2, 3)
array([1., 1.])
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from .wall import Wall

__all__ = ["energy_density", "mean_energy", "SPEED_POINTS"]

#: Speed cells of the piecewise-linear g (relative error of p_e ~ (u_max/SPEED_POINTS)²).
SPEED_POINTS = 8193


def _cells(wall: Wall, speed_pdf: Callable[[np.ndarray], np.ndarray], u_max: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(g at the cell ends (lo, hi), probability of each cell) on [0, u_max]."""
    u = np.linspace(0.0, float(u_max), SPEED_POINTS)
    g = wall.loss(u)
    p = np.maximum(np.asarray(speed_pdf(u), dtype=float), 0.0)
    mass = 0.5 * (p[1:] + p[:-1]) * np.diff(u)
    return np.minimum(g[1:], g[:-1]), np.maximum(g[1:], g[:-1]), mass


def energy_density(wall: Wall, speed_pdf: Callable[[np.ndarray], np.ndarray],
                   e: np.ndarray, *, u_max: float) -> np.ndarray:
    """p_e at the energies ``e`` (module docstring); ``speed_pdf`` the density of the
    impact speed on ``wall`` (negligible beyond ``u_max``)."""
    e = np.asarray(e, dtype=float)
    out = np.zeros(e.size)
    if wall.elastic:
        return out.reshape(e.shape)
    lo, hi, mass = _cells(wall, speed_pdf, u_max)
    width = hi - lo
    flat = width <= 1e-300
    ef = e.ravel()
    for start in range(0, ef.size, 256):          # chunks of energies x all cells
        block = ef[start:start + 256, None]
        inside = (block >= lo) & (block < hi) & ~flat
        out[start:start + 256] = np.sum(np.where(inside, mass / np.where(flat, 1.0, width),
                                                 0.0), axis=1)
    return out.reshape(e.shape)


def mean_energy(wall: Wall, speed_pdf: Callable[[np.ndarray], np.ndarray], *,
                u_max: float) -> float:
    """E[e] = ∫ g(u) p_u(u) du over impacts on ``wall`` (0 for an elastic wall)."""
    if wall.elastic:
        return 0.0
    lo, hi, mass = _cells(wall, speed_pdf, u_max)
    return float(np.sum(0.5 * (lo + hi) * mass) / max(np.sum(mass), 1e-300))
