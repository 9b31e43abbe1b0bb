"""The energy regimes of the averaged density: where Φ(H) is analytic, and in what.

p(H) has a square-root kink at every wall energy G(x_w): above it the orbit is cut
by the wall and the orbit integrals gain a term ∝ (H − G(x_w))^{3/2}.  The energy
axis is therefore split at the floor of the strip and at the wall energies
E₀ < E₁ (:func:`fpk_vibro.orbits.wall_energies`), and Φ is built on each piece in
a variable that makes its integrand analytic:

- the amplitude A (H = G(A)) from H = 0 to E₀, when the strip contains x = 0 (the
  orbits around the minimum that touch no wall);
- s = sqrt(H − E_k) from E_k to E_{k+1} (or ∞): orbits that hit the walls of
  energy ≤ E_k.  For a strip without x = 0 (preload) E₀ is the floor, where the
  orbit shrinks to a point at the nearest wall (T ∝ s, f ∝ 1/s, f dH/ds bounded).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import legendre as L

from ..model import VibroImpactSystem
from ..orbits import energy_floor, energy_loss, orbit_nodes, wall_energies

__all__ = ["Layout", "Regime", "build_regime", "build_all", "phi_rate", "gauss_legendre",
           "panel_nodes"]

_MAX_PANELS = 400


class Layout:
    """Where the regimes of ``system`` lie on the energy axis (module docstring).

    Attributes
    ----------
    floor : float
        The lowest energy on the strip.
    kinks : ndarray
        The distinct wall energies, increasing (the starts of the s-regimes).
    A_max : float or None
        End of the amplitude regime (the nearest wall in |x|, ∞ without walls);
        None when the strip does not contain x = 0 (no amplitude regime).
    """

    def __init__(self, system: VibroImpactSystem) -> None:
        lo, hi = system.x_bounds
        self.floor = energy_floor(system)
        self.kinks = wall_energies(system)
        self.A_max = min(-lo, hi) if lo < 0.0 < hi else None

    @property
    def n_high(self) -> int:
        """Number of s-regimes (at least one, empty without walls)."""
        return max(1, self.kinks.size)

    def top(self, k: int) -> float:
        """Upper energy of s-regime k (∞ for the last)."""
        return float(self.kinks[k + 1]) if k + 1 < self.kinks.size else math.inf


class Regime:
    """Φ on consecutive panels of one variable t (A or s): Legendre antiderivatives."""

    def __init__(self, edges: np.ndarray, coef: np.ndarray, phi0: np.ndarray) -> None:
        self.edges, self.coef, self.phi0 = edges, coef, phi0

    @classmethod
    def empty_like(cls, n_panel: int) -> "Regime":
        return cls(np.zeros(1), np.zeros((n_panel + 1, 0)), np.zeros(0))

    @property
    def empty(self) -> bool:
        return self.edges.size < 2

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Φ(t) for t within [edges[0], edges[-1]] (clipped)."""
        e = self.edges
        k = np.clip(np.searchsorted(e, t, side="right") - 1, 0, e.size - 2)
        tau = np.clip((2.0 * t - e[k] - e[k + 1]) / (e[k + 1] - e[k]), -1.0, 1.0)
        return self.phi0[k] + L.legval(tau, self.coef[:, k], tensor=False)

    @property
    def end_value(self) -> float:
        """Φ at the last edge."""
        k = self.edges.size - 2
        return float(self.phi0[k] + L.legval(1.0, self.coef[:, k]))

    def nodes(self, n_panel: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t, quadrature weights in t, Φ) at the Gauss nodes of every panel, flattened."""
        tq, gw = L.leggauss(n_panel)
        t, w = gauss_legendre(self.edges[:-1], self.edges[1:], tq, gw)
        return t.ravel(), w.ravel(), self(t.ravel())


def build_regime(system, H_of, dH_of, t_max, h0, phi_start, phi_cut, n_panel, n_theta):
    """Panels of Φ in variable t from 0 until t_max or Φ ≥ phi_cut (adaptive widths).

    Returns the :class:`Regime`, the node data (H, weights dH, Φ, orbit sums) of each
    panel, Φ at the end and the end value of t.
    """
    tq, gw = L.leggauss(n_panel)
    j = np.arange(n_panel)
    proj = (j[:, None] + 0.5) * L.legvander(tq, n_panel - 1).T * gw   # values → Legendre coefs
    edges, coefs, phi0, nodes = [0.0], [], [], []
    t, h, phi = 0.0, h0, phi_start
    while t < t_max and phi < phi_cut:
        if len(coefs) >= _MAX_PANELS:
            raise ValueError(
                f"averaging: the density decays too slowly to be normalised (Φ = {phi:.3g} "
                f"< {phi_cut} after {_MAX_PANELS} panels, H = {float(H_of(t)):.3g}); the "
                f"parametric noise D2={system.D2} may be too strong for a stationary density")
        t1 = min(t + h, t_max)
        tt, wt = gauss_legendre(t, t1, tq, gw)
        H = H_of(tt)
        f, sums = phi_rate(system, H, n_theta)
        g = f * dH_of(tt)
        inc = float(np.sum(wt * g))
        if inc > 8.0 and (t1 - t) > 1e-9 * max(t1, 1e-300):
            h = 0.5 * (t1 - t)
            continue
        ci = L.legint(proj @ g, lbnd=-1) * (0.5 * (t1 - t))
        nodes.append((H, wt * dH_of(tt), phi + L.legval(tq, ci), sums))
        edges.append(t1)
        coefs.append(ci)
        phi0.append(phi)
        phi += float(L.legval(1.0, ci))
        t = t1
        if inc < 2.0:
            h *= 2.0
    coef = np.stack(coefs, axis=1) if coefs else np.zeros((n_panel + 1, 0))
    return Regime(np.array(edges), coef, np.array(phi0)), nodes, phi, t


def build_all(system: VibroImpactSystem, layout: Layout, n_theta: int, n_panel: int,
              phi_cut: float):
    """Every regime of ``system``: (low, highs), node data, H_end, nodes of the low regime."""
    from .. import scales
    c = system.c
    nodes: list = []
    phi, H_end = 0.0, layout.floor
    low = Regime.empty_like(n_panel)
    if layout.A_max is not None:
        A_max = layout.A_max
        # initial panel width from the energy scale D1/c of the Gibbs limit
        if c > 0:
            A0 = float(system.amplitude(system.D1 / c))
            h0 = 0.5 * (A0 if np.isfinite(A0) else A_max)
            h0 = min(h0, A_max)
        else:
            h0 = 0.25 * A_max
        low, nodes, phi, t_end = build_regime(
            system, system.potential, system.restoring_force, A_max, h0, 0.0,   # dH/dA = G'(A)
            phi_cut, n_panel, n_theta)
        H_end = float(system.potential(t_end))
    n_low = len(nodes)
    highs = []
    for k in range(layout.n_high):
        if k >= layout.kinks.size or not phi < phi_cut:
            highs.append(Regime.empty_like(n_panel))
            continue
        E, top = float(layout.kinks[k]), layout.top(k)
        with np.errstate(divide="ignore", invalid="ignore"):
            f_b = float(phi_rate(system, np.array([E]), n_theta)[0][0])
        if np.isfinite(f_b) and f_b > 0:
            h0 = 0.5 / np.sqrt(f_b)
        elif E > layout.floor:
            h0 = 0.25 * np.sqrt(E - layout.floor)
        else:                                  # the orbit is a point at E: no rate there
            h0 = 0.5 * math.sqrt(scales.energy_scale(system))
        s_max = math.sqrt(top - E) if math.isfinite(top) else np.inf
        reg, more, phi, s_end = build_regime(
            system, lambda s, E=E: E + s * s, lambda s: 2.0 * s, s_max, h0, phi,
            phi_cut, n_panel, n_theta)
        highs.append(reg)
        nodes += more
        H_end = top if s_end >= s_max else E + s_end ** 2
    return low, highs, nodes, H_end, n_low


def gauss_legendre(lo, hi, t: np.ndarray, gw: np.ndarray):
    """Gauss–Legendre nodes and weights on [lo, hi] (arrays broadcast; nodes last)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    half = 0.5 * (hi - lo)
    return 0.5 * (hi + lo)[..., None] + half[..., None] * t, half[..., None] * gw


def panel_nodes(edges: np.ndarray, t: np.ndarray, gw: np.ndarray):
    """Composite Gauss–Legendre on consecutive panels (last axis of ``edges``), flattened."""
    x, w = gauss_legendre(edges[..., :-1], edges[..., 1:], t, gw)
    shape = x.shape[:-2] + (x.shape[-2] * x.shape[-1],)
    return x.reshape(shape), w.reshape(shape)


def phi_rate(system: VibroImpactSystem, H: np.ndarray, n_theta: int):
    """f(H) = (2c J1 + δ)/J2 and the orbit sums ∮ g dt for the moments."""
    o = orbit_nodes(system, H, n_theta)
    v2 = o.v ** 2
    x2 = o.x ** 2
    J1 = o.integrate(v2)
    J2 = o.integrate(2.0 * v2 * system.noise_intensity(o.x))
    f = (2.0 * system.c * J1 + energy_loss(system, H)) / J2
    sums = {"T": o.period, "x2": 2.0 * o.integrate(x2), "x4": 2.0 * o.integrate(x2 * x2),
            "y2": 2.0 * J1, "y4": 2.0 * o.integrate(v2 * v2), "x1": 2.0 * o.integrate(o.x)}
    return f, sums
