"""Validation, defaults and kernel-parameter set-up for the Monte Carlo engine."""
from __future__ import annotations

import math
import numbers
import sys
import time
from typing import Any

import numpy as np

from .. import _checks
from ..model import VibroImpactSystem
from . import _kernel as K
from .solution import QUANTITIES

CHUNK_PATH_STEPS = 1 << 23      # path-steps per kernel call (progress / Ctrl-C granularity)


def fail(func: str, name: str, allowed: str, value: Any) -> ValueError:
    return _checks.invalid(f"montecarlo.{func}", name, allowed, value)


def check_int(func: str, name: str, value: Any, lo: int, hi: int | None = None) -> int:
    return _checks.check_int(name, value, lo, hi, where=f"montecarlo.{func}")


def check_float(func: str, name: str, value: Any, lo: float, hi: float = math.inf,
                lo_open: bool = True, hi_open: bool = False) -> float:
    return _checks.check_float(name, value, lo, hi, lo_open=lo_open, hi_open=hi_open,
                               where=f"montecarlo.{func}")


def check_system(func: str, system: Any) -> VibroImpactSystem:
    if not isinstance(system, VibroImpactSystem):
        raise fail(func, "system", "a VibroImpactSystem", system)
    return system


def check_quantities(func: str, quantities: Any) -> tuple[str, ...]:
    if isinstance(quantities, str):
        quantities = (quantities,)
    try:
        qs = tuple(quantities)
    except TypeError:
        raise fail(func, "quantities", f"a sequence of names from {QUANTITIES}",
                   quantities) from None
    bad = [q for q in qs if q not in QUANTITIES]
    if bad or len(set(qs)) != len(qs):
        raise fail(func, "quantities", f"distinct names from {QUANTITIES}", quantities)
    return tuple(q for q in QUANTITIES if q in qs)


def check_seed(func: str, seed: Any) -> np.random.SeedSequence:
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        return np.random.SeedSequence()
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise fail(func, "seed", "None, an integer >= 0 or a numpy SeedSequence", seed)
    return np.random.SeedSequence(int(seed))


def _edges_or_count(func: str, name: str, v: Any) -> int | np.ndarray:
    if isinstance(v, numbers.Integral) and not isinstance(v, bool):
        return check_int(func, f"bins[{name!r}]", v, 1, 100_000)
    arr = np.asarray(v, dtype=float) if not isinstance(v, (str, bytes)) else np.array([])
    if arr.ndim != 1 or arr.size < 2 or not np.all(np.isfinite(arr)) or \
            not np.all(np.diff(arr) > 0):
        raise fail(func, f"bins[{name!r}]", "a bin count >= 1 or increasing finite "
                   "edges (>= 2 values)", v)
    w = np.diff(arr)
    if not np.allclose(w, w[0], rtol=1e-9, atol=0):
        raise fail(func, f"bins[{name!r}]", "equally spaced edges (the kernel bins "
                   "uniformly)", v)
    return arr


def check_bins(func: str, bins: Any) -> dict[str, Any]:
    """bins: int n (n bins for energy, x, y; n//2 per axis for joint) or a dict."""
    if isinstance(bins, numbers.Integral) and not isinstance(bins, bool):
        n = check_int(func, "bins", bins, 2, 100_000)
        return {"energy": n, "x": n, "y": n, "joint": (max(n // 2, 1),) * 2}
    if not isinstance(bins, dict):
        raise fail(func, "bins", "an integer >= 2 or a dict {quantity: count or edges}",
                   bins)
    unknown = set(bins) - set(QUANTITIES)
    if unknown:
        raise fail(func, "bins keys", f"names from {QUANTITIES}", sorted(unknown))
    out = check_bins(func, 100)
    for k, v in bins.items():
        if k == "joint":
            if isinstance(v, numbers.Integral) and not isinstance(v, bool):
                v = (v, v)
            if not (isinstance(v, (tuple, list)) and len(v) == 2):
                raise fail(func, "bins['joint']", "a count, or a pair (x bins, y bins) "
                           "of counts or edges", v)
            out[k] = (_edges_or_count(func, "joint x", v[0]),
                      _edges_or_count(func, "joint y", v[1]))
        else:
            out[k] = _edges_or_count(func, k, v)
    return out


# -- time scales --------------------------------------------------------------------
def _omega_lin(system: VibroImpactSystem) -> float:
    """sqrt(|a| + |b| Δ²) (or (D1/Δ²)^(1/3) for a free particle between barriers)."""
    d = system.delta if system.has_barrier else 1.0
    w2 = abs(system.a) + abs(system.b) * d * d
    return math.sqrt(w2) if w2 > 0 else (system.D1 / (d * d)) ** (1.0 / 3.0)


def _rate0(system: VibroImpactSystem) -> float:
    """c, or with c = 0 (inelastic barrier required) (1 − r²) ω_lin/2π."""
    if system.c > 0:
        return system.c
    return (1.0 - system.r ** 2) * _omega_lin(system) / (2.0 * math.pi)


def energy_scale(system: VibroImpactSystem) -> float:
    """Rough stationary E[H] scale D1/λ0 (initial states and length scales only)."""
    return system.D1 / _rate0(system)


def amplitude_scale(system: VibroImpactSystem, n_scales: float = 5.0) -> float:
    """Amplitude at ``n_scales`` energy scales, capped by Δ with two barriers."""
    A = float(system.amplitude(n_scales * energy_scale(system)))
    if not math.isfinite(A):
        A = system.delta if system.has_barrier else 1.0
    return min(A, system.delta) if system.barriers == "both" else A


def length_scale(system: VibroImpactSystem) -> float:
    """Typical amplitude X of the motion (5 energy scales, at most Δ)."""
    return amplitude_scale(system, 5.0)


def omega0(system: VibroImpactSystem) -> float:
    """Reference angular frequency sqrt(|a| + |b| X²), X = :func:`length_scale`."""
    X = length_scale(system)
    w2 = abs(system.a) + abs(system.b) * X * X
    if w2 > 0:
        return math.sqrt(w2)
    return _omega_lin(system)


def period(system: VibroImpactSystem) -> float:
    """Reference period T0 = 2π/ω0 of the smooth motion."""
    return 2.0 * math.pi / omega0(system)


def relaxation_rate(system: VibroImpactSystem) -> float:
    """Slowest energy relaxation rate estimate λ (DESIGN §2 averaged drift).

    c when c > 0: paths below the barrier energy G(Δ) lose energy only through
    damping, so they set the slowest time scale.  With c = 0 (allowed only with an
    inelastic barrier) the impact loss rate (1 − r²)/T0: one impact per period
    removes the fraction 1 − r² of the kinetic energy at impact.
    """
    if system.c > 0:
        return system.c
    return (1.0 - system.r ** 2) / period(system)


#: Target relative SE below which the default dt shrinks (:func:`default_dt`).
DT_RSE = 1e-3


def default_dt(system: VibroImpactSystem, target_rse: float | None = None) -> float:
    """T0/120, times sqrt(target_rse / DT_RSE) when ``target_rse`` < DT_RSE.

    The scheme's bias is O(dt²): the largest measured at T0/120 is 5.4e-4
    relative (E[x²] at r = 0.98 against FE; 17e-4 and 65e-4 at 2 and 4 × T0/120),
    so shrinking dt as sqrt(target_rse) keeps it near 0.4 × a smaller target.
    """
    dt = period(system) / 120.0
    if target_rse is not None and target_rse < DT_RSE:
        dt *= math.sqrt(target_rse / DT_RSE)
    return dt


def default_t_burn(system: VibroImpactSystem) -> float:
    """6 relaxation times 6/λ (initial-state bias decays to e⁻⁶ ≈ 0.25 %, and the
    start is already near the equilibrium energy scale)."""
    return 6.0 / relaxation_rate(system)


def default_sample_every(system: VibroImpactSystem, dt: float) -> int:
    """Steps between samples: about T0/4 in time.

    E[H] decorrelates over the energy relaxation time 1/λ ≫ T0 (40 for the
    paper's case, T0 ≈ 6), so for E[H] denser sampling adds only cost; the x and
    y histograms do gain from it (paper r = 0.92, equal sampled time: standard
    errors ×1.4 at T0/2, ×0.7 at T0/8, measured), and T0/4 costs ~6 % of a
    path-step.  The ensemble's random phases make the histograms unbiased at any
    interval.
    """
    return max(1, round(period(system) / (4.0 * dt)))


def check_dt(func: str, system: VibroImpactSystem, dt: Any) -> float:
    dt = check_float(func, "dt", dt, 0.0)
    X = amplitude_scale(system, 30.0)
    wmax = math.sqrt(abs(system.a) + 3.0 * abs(system.b) * X * X)
    limit = 1.0 / wmax if wmax > 0 else math.inf
    if dt > limit:
        raise fail(func, "dt", f"in (0, {limit:.4g}] (1/ω_max, ω_max² = |a| + 3|b| X², "
                   f"X = {X:.4g}: beyond it the explicit splitting loses stability)", dt)
    return dt


# -- kernel set-up ------------------------------------------------------------------
def block_starts(n_paths: int, n_blocks: int) -> np.ndarray:
    return (np.arange(n_blocks + 1, dtype=np.int64) * n_paths) // n_blocks


def rng_states(children: list[np.random.SeedSequence]) -> np.ndarray:
    st = np.array([c.generate_state(4, np.uint64) for c in children], dtype=np.uint64)
    st[np.all(st == 0, axis=1), 0] = 1           # xoshiro's forbidden all-zero state
    return st


def step_params(system: VibroImpactSystem, dt: float, max_impacts: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's (p, ip) vectors for one step size (histogram slots left 0)."""
    p = np.zeros(K.NP)
    ip = np.zeros(K.NI, dtype=np.int64)
    c = system.c
    p[K.P_A], p[K.P_B], p[K.P_HH] = system.a, system.b, 0.5 * dt
    p[K.P_EC] = math.exp(-c * dt)
    s2 = -math.expm1(-2.0 * c * dt) / c if c > 0 else 2.0 * dt   # Var of OU / D
    p[K.P_SD0] = math.sqrt(system.D1 * s2)
    p[K.P_D1S2], p[K.P_D2S2] = system.D1 * s2, system.D2 * s2
    lo, hi = system.x_bounds
    p[K.P_LO], p[K.P_HI], p[K.P_R] = lo, hi, system.r
    p[K.P_GD] = system.barrier_energy
    for i, xb in ((K.P_FLO, lo), (K.P_FHI, hi)):
        p[i] = -(system.a + system.b * xb * xb) * xb if math.isfinite(xb) else 0.0
    ip[K.I_MODE] = {"none": K.MODE_NONE, "right": K.MODE_RIGHT, "both": K.MODE_BOTH}[
        system.barriers]
    ip[K.I_D2] = 1 if system.D2 > 0 else 0
    ip[K.I_MAXK] = max_impacts
    return p, ip


def potential_min(system: VibroImpactSystem) -> float:
    """min G over the strip (0 unless a < 0 < b, the double well)."""
    a, b = system.a, system.b
    g = 0.0
    if a < 0 < b:
        xm2 = -a / b
        lo, hi = system.x_bounds
        if xm2 <= max(lo * lo, hi * hi):
            g = -a * a / (4.0 * b)
    if system.barriers == "both" and b < 0:
        g = min(g, float(system.potential(system.delta)))
    return g


class Histograms:
    """Edges of the requested histograms and the per-block count arrays."""

    def __init__(self, system: VibroImpactSystem, quantities: tuple[str, ...],
                 bins: dict[str, Any], n_blocks: int, H_max: float) -> None:
        lo, hi = system.x_bounds
        gmin = potential_min(system)
        H_max = max(H_max, gmin + 1e-12)
        if system.barriers == "both":
            xlo, xhi = lo, hi
        else:                       # |x| <= A(H) for every state with energy H
            X = max(float(system.amplitude(max(H_max, 0.0))), 1e-12)
            xlo, xhi = -X, min(hi, X)
            if xhi <= xlo:
                xhi = xlo + 1e-12
        Y = math.sqrt(2.0 * (H_max - gmin))

        def make(spec, v0, v1):
            return spec if isinstance(spec, np.ndarray) else np.linspace(v0, v1, spec + 1)

        self.edges = {}
        if "energy" in quantities:
            self.edges["edges_H"] = make(bins["energy"], gmin, H_max)
        if "x" in quantities:
            self.edges["edges_x"] = make(bins["x"], xlo, xhi)
        if "y" in quantities:
            self.edges["edges_y"] = make(bins["y"], -Y, Y)
        if "joint" in quantities:
            self.edges["edges_jx"] = make(bins["joint"][0], xlo, xhi)
            self.edges["edges_jy"] = make(bins["joint"][1], -Y, Y)

        def arr(key, *tail):
            return np.zeros((n_blocks, self.edges[key].size - 1) + tail) \
                if key in self.edges else np.zeros((n_blocks, 0) + tail)

        self.hH = arr("edges_H")
        self.hx = arr("edges_x")
        self.hy = arr("edges_y")
        nj = (self.edges["edges_jx"].size - 1, self.edges["edges_jy"].size - 1) \
            if "edges_jx" in self.edges else (0, 1)
        self.hj = np.zeros((n_blocks,) + nj)

    def fill_params(self, p: np.ndarray) -> None:
        """Put the (uniform) bin origins and inverse widths into p."""
        for key, i0, iw in (("edges_H", K.P_H0, K.P_HIW), ("edges_x", K.P_X0, K.P_XIW),
                            ("edges_y", K.P_Y0, K.P_YIW), ("edges_jx", K.P_JX0, K.P_JXIW),
                            ("edges_jy", K.P_JY0, K.P_JYIW)):
            if key in self.edges:
                e = self.edges[key]
                p[i0] = e[0]
                p[iw] = (e.size - 1) / (e[-1] - e[0])


class Progress:
    """A one-line progress report on stderr, only on a terminal and after 2 s."""

    def __init__(self, enabled: bool | None, label: str) -> None:
        self.enabled = sys.stderr.isatty() if enabled is None else bool(enabled)
        self.label = label
        self.t0 = time.perf_counter()
        self.shown = False

    def update(self, frac: float, extra: str = "") -> None:
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        if el < 2.0 and not self.shown:
            return
        self.shown = True
        eta = el * (1 - frac) / frac if frac > 0 else math.inf
        sys.stderr.write(f"\r[montecarlo] {self.label}: {100 * frac:5.1f}%  "
                         f"{el:6.1f}s elapsed, ~{eta:6.1f}s left {extra}   ")
        sys.stderr.flush()

    def close(self, note: str = "") -> None:
        if self.enabled and self.shown:
            sys.stderr.write(f"\r[montecarlo] {self.label}: done {note}".ljust(78) + "\n")
            sys.stderr.flush()
