"""The system's time scales and the default step, burn-in and sampling interval of
the Monte Carlo engine (from :mod:`fpk_vibro.scales`)."""
from __future__ import annotations

import functools
import math

import numpy as np

from ..model import VibroImpactSystem
from ..scales import (_bound_density, amplitude_scale, energy_scale, length_scale, omega0,
                      period, potential_min, reach, tail_energy)
from ..scales import relaxation_rate as _relaxation_rate

#: Target relative SE below which the default dt shrinks (:func:`default_dt`).
DT_RSE = 1e-3


@functools.lru_cache(maxsize=64)
def typical_energy(system: VibroImpactSystem) -> float:
    """E[H] − min G of the stationary energy density that bounds the tail
    (:mod:`fpk_vibro.scales`: orbit-averaged drift and diffusion with the impact loss
    where G increases on each side of its minimum, the local temperature D(X(H))/c
    elsewhere).  It is the averaging estimate, close where the energy carries the
    mass (paper case 0.216 against 0.22 by FE; 2.6·10⁴ against 2.3·10⁴ at D1 = 10⁶,
    r = 0.92) and above it elsewhere (Δ = 10⁻³, r = 0: 7.2·10⁻⁴ against 3·10⁻⁴), so
    the scales below err towards shorter steps.  Without a damping bound (c = 0) or
    where the tail does not decay: D(X)/λ0, X the wall extent.
    """
    g0 = potential_min(system)
    try:
        top = tail_energy(system, 1e-6)
        H = g0 + (top - g0) * np.linspace(0.0, 1.0, 801) ** 2
        Hm = 0.5 * (H[1:] + H[:-1])
        with np.errstate(all="ignore"):
            rate, _ = _bound_density(system, H)
            _, dS = _bound_density(system, Hm)        # the period at the midpoints
            phi = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) *
                                                   np.diff(H))])
            w = dS * np.diff(H) * np.exp(-0.5 * (phi[1:] + phi[:-1]))
            E = float(np.sum(w * (Hm - g0)) / np.sum(w))
        if math.isfinite(E) and E > 0:
            return E
    except (ValueError, ArithmeticError):
        pass
    X = amplitude_scale(system, 5.0)
    return energy_scale(system) * (1.0 + system.D2 * X * X / system.D1 if system.D1 > 0
                                   else 1.0)


def time_scales(system: VibroImpactSystem) -> dict[str, float]:
    """The system's time scales that bound the Monte Carlo step (:func:`_time_scales`)."""
    return dict(_time_scales(system))


@functools.lru_cache(maxsize=64)
def _time_scales(system: VibroImpactSystem) -> tuple[tuple[str, float], ...]:
    """The system's time scales that bound the Monte Carlo step, by name (seconds).

    With E = :func:`typical_energy`, v = sqrt(2 E) the typical speed and X the reach
    at 5 E:

    - ``period``: T0 = 2π/ω0 (:func:`fpk_vibro.scales.period`, ω0 at the amplitude
      of 5 energy scales D1/c), or 2π/ω0 at X where that is over 1.5 × faster
      (parametric noise lifting the energy far above D1/c);
    - ``damping time 1/c``;
    - ``noise time E/D``: the time the noise D = D1 + D2 x² (at the reach of E)
      needs to supply the typical energy (a step's kick sqrt(2 D dt) against v);
    - ``crossing time L/v``: the time to cross the part of the strip the typical
      energy reaches (L = 2Δ between walls at ±Δ) at the typical speed (with a wall).
    """
    E = typical_energy(system)
    g0 = potential_min(system)
    X5 = float(reach(system, g0 + 5.0 * E))
    X = max(X5, length_scale(system)) if math.isfinite(X5) else length_scale(system)
    w2 = abs(system.a) + abs(system.b) * X * X
    T0 = period(system)
    if w2 > 0 and 2.0 * math.pi / math.sqrt(w2) < T0 / 1.5:
        T0 = 2.0 * math.pi / math.sqrt(w2)
    out = {"period": T0}
    if system.c > 0:
        out["damping time 1/c"] = 1.0 / system.c
    XE = float(reach(system, g0 + E))
    XE = XE if math.isfinite(XE) else X
    D = system.D1 + system.D2 * XE * XE
    if D > 0 and E > 0:
        out["noise time E/D"] = E / D
    if system.walls and E > 0:
        lo, hi = system.x_bounds
        L = min(hi, XE) - max(lo, -XE)
        if L > 0:
            out["crossing time L/v"] = L / math.sqrt(2.0 * E)
    tb = min((t for t, _ in _bounce_times(system)), default=math.inf)
    if math.isfinite(tb):
        out["bounce time 2D/F²"] = tb
    return tuple(out.items())


def wall_r(system: VibroImpactSystem, wall) -> float:
    """The restitution of ``wall`` the step size rules take: the number, or for a law
    r(u) its smallest value over the impact speeds a path reaches (up to the speed at
    the wall of 30 typical energies above the bottom of the potential; the lower r,
    the more energy an impact removes and the smaller the step the rules ask)."""
    if wall.law is None:
        return float(wall.r)
    E = typical_energy(system)
    g0 = potential_min(system)
    du = g0 + 30.0 * E - float(system.potential(wall.position))
    return wall.r_bounds(math.sqrt(2.0 * max(du, 30.0 * E)))[0]


def _bounce_times(system: VibroImpactSystem) -> list[tuple[float, float]]:
    """(2 D(x_w)/F(x_w)², r_w) for each wall the force F pushes paths into (a
    preloaded wall, a double well or softening spring beyond its hump): a path at
    rest there is launched by the noise to speeds u ~ 2D/|F| and falls back after
    ~u/|F|, so it bounces (and collapses onto the wall for r < 1) on that scale."""
    out = []
    lo, hi = system.x_bounds
    for side, w in system.walls:
        xw = w.position
        F = -float(system.restoring_force(xw))
        if (F > 0 if side == "right" else F < 0):
            out.append((2.0 * (system.D1 + system.D2 * xw * xw) / (F * F),
                        wall_r(system, w)))
    return out


#: Divisors of the crossing time at small r (the sticking of an inelastic impact,
#: where the noise rather than the force moves a path off the wall), log-interpolated.
STICK_R = (0.0, 0.1, 0.2, 0.3)
STICK_DIV = (256.0, 48.0, 24.0, 12.0)


def crossing_divisor(system: VibroImpactSystem, E: float) -> float:
    """k: the default step is the crossing time L/v over k (:func:`step_bounds`).

    Largest over the walls of max(16 (1 − r²), φ k_s(r)), at least 1/8 (r of a law:
    :func:`wall_r`, its smallest over the speeds reached):

    - 16 (1 − r²): an impact removes (1 − r²) of the kinetic energy, and steps that
      span a good part of the decay time L/((1 − r²) v) lose the energy decay within
      the step (E[y²] at D1 = 10⁶, r = 0.92: −24 % at the old T0/120 ≈ 9.5 L/v,
      +1 ± 0.5 % at L/(2v); r = 0.6, Δ = 10⁻³: −2.9 % at k = 2, −0.8 ± 0.4 % at 8);
    - k_s(r) (:data:`STICK_DIV`: 256 at r = 0, 48 at 0.1, 24 at 0.2, 12 at 0.3):
      at small r a path stops on the wall and the step resolves its release; the
      error converges slowly (Δ = 10⁻³, r = 0: −19.5, −5.7, −2.2, −1.0, −0.7 % at
      k = 2, 8, 32, 128, 256 against k = 1024; r = 0.1: −2.8, −0.6 % at k = 8, 32).
      φ = min(1, u*/v), u* = 2 D(x_w)/|F(x_w)| the speed below which noise rather
      than the restoring force F carries a path off the wall: where the force
      dominates (paper system with r = 0: φ = 0.08) T0/120 suffices (−1.0 ± 0.9 %);
    - 1/8: with elastic walls only the impacts per sub-step must stay below
      ``max_impacts`` (64): 8 L/v is ~2 crossings per sub-step at the typical speed.
    """
    v = math.sqrt(2.0 * E)
    k = 0.125
    for _, w in system.walls:
        xw = w.position
        F = abs(float(system.restoring_force(xw)))
        Dw = system.D1 + system.D2 * xw * xw
        phi = min(1.0, 2.0 * Dw / (F * v)) if F * v > 0 else 1.0
        k = max(k, _divisor(wall_r(system, w), phi, 0.125))
    return k


def _divisor(r: float, phi: float, least: float) -> float:
    """max(least, 16 (1 − r²), φ k_s(r)) (:func:`crossing_divisor`)."""
    ks = float(np.exp(np.interp(r, STICK_R, np.log(STICK_DIV), right=-np.inf)))
    return max(least, 16.0 * (1.0 - r * r), phi * ks)


def step_bounds(system: VibroImpactSystem) -> dict[str, tuple[float, float]]:
    """{scale name: (scale, largest default step it allows)}; the default dt is the
    smallest (:func:`default_dt`).

    T0/120 (the O(dt²) bias of smooth motion, see :func:`default_dt`); 1/(10 c)
    (the position update of a step sees the velocity at its ends: with c dt ≳ 1 the
    overdamped motion is lost); the noise time over 4; the crossing time over
    :func:`crossing_divisor`; the bounce time on a wall the force pushes paths into
    over max(4, 16 (1 − r²), k_s(r)) (a = −1, b = −0.3, walls at ±0.8, D1 = 0.005,
    bounce time 0.011: E[y²] +35 % at the old T0/120 = 0.048 with r = 0.8, +2 ±
    1.5 % at 0.012; with r = 0.3 ×2, −17, −5.5, −1 % at 0.048, 0.012, 0.003,
    0.00075).
    """
    ts = time_scales(system)
    out = {}
    for name, t in ts.items():
        if name == "period":
            out[name] = (t, t / 120.0)
        elif name == "damping time 1/c":
            out[name] = (t, 0.1 * t)
        elif name == "noise time E/D":
            out[name] = (t, t / 4.0)
        elif name == "bounce time 2D/F²":
            out[name] = (t, min(tb / _divisor(r, 1.0, 4.0) for tb, r in _bounce_times(system)))
        else:
            out[name] = (t, t / crossing_divisor(system, typical_energy(system)))
    return out


def binding_scale(system: VibroImpactSystem) -> tuple[str, float, float]:
    """(name, scale, allowed step) of the scale that sets the default step."""
    name, (t, b) = min(step_bounds(system).items(), key=lambda kv: kv[1][1])
    return name, t, b


def default_dt(system: VibroImpactSystem, target_rse: float | None = None) -> float:
    """The smallest step :func:`step_bounds` allows, times sqrt(target_rse / DT_RSE)
    when ``target_rse`` < DT_RSE.

    The scheme's bias is O(dt²) on smooth motion: the largest measured at T0/120 is
    5.4e-4 relative (E[x²] at r = 0.98 against FE; 17e-4 and 65e-4 at 2 and 4 ×
    T0/120), so shrinking dt as sqrt(target_rse) keeps it near 0.4 × a smaller target.
    """
    dt = min(b for _, b in step_bounds(system).values())
    if target_rse is not None and target_rse < DT_RSE:
        dt *= math.sqrt(target_rse / DT_RSE)
    return dt


def default_t_burn(system: VibroImpactSystem) -> float:
    """6 relaxation times 6/λ (initial-state bias decays to e⁻⁶ ≈ 0.25 %, and the
    start is already near the equilibrium energy scale)."""
    return 6.0 / relaxation_rate(system)


def relaxation_rate(system: VibroImpactSystem) -> float:
    """:func:`fpk_vibro.scales.relaxation_rate`, or with overdamping (c > 2 ω0) the
    slowest rate of the position, (c − sqrt(c² − 4 ω0²))/2 ≈ ω0²/c (c = 10⁶, a = 1:
    10⁻⁶ where c alone would burn in for 6·10⁻⁶ of the 10⁶ s the position needs)."""
    lam = _relaxation_rate(system)
    c, w2 = system.c, omega0(system) ** 2
    if c > 0 and c * c > 4.0 * w2 > 0:
        lam = min(lam, 2.0 * w2 / (c + math.sqrt(c * c - 4.0 * w2)))
    return lam


def default_sample_every(system: VibroImpactSystem, dt: float) -> int:
    """Steps between samples: about T/4 in time, T the smaller of the period and
    4 crossing times (:func:`time_scales`; the paper's case: T0).

    E[H] decorrelates over the energy relaxation time 1/λ ≫ T0 (40 for the
    paper's case, T0 ≈ 6), so for E[H] denser sampling adds only cost; the x and
    y histograms do gain from it (paper r = 0.92, equal sampled time: standard
    errors ×1.4 at T0/2, ×0.7 at T0/8, measured), and T0/4 costs ~6 % of a
    path-step.  The ensemble's random phases make the histograms unbiased at any
    interval.
    """
    ts = time_scales(system)
    T = min(ts["period"], 4.0 * ts.get("crossing time L/v", math.inf))
    return max(1, round(T / (4.0 * dt)))


def dt_limit(system: VibroImpactSystem) -> float:
    """1/ω_max, ω_max² = |a| + 3|b| X², X at 30 energy scales: beyond it the explicit
    splitting loses stability."""
    X = amplitude_scale(system, 30.0)
    wmax = math.sqrt(abs(system.a) + 3.0 * abs(system.b) * X * X)
    return 1.0 / wmax if wmax > 0 else math.inf
