"""The system's own scales: period, relaxation rate, energy scale and tail cut.

One module for every method: Monte Carlo (time step, burn-in, initial state),
finite elements (truncated domain, time step) and the cost estimates of a scene
use these, so each scale is estimated once.

Tail cut
--------
Where the density has no closed form, the truncation of the state space uses a
bound on the energy tail that holds for every system with damping c > 0: along
the energy H the local temperature is at most ``T(H) = D(X(H)) / c`` with
``D(x) = D1 + D2 x²`` and X(H) the largest |x| reachable at energy H on the
strip; impacts (r < 1) only remove energy.  Where G increases on each side of
its minimum (one orbit per energy level) the temperature is instead the orbit
average ``J2/(2 J1 + δ/c)`` (orbit integrals of :mod:`fpk_vibro.orbits`, the
impact loss δ spread over the orbit), which is tight with parametric noise and
impacts and still conservative for r < 1.  The tail density of the energy is
``dS(H) exp(−Φ(H))``, ``Φ(H) = ∫ du / T(u)``, S(H) the area of the state space
below H (dS/dH the period).  :func:`tail_energy` is the H_t above which it holds
less than ``mass``.  For r = 1, D2 = 0 both are the exact Gibbs tail.
"""
from __future__ import annotations

import functools
import math

from typing import Any

import numpy as np

from .model import VibroImpactSystem

__all__ = ["energy_scale", "length_scale", "omega0", "period", "relaxation_rate",
           "relaxation_time", "potential_min", "tail_energy", "reach", "density_grids",
           "TAIL_MASS"]

#: Mass allowed beyond a truncation of the state space (FE domain).
TAIL_MASS = 1e-8


def _wall_extent(system: VibroImpactSystem) -> float:
    """max |x_w| over the walls (Δ for walls at ±Δ); 1 without walls or with one at 0."""
    d = max((abs(w.position) for _, w in system.walls), default=0.0)
    return d if d > 0 else 1.0


def _impact_loss(system: VibroImpactSystem) -> float:
    """Mean over the walls of 1 − r², the share of the kinetic energy an impact
    removes (1 − r² for walls at ±Δ or one wall; 0 without walls).  The mean, not
    the least dissipative wall: with c = 0 one inelastic wall beside an elastic one
    is enough for a stationary state (the model refuses c = 0 only when no wall
    loses energy), and its loss is halved, not lost, by the elastic one."""
    walls = [w for _, w in system.walls]      # (a law: its least r, the largest loss)
    return sum(1.0 - w.r_bounds()[0] ** 2 for w in walls) / len(walls) if walls else 0.0


def _omega_lin(system: VibroImpactSystem) -> float:
    """sqrt(|a| + |b| Δ²) (or (D1/Δ²)^(1/3) for a free particle between barriers);
    Δ = max |x_w| over the walls."""
    d = _wall_extent(system)
    w2 = abs(system.a) + abs(system.b) * d * d
    return math.sqrt(w2) if w2 > 0 else (system.D1 / (d * d)) ** (1.0 / 3.0)


def _rate0(system: VibroImpactSystem) -> float:
    """c, or with c = 0 (an inelastic wall required) (1 − r²) ω_lin/2π, 1 − r² the
    mean over the walls (:func:`_impact_loss`)."""
    if system.c > 0:
        return system.c
    return _impact_loss(system) * _omega_lin(system) / (2.0 * math.pi)


def energy_scale(system: VibroImpactSystem) -> float:
    """Rough stationary E[H] scale D1/λ0 (initial states and length scales)."""
    return system.D1 / _rate0(system)


def amplitude_scale(system: VibroImpactSystem, n_scales: float = 5.0) -> float:
    """Amplitude at ``n_scales`` energy scales, capped by max |x_w| with two walls."""
    A = float(system.amplitude(n_scales * energy_scale(system)))
    if not math.isfinite(A):
        A = _wall_extent(system)
    both = system.left is not None and system.right is not None
    return min(A, _wall_extent(system)) if both else A


def length_scale(system: VibroImpactSystem) -> float:
    """Typical amplitude X of the motion (5 energy scales, at most Δ)."""
    return amplitude_scale(system, 5.0)


def omega0(system: VibroImpactSystem) -> float:
    """Reference angular frequency sqrt(|a| + |b| X²), X = :func:`length_scale`."""
    X = length_scale(system)
    w2 = abs(system.a) + abs(system.b) * X * X
    return math.sqrt(w2) if w2 > 0 else _omega_lin(system)


def period(system: VibroImpactSystem) -> float:
    """Reference period T0 = 2π/ω0 of the smooth motion."""
    return 2.0 * math.pi / omega0(system)


def relaxation_rate(system: VibroImpactSystem) -> float:
    """Slowest energy relaxation rate estimate λ.

    c when c > 0: paths below the barrier energy G(Δ) lose energy only through
    damping, so they set the slowest time scale.  With c = 0 (allowed only with an
    inelastic barrier) the impact loss rate (1 − r²)/T0: one impact per period
    removes the fraction 1 − r² of the kinetic energy at impact (the mean over the
    walls, :func:`_impact_loss`).
    """
    if system.c > 0:
        return system.c
    return _impact_loss(system) / period(system)


def relaxation_time(system: VibroImpactSystem) -> float:
    """1/λ, the time over which the energy forgets its start."""
    return 1.0 / relaxation_rate(system)


def potential_min(system: VibroImpactSystem) -> float:
    """min G over the strip: at x = 0, at the wells ±sqrt(−a/b) (a < 0 < b) or at a
    wall, whichever of them lie on the strip."""
    a, b = system.a, system.b
    lo, hi = system.x_bounds
    cands = [0.0]
    if a < 0 < b:
        xm = math.sqrt(-a / b)
        cands += [-xm, xm]
    cands += [w.position for _, w in system.walls]
    on = [x for x in cands if lo <= x <= hi]
    return float(min(system.potential(x) for x in on))


def reach(system: VibroImpactSystem, H: np.ndarray) -> np.ndarray:
    """Largest |x| on the strip with G(x) ≤ H (the walls cap it)."""
    lo, hi = system.x_bounds
    wall = max(abs(lo), abs(hi))
    A = np.asarray(system.amplitude(np.maximum(np.asarray(H, dtype=float), 0.0)), dtype=float)
    if system.a < 0 < system.b:            # the outer root of G = H, also for H < 0
        disc = system.a ** 2 + 4.0 * system.b * np.asarray(H, dtype=float)
        with np.errstate(invalid="ignore"):
            A = np.sqrt(np.maximum(-system.a + np.sqrt(np.maximum(disc, 0.0)), 0.0) / system.b)
    if system.b < 0:      # softening: beyond its hump G falls again, down to the wall
        A = np.where(np.asarray(H, dtype=float) >= system.potential(wall), wall, A)
    return np.where(np.isfinite(A), np.minimum(A, wall), wall)


@functools.lru_cache(maxsize=1)
def _gauss_400() -> tuple[np.ndarray, np.ndarray]:
    """The 400-point Gauss–Legendre rule, computed once (an eigenvalue problem of
    400 × 400: ~10 ms, 40 % of a 6 000-DOF FE solve's time, three times per solve)."""
    t, w = np.polynomial.legendre.leggauss(400)
    t.flags.writeable = w.flags.writeable = False
    return t, w


def _bound_density(system: VibroImpactSystem, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rate 1/T(H), dS/dH) of the tail bound on the energies ``H`` (module docstring)."""
    from .orbits import energy_loss, orbit_nodes, single_well
    if single_well(system):
        with np.errstate(divide="ignore", invalid="ignore"):   # H = 0 with a = 0
            o = orbit_nodes(system, np.maximum(H, 0.0))
        v2 = np.nan_to_num(o.v ** 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            J1 = o.integrate(v2)
            J2 = o.integrate(2.0 * v2 * system.noise_intensity(o.x))
            rate = (2.0 * system.c * J1 + energy_loss(system, H)) / J2
        rate[0] = system.c / system.D1                      # the H → 0 limit
        return rate, np.nan_to_num(o.period, posinf=0.0)
    X2 = reach(system, H) ** 2
    lo, hi = system.x_bounds
    X = float(reach(system, H[-1]))
    x0, x1 = max(lo, -X), min(hi, X)
    t, w = _gauss_400()
    x = 0.5 * (x0 + x1) + 0.5 * (x1 - x0) * t
    kin = np.maximum(H[:, None] - system.potential(x)[None, :], 0.0)
    S = (2.0 * np.sqrt(2.0 * kin)) @ (0.5 * (x1 - x0) * w)
    return system.c / (system.D1 + system.D2 * X2), np.gradient(S, H)


def tail_energy(system: VibroImpactSystem, mass: float = TAIL_MASS) -> float:
    """Energy H_t above which the tail of the module docstring holds < ``mass``.

    Raises
    ------
    ValueError
        For c = 0 (no damping bound) or where the tail does not decay
        (parametric noise too strong on a side without barrier).
    """
    if system.c == 0:
        raise ValueError("c = 0: no damping bound on the energy tail (all dissipation "
                         "comes from impacts); give y_max")
    g0 = potential_min(system)
    T0 = (system.D1 + system.D2 * float(reach(system, g0)) ** 2) / system.c
    top = g0 + 40.0 * T0
    for _ in range(30):
        H = g0 + (top - g0) * np.linspace(0.0, 1.0, 2001) ** 2
        rate, dS = _bound_density(system, H)
        phi = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(H))])
        dm = 0.5 * (dS[1:] + dS[:-1]) * np.diff(H) * np.exp(-0.5 * (phi[1:] + phi[:-1]))
        total = dm.sum()
        if total > 0:
            tail = np.concatenate([np.cumsum(dm[::-1])[::-1], [0.0]]) / total
            if tail[-2] < 1e-3 * mass:
                return float(H[np.argmax(tail < mass)])
        top = g0 + 2.0 * (top - g0)
    raise ValueError(f"the energy tail does not decay fast enough for a truncation "
                     f"(D2={system.D2} against c={system.c} on a side without barrier); "
                     "give y_max and a mesh that covers the support")


def density_grids(system: VibroImpactSystem, reference: Any) -> dict[str, np.ndarray]:
    """Evaluation grids for H, x, y covering the bulk of ``reference``'s density."""
    g0 = potential_min(system)
    H_top = g0 + 12.0 * max(reference.moments()["E_H"] - g0, 1e-12)
    lo, hi = system.x_bounds
    A = float(reach(system, H_top))
    lo, hi = max(lo, -A), min(hi, A)
    y_top = float(np.sqrt(2.0 * (H_top - g0)))
    return {"energy": np.linspace(g0, H_top, 301)[1:], "x": np.linspace(lo, hi, 241),
            "y": np.linspace(-y_top, y_top, 241),
            "joint": (np.linspace(lo, hi, 121), np.linspace(-y_top, y_top, 121))}
