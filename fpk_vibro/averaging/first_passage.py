"""Mean first-passage time and reliability of the averaged energy (docs/impacts.md).

The averaged energy is the diffusion dH = m(H) dt + σ(H) dW on (H_min, ∞), reflected
at the floor H_min of the potential.  Its mean exit time through H_c solves
Pontryagin's equation m τ' + ½ σ² τ'' = −1 with τ(H_c) = 0 and τ' bounded at H_min:

    τ(H0) = ∫_{H0}^{H_c} 2 F(u) / (σ²(u) p_s(u)) du,    F(u) = ∫_{H_min}^u p_s,

p_s the averaged stationary density (:func:`fpk_vibro.averaging.stationary`).  The
reliability R(t) comes from the conservative finite-volume generator of
:mod:`fpk_vibro.averaging.transient` on (H_min, H_c) with the top face absorbing
(p = 0 beyond it), by its eigen-decomposition.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from scipy import integrate, linalg

from .._checks import check_int
from ..first_passage import FirstPassage, check_energy, parse_start
from ..model import VibroImpactSystem, check_system
from ..orbits import energy_floor, orbit_nodes
from .coefficients import coefficients
from .stationary import stationary
from .transient import averaged_operator, energy_faces

__all__ = ["first_passage"]


def first_passage(system: VibroImpactSystem, *, energy: float, start: Any = (0.0, 0.0),
                  times: Sequence[float] | None = None, n_grid: int = 4000,
                  n_cells: int = 400) -> FirstPassage:
    """τ(H0) and R(t | start) out of {H < energy} under stochastic averaging.

    Parameters
    ----------
    system : VibroImpactSystem
    energy : float
        The critical energy H_c.
    start : (x0, y0), dict or "stationary"
        As in :func:`fpk_vibro.fem.first_passage`; a point enters through its
        energy H(x0, y0) only (averaging forgets the phase).
    times : sequence of float, optional
        R(t) is tabulated up to the largest of these and 5 τ.
    n_grid : int
        Quadrature nodes of the τ integral (quadratically graded at the floor).
    n_cells : int
        Finite-volume cells of the reliability.

    Returns
    -------
    FirstPassage
        ``mean_time(x0, y0)`` = τ(H(x0, y0)).
    """
    where = "averaging.first_passage"
    check_system(where, system)
    H_c = check_energy(where, system, energy)
    kind, value = parse_start(where, system, start, H_c)
    n_grid = check_int("n_grid", n_grid, 16, 10 ** 7, where=where)
    n_cells = check_int("n_cells", n_cells, 16, 20000, where=where)
    sol = stationary(system)
    floor = energy_floor(system)
    u = floor + (H_c - floor) * np.linspace(0.0, 1.0, n_grid + 1) ** 2
    p = sol.pdf_energy(u)
    F = integrate.cumulative_trapezoid(p, u, initial=0.0)
    _, _, s2 = coefficients(system, u[1:])
    g = np.empty_like(u)
    g[1:] = 2.0 * F[1:] / (s2 * p[1:])
    g[0] = 2.0 * g[1] - g[2]                   # the finite limit at the floor
    G = integrate.cumulative_trapezoid(g, u, initial=0.0)
    tau_of_H = G[-1] - G                        # τ(u) = ∫_u^{H_c} g

    def tau(H):
        return np.where(H < H_c, np.interp(H, u, tau_of_H), 0.0)

    faces = energy_faces(system, H_c, n_cells)
    A = averaged_operator(system, faces, sol).toarray()
    c, h = 0.5 * (faces[1:] + faces[:-1]), np.diff(faces)
    # the top face absorbs: flux ½ σ² p_s(H_c)/p_s(c_N) p_N / (H_c − c_N)
    _, _, s2c = coefficients(system, np.array([H_c]))
    Tf, Tc = (orbit_nodes(system, np.array([x])).period[0] for x in (H_c, c[-1]))
    ratio = Tf / Tc * np.exp(sol.phi(np.array([c[-1]]))[0] - sol.phi(np.array([H_c]))[0])
    A[-1, -1] -= 0.5 * s2c[0] * ratio / (H_c - c[-1]) / h[-1]
    q0 = _start_masses(system, kind, value, sol, faces, H_c) / h       # cell densities
    mean = float(_mean_from(kind, value, system, tau, sol, H_c))
    t_end = max(5.0 * mean, max(times) if times is not None and len(times) else 0.0)
    T = np.linspace(0.0, t_end, 801)
    lam, V = linalg.eig(A)
    coef = linalg.solve(V, q0)
    R = np.real((h @ V) * coef @ np.exp(np.outer(lam, T)))
    info = {"n_grid": n_grid, "n_cells": n_cells, "tau_fv": float(h @ linalg.solve(-A, q0))}
    return FirstPassage("averaging", system, H_c, (kind, value), mean, 0.0, T,
                        np.clip(R, 0.0, 1.0), None, info,
                        _mean_at=lambda x, y: tau(system.energy(x, y)))


def _mean_from(kind, value, system, tau, sol, H_c) -> float:
    if kind == "point":
        return tau(float(system.energy(*value)))
    if kind == "stationary":
        H = np.linspace(energy_floor(system), H_c, 20001)
        w = sol.pdf_energy(H)
        return float(np.trapezoid(w * tau(H), H) / np.trapezoid(w, H))
    x, y, w = _gauss_hermite(value)
    inside = system.energy(x, y) < H_c
    return float(np.sum(w[inside] * tau(system.energy(x[inside], y[inside])))
                 / np.sum(w[inside]))


def _gauss_hermite(value, n: int = 48):
    """Nodes and weights of the Gaussian start (a zero std is a point)."""
    (mx, my), (sx, sy) = value["mean"], value["std"]
    t, w = np.polynomial.hermite_e.hermegauss(n)
    w = w / w.sum()
    X, Y = np.meshgrid(mx + sx * t, my + sy * t, indexing="ij")
    return X.ravel(), Y.ravel(), np.outer(w, w).ravel()


def _start_masses(system, kind, value, sol, faces, H_c) -> np.ndarray:
    """P(H ∈ cell) of the start, conditioned on the safe set."""
    if kind == "point":
        H0 = float(system.energy(*value))
        q = np.zeros(faces.size - 1)
        q[min(max(np.searchsorted(faces, H0) - 1, 0), q.size - 1)] = 1.0
        return q
    if kind == "stationary":
        H = np.linspace(faces[0], faces[-1], 40001)
        cdf = integrate.cumulative_trapezoid(sol.pdf_energy(H), H, initial=0.0)
        q = np.diff(np.interp(faces, H, cdf))
    else:
        x, y, w = _gauss_hermite(value)
        Hs = system.energy(x, y)
        q, _ = np.histogram(Hs, bins=faces, weights=w)
    return q / q.sum()
