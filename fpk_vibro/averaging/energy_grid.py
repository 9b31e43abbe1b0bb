"""The energy grid of the averaged transient and the initial density on it.

:func:`energy_faces` places the finite-volume cells in H (every wall energy a face);
:func:`initial_cell_masses` is the initial condition's mass in each cell and
:func:`check_coverage` refuses a grid that leaves some of it outside.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy import special

from .._checks import InputError
from ..initial import InitialCondition
from ..model import VibroImpactSystem
from .regimes import Layout

__all__ = ["energy_faces", "initial_cell_masses", "check_coverage"]


#: Width ratio of neighbouring cells above the stationary density's reach (a start
#: far above the stationary energies).  E[H] at t = 1 from y0 = 10 … 1e6 on the paper's
#: system against the averaged drift's own ODE: 1.5–3.8 % off at 1.03 (0.2–4.8 s),
#: 0.5–1.3 % at 1.01 (0.4–30 s), 4–13 % at 1.1.
GROWTH = 1.03


def energy_faces(system: VibroImpactSystem, H_max: float, n_cells: int,
                 H_top: float | None = None) -> np.ndarray:
    """Cell faces on [floor, H_max]; every wall energy G(x_w) < H_max is a face, with
    cells uniform in s = sqrt(H − G(x_w)) above it (graded toward it from above).

    A strip containing x = 0 starts with cells uniform in H from 0; a preloaded
    strip starts at its floor, a wall energy, with cells uniform in s.  With
    ``H_top`` (where the stationary density ends) below ``H_max``, the ``n_cells``
    cells cover [floor, H_top] and cells growing by :data:`GROWTH` continue to
    ``H_max`` (wall energies there are faces too): a start far above the stationary
    energies does not stretch the cells the stationary density needs.
    """
    if H_top is None or not H_top < H_max / GROWTH:
        return _faces(system, H_max, n_cells)
    low = _faces(system, H_top, n_cells)
    width, top, ext = low[-1] - low[-2], float(low[-1]), []
    while top < H_max:
        width *= GROWTH
        top = min(top + width, H_max)
        ext.append(top)
    ext = np.asarray(ext)
    kinks = Layout(system).kinks
    kinks = kinks[(kinks > H_top) & (kinks < H_max)]
    if kinks.size:           # a kink replaces the nearest face (widths stay graded)
        near = np.clip(np.searchsorted(ext, kinks), 0, ext.size - 2)
        ext[near] = kinks
        ext = np.unique(ext)
    return np.concatenate([low, ext])


def _faces(system: VibroImpactSystem, H_max: float, n_cells: int) -> np.ndarray:
    """:func:`energy_faces` of ``n_cells`` cells on [floor, H_max]."""
    lay = Layout(system)
    kinks = [float(E) for E in lay.kinks if lay.floor < E < H_max]
    if lay.A_max is not None and len(kinks) <= 1:
        Hb = system.barrier_energy
        if not (system.has_barrier and Hb < H_max):
            return np.linspace(0.0, H_max, n_cells + 1)
        # above G(Δ) uniform in s = sqrt(H − G(Δ)): p(H) ~ (H − G(Δ))^½ there
        n1 = min(max(8, round(n_cells * np.sqrt(Hb / H_max))), n_cells - 8)
        s = np.linspace(0.0, np.sqrt(H_max - Hb), n_cells - n1 + 1)[1:]
        return np.concatenate([np.linspace(0.0, Hb, n1 + 1), Hb + s * s])
    B = np.array([lay.floor, *kinks, H_max])
    in_s = [lay.A_max is None] + [True] * len(kinks)
    n = _share(n_cells, np.sqrt(np.diff(B)))
    faces = [B[:1]]
    for lo, hi, k, s_var in zip(B[:-1], B[1:], n, in_s):
        seg = (lo + np.linspace(0.0, np.sqrt(hi - lo), k + 1) ** 2 if s_var
               else np.linspace(lo, hi, k + 1))
        seg[-1] = hi
        faces.append(seg[1:])
    return np.concatenate(faces)


def _share(n_cells: int, weights: np.ndarray) -> np.ndarray:
    """n_cells split in proportion to ``weights``, at least min(8, n_cells // len) each."""
    least = min(8, n_cells // weights.size)
    n = np.maximum(least, np.round(n_cells * weights / weights.sum()).astype(int))
    n[np.argmax(n)] += n_cells - n.sum()
    return n


def initial_cell_masses(init: InitialCondition, faces: np.ndarray, *, n_samples: int = 400_000,
                        seed: int = 0) -> np.ndarray:
    """P(H ∈ cell) under the initial condition: exact CDF differences for the Gaussian form.

    F(H) = P(H(X, Y) ≤ H) = E_X[P(|Y − 0| ≤ sqrt(2(H − G(X))))]; a zero std in a
    component makes it a point mass there.  A sampler callable is histogrammed
    from ``n_samples`` draws of ``numpy.random.default_rng(seed)``.
    """
    system = init.system
    if not init.is_gaussian:
        x, y = init.sample(n_samples, np.random.default_rng(seed))
        H = system.energy(x, y)
        counts, _ = np.histogram(np.clip(H, faces[0], faces[-1]), bins=faces)
        return counts / n_samples
    (mx, my), (sx, sy) = init.mean, init.std

    def p_y(G: np.ndarray) -> np.ndarray:   # P(Y²/2 ≤ H − G) for every face H
        s = np.sqrt(2.0 * np.maximum(faces - G, 0.0))
        if sy == 0:
            return (np.abs(my) <= s).astype(float) * (faces >= G)
        return special.ndtr((s - my) / sy) - special.ndtr((-s - my) / sy)

    if sx == 0:
        F = p_y(system.potential(mx))
    else:
        lo, hi = system.x_bounds
        a, b = max(lo, mx - 12 * sx), min(hi, mx + 12 * sx)
        t, w = np.polynomial.legendre.leggauss(64)
        edges = np.linspace(a, b, 33)
        xs = (0.5 * (edges[1:] + edges[:-1])[:, None] + 0.5 * np.diff(edges)[:, None] * t).ravel()
        ws = (0.5 * np.diff(edges)[:, None] * w).ravel() * np.exp(-0.5 * ((xs - mx) / sx) ** 2)
        ws /= ws.sum()
        F = np.sum(ws[:, None] * p_y(system.potential(xs)[:, None]), axis=0)
    return np.diff(F)


def check_coverage(masses: Any, H_max: float) -> None:
    """Raise unless the cell masses of the initial density sum to 1 (to 1e-6)."""
    lost = 1.0 - float(masses.sum())
    if lost > 1e-6:
        raise InputError(f"averaging.transient: H_max = {H_max:g} leaves {lost:.2g} of the "
                         "initial mass outside the energy grid (raise it)",
                         where="averaging.transient", name="H_max")
