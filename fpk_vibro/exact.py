"""The exact stationary density for elastic impacts without parametric noise.

For r = 1 and D2 = 0 (or no barrier and D2 = 0) the Gibbs density

    p(x, y) = exp(−β H(x, y)) / Z,   β = c / D1,

on the strip solves the stationary FPK and satisfies the impact condition
p(Δ, −v) = p(Δ, v) (docs/theory.md, §Exact solution).  It is the reference every
method is checked against.  It holds for any a, b (softening, double well) allowed
by the model and for any walls with r = 1 each (asymmetric, both on one side of
x = 0, at or beyond the equilibrium): the density is the same expression restricted
to the strip, so p(y) stays Gaussian while p(x) ∝ exp(−β G(x)) is cut by the walls and
E[x] = ∫ x exp(−β G) dx / ∫ exp(−β G) dx ≠ 0 unless the walls are at ±Δ.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import integrate, special

from ._checks import InputError
from .model import VibroImpactSystem, check_system
from .orbits import energy_floor, orbit_nodes, require_single_well
from .scales import potential_min
from .solution import Solution

__all__ = ["GibbsSolution", "gibbs", "gibbs_upcrossing_rate"]

_QUAD = dict(epsabs=0.0, epsrel=1e-13, limit=400)


class GibbsSolution(Solution):
    """p(x, y) ∝ exp(−(c/D1) H) on the strip; exact for r = 1 (or no barrier), D2 = 0.

    Raises
    ------
    ValueError
        If the system is not such a case (r < 1 with a barrier, or D2 > 0).
    """

    kind = "exact"

    def __init__(self, system: VibroImpactSystem) -> None:
        require_gibbs(system)
        self.system = system
        self.beta = system.c / system.D1
        lo, hi = system.x_bounds
        # wells of G inside the strip, where the integrand peaks
        wells = [w for w in self._wells() if lo < w < hi]
        self._g0 = potential_min(system)            # min G over the strip
        self._bounds = (lo, hi)
        self._points = sorted(set(wells + [0.0]))
        self.Zx = self._x_integral(lambda x: np.ones_like(x))
        self.Z = self.Zx * math.sqrt(2.0 * math.pi / self.beta)

    def _wells(self) -> list[float]:
        a, b = self.system.a, self.system.b
        return [math.sqrt(-a / b), -math.sqrt(-a / b)] if a < 0 < b else []

    def _weight(self, x: np.ndarray) -> np.ndarray:
        return np.exp(-self.beta * (self.system.potential(x) - self._g0))

    def _x_integral(self, g) -> float:
        """∫ g(x) exp(−β(G − G_min)) dx over the strip, split at the wells."""
        lo, hi = self._bounds
        cuts = [lo] + [p for p in self._points if lo < p < hi] + [hi]
        return sum(integrate.quad(lambda x: float(g(np.asarray(x)) * self._weight(x)),
                                  u, v, **_QUAD)[0] for u, v in zip(cuts[:-1], cuts[1:]))

    # -- densities ----------------------------------------------------------------
    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        p = np.exp(-self.beta * (self.system.energy(x, y) - self._g0)) / self.Z
        return np.where(self.system.in_strip(x), p, 0.0)

    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return np.where(self.system.in_strip(x), self._weight(x) / self.Zx, 0.0)

    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        return math.sqrt(self.beta / (2.0 * math.pi)) * np.exp(-0.5 * self.beta * y * y)

    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        """p(H) = T(H) exp(−βH)/Z, T(H) = ∫ 2 dx/sqrt(2H − 2G) over {G < H} ∩ strip."""
        H = np.asarray(H, dtype=float)
        try:
            require_single_well(self.system, "the vectorised period")
            T = orbit_nodes(self.system, np.maximum(H, energy_floor(self.system))).period
            T = np.where(H > self._g0, T, 0.0)
        except ValueError:
            T = np.vectorize(self._period_general, otypes=[float])(H)
        with np.errstate(over="ignore"):
            p = T * np.exp(-self.beta * (H - self._g0)) / self.Z
        return np.where(H > self._g0, p, 0.0)

    def _period_general(self, H: float) -> float:
        """Level-set period for any potential: quad with 1/sqrt weights at turning points."""
        a, b = self.system.a, self.system.b
        lo, hi = self._bounds
        # 2H − 2G(x) = −(b/2)(x² − q1)(x² − q2) (or a(q − x²) for b = 0): factored,
        # so it keeps its relative accuracy next to the turning points
        if b != 0:
            disc = a * a + 4 * b * H
            if disc < 0:
                qs = []
                def gap(x):
                    return 2.0 * H - 2.0 * float(self.system.potential(x))
            else:
                sq = math.sqrt(disc)
                q1, q2 = (-a + sq) / b, (-a - sq) / b
                qs = [q1, q2]
                def gap(x):
                    return -0.5 * b * (x * x - q1) * (x * x - q2)
        else:
            qs = [2.0 * H / a] if a != 0 else []
            def gap(x):
                return 2.0 * H - a * x * x
        roots = [s * math.sqrt(q) for q in qs if q > 0 for s in (1.0, -1.0)]
        cuts = sorted({c for c in roots if lo < c < hi} | {lo, hi})
        rootset = set(roots)
        total = 0.0
        for u, v in zip(cuts[:-1], cuts[1:]):
            if not (math.isfinite(u) and math.isfinite(v)):
                continue
            if self.system.potential(0.5 * (u + v)) >= H:
                continue
            al = -0.5 if u in rootset else 0.0
            ar = -0.5 if v in rootset else 0.0

            def f(x, u=u, v=v, al=al, ar=ar):
                return 2.0 / math.sqrt(max(gap(x), 1e-300)) * max(x - u, 0.0) ** (-al) * max(v - x, 0.0) ** (-ar)
            total += integrate.quad(f, u, v, weight="alg", wvar=(al, ar), **_QUAD)[0]
        return total

    def moments(self) -> dict[str, float]:
        G = self.system.potential
        Ex2 = self._x_integral(lambda x: x * x) / self.Zx
        Ex4 = self._x_integral(lambda x: x ** 4) / self.Zx
        EG = self._x_integral(G) / self.Zx
        out = {"E_H": 0.5 / self.beta + EG, "E_x2": Ex2, "E_y2": 1.0 / self.beta,
               "E_x4": Ex4, "E_y4": 3.0 / self.beta ** 2}
        if self.system.has_barrier:
            # P(H > min G(x_w)): the probability of being on an orbit that hits a wall
            Gb = self.system.barrier_energy
            out["P_impact"] = self._x_integral(
                lambda x: special.erfc(np.sqrt(self.beta * np.maximum(Gb - G(x), 0.0)))) / self.Zx
        return out

    def error_estimate(self) -> dict[str, Any]:
        """The exact density's error: zero (its integrals to 1e-13 relative)."""
        keys = ["L1", "E_H", "E_x2", "E_y2"] + (["P_impact"] if self.system.has_barrier
                                                else [])
        return {**{k: 0.0 for k in keys},
                "assumes": "exact (the Gibbs density; quadrature to 1e-13 relative)"}

    def impacts(self) -> dict[str, dict[str, float]]:
        """Closed forms (docs/impacts.md): y ~ N(0, σ²), σ² = D1/c, independent of x,
        so ν_w = p_X(x_w) σ/sqrt(2π), E[u] = σ sqrt(π/2), E[u²] = 2σ², no energy lost."""
        sigma = math.sqrt(self.system.D1 / self.system.c)
        out = {}
        for side, w in self.system.walls:
            px = float(self.pdf_x(np.array([w.position]))[0])
            out[side] = {"rate": px * sigma / math.sqrt(2 * math.pi),
                         "mean_speed": sigma * math.sqrt(math.pi / 2),
                         "mean_square_speed": 2 * sigma * sigma, "energy_rate": 0.0}
        return out

    def impact_speed_pdf(self, wall: str, u):
        """The Rayleigh density (u/σ²) exp(−u²/2σ²), u ≥ 0, on either wall."""
        self.wall_named(wall)
        u = np.asarray(u, dtype=float)
        s2 = self.system.D1 / self.system.c
        return np.where(u >= 0, u / s2 * np.exp(-u * u / (2 * s2)), 0.0)

    def mean_x(self) -> float:
        """E[x] = ∫ x exp(−β G) dx / ∫ exp(−β G) dx over the strip (adaptive quadrature);
        exactly 0 for walls at ±Δ or none."""
        if self.system.symmetric:
            return 0.0
        return self._x_integral(lambda x: x) / self.Zx

    # -- persistence --------------------------------------------------------------
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return {}, {}

    @classmethod
    def _check_state(cls, system, meta, arrays):
        """The stored system must be one the Gibbs density is exact for."""
        require_gibbs(system)

    @classmethod
    def _from_state(cls, system, meta, arrays):
        return cls(system)


def require_gibbs(system: VibroImpactSystem) -> None:
    """Raise :class:`~fpk_vibro._checks.InputError` unless D2 = 0 and every wall has
    r = 1 (a number, or a law r(u) ≡ 1)."""
    check_system("exact.gibbs", system)
    rs = {side: w.r for side, w in system.walls}
    if system.D2 != 0 or any(not w.elastic for _, w in system.walls):   # (a law r ≡ 1 too)
        got = (f"r={system.r}" if system.r is not None
               else ", ".join(f"{side} r={r}" for side, r in rs.items()))
        raise InputError(f"exact: the Gibbs density needs D2 = 0 and r = 1 at every wall "
                         f"(or no wall); got D2={system.D2}, {got}", where="exact",
                         name="system")


def gibbs(system: VibroImpactSystem) -> GibbsSolution:
    """The exact Gibbs solution of ``system`` (r = 1 or no barrier, D2 = 0)."""
    return GibbsSolution(system)


def gibbs_upcrossing_rate(system: VibroImpactSystem, b: Any) -> Any:
    """The closed form of ν⁺(b) for r = 1 (or no wall) and D2 = 0.

    The Gibbs density p = exp(−β H)/Z, β = c/D1, H = y²/2 + G(x), gives

        ν⁺(b) = ∫₀^∞ y e^{−β y²/2} dy · e^{−β G(b)}/Z = (D1/c) e^{−β G(b)} / Z,

    Z the normaliser of :class:`GibbsSolution` (0 beyond a wall; docs/theory.md,
    §Spectra and crossings).

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> s = VibroImpactSystem(a=4, b=0, c=0.2, D1=0.01, barriers="none")
    >>> round(gibbs_upcrossing_rate(s, 0.0), 12) == round(2 / (2 * math.pi), 12)
    True
    """
    from .crossings import _levels, _out
    levels, scalar = _levels("gibbs_upcrossing_rate", b)
    sol = GibbsSolution(system)
    with np.errstate(under="ignore"):
        nu = np.exp(-sol.beta * (system.potential(levels) - sol._g0)) / (sol.beta * sol.Z)
    return _out(np.where(system.in_strip(levels), nu, 0.0), scalar)
