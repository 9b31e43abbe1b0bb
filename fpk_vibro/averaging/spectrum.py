"""The energy-envelope spectrum: S(ω) and R(τ) from the orbits, the averaged energy
diffusion and the phase diffusion.

Model.  On the orbit of energy H the motion has frequency Ω(H) and Fourier
coefficients c_k(H) (x) or s_k(H) (y), phase θ counted from the orbit's left end
(:mod:`fpk_vibro.averaging.envelope`).  With θ uniform and H stationary (the averaged
p(H), :func:`~fpk_vibro.averaging.stationary`), the harmonic k of the signal,
2 c_k(H) cos kθ, is carried along by the averaged energy diffusion (generator
L f = m f' + ½σ² f'' = (1/p)(½σ² p f')') while its phase turns at kΩ(H) and diffuses
at k²σ_φ²(H)/2.  So (Feynman–Kac) with A_k = L + ikΩ − k²σ_φ²/2,

    R(τ) = Σ_k 2 Re ⟨p c_k, e^{A_k τ} c_k⟩  (+ ⟨p c̃₀, e^{Lτ} c̃₀⟩, c̃₀ = c₀ − E[x]),
    S(ω) = (1/π) Σ_k Re ⟨p c_k, [(iω − A_k)⁻¹ + (−iω − A_k)⁻¹] c_k⟩  (+ the k = 0 term),

two-sided (∫S dω = Var q).  A path's frequency thus changes as its energy wanders
(impacting orbits are faster), which broadens the lines beyond the spread of Ω over
p(H) or narrows them (motional narrowing), as the rates say.

Why this is right for the linear oscillator.  Without walls c₁ = sqrt(H/2a),
L sqrt(H) = sqrt(H) (D1/4H − c/2) (m = D1 − cH, σ² = 2D1H) and σ_φ² = D1/2H: the
two noise terms cancel and c₁ is an eigenfunction of A₁ with eigenvalue iω0 − c/2.
S is then (E[H]/2a)[L(ω − ω0) + L(ω + ω0)], L the Lorentzian of half-width c/2:
near the peak the exact (D1/π)/((a − ω²)² + c²ω²) (a − ω² ≈ 2ω0(ω0 − ω)), the same
height, width and area; their ratio is (ω² + ω0²)/(2ω0²) up to O(c²), an O(c)
relative error within the line.  The width is the damping's: c/2 = d/(2H) with d(H)
the energy lost per unit time; a bare delta line per energy would have none.

Numerics.  Energies from the floor to where Φ = 40 (p below e^-40 of its start) in
cells uniform in the regime variables of the averaged density (amplitude below the
lowest wall energy, s = sqrt(H − G(x_w)) above each; every wall energy a face);
L by finite volumes (symmetric in the p-weighted product, zero flux at both ends).
A_k, symmetrised by the square roots of the cell masses, is complex symmetric and
tridiagonal; its eigen-decomposition gives ⟨p c, e^{A_k τ} c⟩ = Σ_j α_j e^{λ_j τ}, so
R_k(τ) = 2 Re Σ α_j e^{λ_j τ} and S_k(ω) = (1/π) Re Σ α_j [1/(iω − λ_j) + 1/(−iω − λ_j)]
on any ω and τ (α_j from a solve with the eigenvectors; |Σα − ⟨p c, c⟩| checks them).
Harmonics are added until the p-weighted Parseval deficit ⟨q²⟩ − c₀² − Σ 2c_k² is
below 1e-5 of the variance.  Above each wall energy E, Ω has a square-root kink
and σ_φ² ∝ 1/(H − E): it is cut off at the energy's random change over a period
(:func:`_regularised`), without which S drifts with the smallest cell.

Error estimate (``Spectrum.error_estimate()``), per ω the sum of:

- grid: |S − S(half the cells)| (the harmonics above 1e-3 of the variance);
- harmonics: the Parseval deficit, put on the next harmonic's lines;
- line shape: each cell's part of S_k times min(1, |ω² − (kΩ)²|/(ω² + (kΩ)²)) plus
  d/(2ΩH), d the energy lost per unit time (for the linear oscillator the exact
  relative departure of the Lorentzian pair, plus its damping per radian); the
  whole part of a harmonic below 1e-3 of the variance;
- averaging's density: S times the indicator model's estimate for E[H] or the
  variance, whichever is larger (p(H) places the lines, and E[x²] alone can be
  right by cancellation: :mod:`fpk_vibro.averaging.error_model`, no FE solve).

It assumes what averaging assumes: light damping and weak noise, the energy nearly
constant over a period; impacts keep the phase on the orbit (their phase jumps with
r < 1 are left out).
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.linalg import eigh_tridiagonal

from .._checks import InputError, check_int
from ..model import VibroImpactSystem
from ..orbits import energy_loss
from ..spectrum import Spectrum, check_omega, check_signal
from .envelope import orbit_terms
from .options import Options
from .regimes import Layout

__all__ = ["spectrum", "ASSUMES"]

ASSUMES = ("averaging's energy envelope: light damping and weak noise (energy nearly "
           "constant over a period); harmonics carried by the averaged energy diffusion "
           "with phase diffusion, phase jumps at impacts left out; the density part from "
           "the indicator model (no FE check)")
_PHI_END = 40.0
_DEFICIT = 1e-5
#: A harmonic with less of the variance than this is left out (counted in the deficit).
_ACTIVE = 1e-9
#: Harmonics above this share of the variance get the per-cell line-shape error.
_MAIN = 1e-3


def _cells(sol, n_cells: int, merge: int = 1) -> tuple[np.ndarray, ...]:
    """(faces, centres, p(H) dH per cell): cells uniform in each regime's variable,
    every wall energy a face; ``merge`` = 2 joins neighbours."""
    s, lay = sol.system, Layout(sol.system)
    grid = np.linspace(lay.floor, sol.H_end, 4001)
    above = np.nonzero(sol.phi(grid) >= _PHI_END)[0]
    H_cut = float(grid[above[0]]) if above.size else float(sol.H_end)
    pieces = []                                      # (H(t), dH/dt, t1)
    if lay.A_max is not None:
        top = float(lay.kinks[0]) if lay.kinks.size else math.inf
        pieces.append((s.potential, s.restoring_force,
                       lay.A_max if H_cut > top else float(s.amplitude(H_cut))))
    for k, E in enumerate(lay.kinks):
        if H_cut <= E:
            break
        hi = min(lay.top(k), H_cut)
        pieces.append((lambda u, E=E: E + u * u, lambda u: 2.0 * u, math.sqrt(hi - E)))
    masses = [float(np.mean(sol.pdf_energy(H_of(np.linspace(0, t1, 65)))))
              * (H_of(t1) - H_of(0.0)) for H_of, _, t1 in pieces]
    share = np.array(masses) / max(sum(masses), 1e-300)
    counts = np.maximum(16, 2 * np.round(0.5 * n_cells * share).astype(int))
    faces, centres, mass = [np.array([lay.floor])], [], []
    for (H_of, dH, t1), m in zip(pieces, counts):
        e = np.linspace(0.0, t1, m + 1)[::merge]
        tm = 0.5 * (e[1:] + e[:-1])
        faces.append(H_of(e[1:]))
        centres.append(H_of(tm))
        mass.append(sol.pdf_energy(H_of(tm)) * dH(tm) * np.diff(e))
    return np.concatenate(faces), np.concatenate(centres), np.concatenate(mass)


class _Envelope:
    """The discrete model on one set of cells: L, the harmonics and their rates."""

    def __init__(self, sol, of: str, n_cells: int, K: int, n: int, merge: int = 1):
        s = sol.system
        faces, H, mass = _cells(sol, n_cells, merge)
        o = orbit_terms(s, H, K, n, of)
        self.H, self.mass, self.omega, self.c = H, mass, o["omega"], o["c"]
        self.c0 = o["c0"]
        self.deficit = mass * np.maximum(o["msq"] - o["c0"] ** 2
                                         - 2.0 * np.sum(o["c"] ** 2, -1), 0.0)
        self.phase2 = _regularised(s, H, o["phase2"], n)
        T = np.where(self.omega > 0, 2 * np.pi / np.where(self.omega > 0, self.omega, 1), 0)
        loss = o["loss"] + np.where(T > 0, energy_loss(s, H) / np.where(T > 0, T, 1.0), 0.0)
        Hrel = H - Layout(s).floor
        self.share = np.where((Hrel > 0) & (self.omega > 0), loss / (
            2.0 * np.maximum(self.omega, 1e-300) * np.maximum(Hrel, 1e-300)), 0.0)
        # L by finite volumes: flux ½σ²p at the inner faces, zero at both ends
        inner = faces[1:-1]
        F = 0.5 * orbit_terms(s, inner, 1, n, "x")["sigma2"] * sol.pdf_energy(inner)
        g = F / np.diff(H)
        self.up = np.append(g / mass[:-1], 0.0)       # L[i, i+1]
        self.down = np.insert(g / mass[1:], 0, 0.0)   # L[i, i-1]
        self.diag = -(self.up + self.down)

    def harmonic(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(diagonal of A_k, the coefficients it carries); k = 0: L and c̃₀."""
        if k == 0:
            c = self.c0 - np.sum(self.mass * self.c0) / np.sum(self.mass)
            return self.diag.astype(complex), c
        return (self.diag + 1j * k * self.omega - 0.5 * k * k * self.phase2,
                self.c[:, k - 1])

    def modes(self, k: int) -> tuple[np.ndarray, np.ndarray, float]:
        """(λ_j, α_j) with ⟨p c, e^{A_k τ} c⟩ = Σ α_j e^{λ_j τ}, and the relative
        mismatch |Σα − ⟨p c, c⟩| / ⟨p c, c⟩ (the eigenvectors' conditioning)."""
        d, c = self.harmonic(k)
        rc = np.sqrt(self.mass) * c
        off = np.sqrt(self.up[:-1] * self.down[1:])  # the symmetrised off-diagonal
        if k == 0:                                    # real symmetric: stable, and drop
            lam, V = eigh_tridiagonal(d.real, off)    # the stationary mode
            lam, V = lam[:-1], V[:, :-1]
            alpha = (V.T @ rc) ** 2 + 0j
        else:
            lam, V = np.linalg.eig(np.diag(d) + np.diag(off, 1) + np.diag(off, -1))
            alpha = (rc @ V) * np.linalg.solve(V, rc.astype(complex))
        total = float(rc @ rc)
        miss = abs(complex(np.sum(alpha)) - total) / max(total, 1e-300)
        return lam + 0j, alpha, miss


def _regularised(system: VibroImpactSystem, H: np.ndarray, phase2: np.ndarray, n: int
                 ) -> np.ndarray:
    """σ_φ² with its singularity above each wall energy E cut off: Ω has a square-root
    kink at E, so σ_φ² ∝ 1/(H − E) there, where the diffusion approximation of the
    phase needs H − E larger than the energy's random change over a period,
    δ = sqrt(σ²(E) T(E)).  Between E and E + δ the value at E + δ is used (paper case:
    S changes by < 0.1 % for δ between 0.05 and 0.16 and no longer depends on the
    cells; without the cut-off it drifts like the log of the smallest cell)."""
    out = phase2.copy()
    for E in Layout(system).kinks:
        o = orbit_terms(system, np.array([E]), 1, n, "x")
        delta = math.sqrt(max(float(o["sigma2"][0]) * 2 * math.pi / max(
            float(o["omega"][0]), 1e-300), 0.0))
        near = (H > E) & (H < E + delta)
        if np.any(near):
            out[near] = orbit_terms(system, np.array([E + delta]), 1, n, "x")["phase2"][0]
    return out


def _density(w: np.ndarray, k: int, lam: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """S_k(ω) = (1/π) Re Σ α_j [1/(iω − λ_j) + 1/(−iω − λ_j)] (half that for k = 0,
    whose R carries no factor 2)."""
    S = np.zeros(w.size)
    scale = (0.5 if k == 0 else 1.0) / np.pi
    step = max(1, 200_000 // max(1, lam.size))
    for i in range(0, w.size, step):                 # chunks of ω
        iw = 1j * w[i:i + step, None]
        S[i:i + step] = scale * (alpha[None, :] * (1.0 / (iw - lam) + 1.0 / (-iw - lam))
                                 ).real.sum(-1)
    return S


def _shape(w: np.ndarray, S_k: np.ndarray, k: int, env: "_Envelope", main: bool
           ) -> np.ndarray:
    """The line-shape error of harmonic k (module docstring): per cell i, its part of
    S_k, (m c)_i Re g_i with (±iω − A_k) g = c, times min(1, |ω² − (kΩ_i)²|/(ω² +
    (kΩ_i)²)) + d_i/(2Ω_i H_i); |S_k| (1 + max ρ) for a harmonic that is not ``main``;
    none for k = 0 (the slow wandering of the orbit mean has no line)."""
    if k == 0:
        return np.zeros(w.size)
    if not main:
        return np.abs(S_k) * (1.0 + min(1.0, float(np.max(env.share))))
    d, c = env.harmonic(k)
    kO2 = (k * env.omega[:, None]) ** 2
    out = np.zeros(w.size)
    step = max(1, 100_000 // d.size)
    for i in range(0, w.size, step):
        ww = w[i:i + step]
        f = np.minimum(1.0, np.abs(ww ** 2 - kO2) / np.maximum(ww ** 2 + kO2, 1e-300)) \
            + env.share[:, None]
        for sign in (1.0, -1.0):
            g = _thomas(sign * 1j * ww, d, env.up, env.down, c)
            out[i:i + step] += np.abs((env.mass * c)[:, None] * g.real * f).sum(0)
    return out / np.pi


def _thomas(z: np.ndarray, d: np.ndarray, up: np.ndarray, down: np.ndarray,
            c: np.ndarray) -> np.ndarray:
    """(N, z.size): solve (z − A) g = c for each z, A tridiagonal (diagonal d, upper
    ``up``, lower ``down``); the real part of z − A dominates its diagonal, so no
    pivoting is needed."""
    n = d.size
    cp = np.empty((n, z.size), dtype=complex)
    g = np.empty((n, z.size), dtype=complex)
    beta = z - d[0]
    cp[0], g[0] = -up[0] / beta, c[0] / beta
    for i in range(1, n):
        beta = z - d[i] + down[i] * cp[i - 1]
        cp[i] = -up[i] / beta
        g[i] = (c[i] + down[i] * g[i - 1]) / beta
    for i in range(n - 2, -1, -1):
        g[i] -= cp[i] * g[i + 1]
    return g


def spectrum(system: VibroImpactSystem, omega: Any, of: str = "x", *, n_theta: int = 48,
             n_panel: int = 24, phi_cut: float = 60.0, n_cells: int = 128,
             harmonics: int = 48, n_lags: int | None = None) -> Spectrum:
    """The energy-envelope spectrum S(ω) and correlation R(τ) of ``of`` (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
        What :func:`~fpk_vibro.averaging.stationary` takes: one orbit per energy
        level, white noise, no forcing (anything else: one-line InputError).
    omega : array_like
        Frequencies in rad/s, ascending, ≥ 0.
    of : {"x", "y"}
    n_theta, n_panel, phi_cut : numerics of :func:`~fpk_vibro.averaging.stationary`
        (n_theta: nodes per orbit, raised to 2·harmonics + 16 for the harmonics).
    n_cells : int
        Energy cells of the averaged diffusion (≥ 32).
    harmonics : int
        The most harmonics (1–256); fewer when the Parseval deficit is below 1e-5.
    n_lags : int, optional
        Lags of R (default: 32 per period of the fundamental up to where R is below
        1e-4 R(0), 513–8193).

    Returns
    -------
    Spectrum
        Method "averaging"; ``info`` has ``harmonics``, ``cells``, ``seconds``.

    Examples
    --------
    >>> import numpy as np
    >>> from fpk_vibro import VibroImpactSystem, averaging
    >>> s = VibroImpactSystem(a=1.0, b=0.0, c=0.05, D1=0.005, barriers="none")
    >>> sp = averaging.spectrum(s, np.linspace(0.0, 3.0, 601))
    >>> round(sp.peak_frequency(), 3), round(float(sp.correlation(0.0)) / 0.1, 6)
    (1.0, 1.0)
    """
    t0 = time.perf_counter()
    where = "averaging.spectrum"
    w = check_omega(where, omega)
    of = check_signal(where, of)
    n_cells = check_int("n_cells", n_cells, 32, 20_000, where=where)
    K = check_int("harmonics", harmonics, 1, 256, where=where)
    if n_lags is not None:
        n_lags = check_int("n_lags", n_lags, 16, 10 ** 6, where=where)
    sol = _stationary(system, n_theta, n_panel, phi_cut)
    n = max(sol.n_theta, 2 * K + 16)
    env = _Envelope(sol, of, n_cells, K, n)
    m = sol.moments()
    mean = float(sol.mean_x()) if of == "x" else 0.0
    variance = (m["E_x2"] - mean ** 2) if of == "x" else m["E_y2"]
    power = np.sum(env.mass[:, None] * env.c ** 2, 0)
    tail = np.sum(env.deficit) + 2.0 * (np.sum(power) - np.cumsum(power))
    ok = np.nonzero(tail <= _DEFICIT * variance)[0]
    K_used = int(ok[0]) + 1 if ok.size else K
    ks = [k + 1 for k in range(K_used) if power[k] > _ACTIVE * variance]
    if of == "x" and not system.symmetric:
        ks = [0] + ks
    modes = {k: env.modes(k) for k in ks}
    main = [k for k in ks if k == 0 or power[k - 1] > _MAIN * variance]
    S, shape = np.zeros(w.size), np.zeros(w.size)
    for k, (lam, alpha, _) in modes.items():
        Sk = _density(w, k, lam, alpha)
        S, shape = S + Sk, shape + _shape(w, Sk, k, env, k in main)
    lags = _lags(modes, n_lags, env)
    R = _correlation(lags, modes)
    deficit = float(tail[K_used - 1])
    est = _estimate(sol, of, w, S, shape, R, lags, modes, main, deficit, variance, env,
                    n_cells, K, n)
    info = {"harmonics": len(ks), "harmonics_max": K_used, "cells": int(env.H.size),
            "n_theta": n, "seconds": time.perf_counter() - t0}
    return Spectrum("averaging", system, of, w, S, variance=variance, lags=lags,
                    correlation=R, estimate=est, info=info, mean=mean)


def _stationary(system, n_theta, n_panel, phi_cut):
    from .stationary import solve
    try:
        opts, _ = Options.prepare(system, "stationary", dict(
            n_theta=n_theta, n_panel=n_panel, phi_cut=phi_cut))
    except InputError as exc:
        text = str(exc).replace("averaging.stationary", "averaging.spectrum", 1)
        if not text.startswith("averaging.spectrum"):
            text = "averaging.spectrum: " + text.removeprefix("averaging: ")
        raise InputError(text, where="averaging.spectrum", name=exc.name) from None
    try:
        return solve(system, opts)
    except ValueError as exc:         # no normalisable density (a power-law tail)
        text = str(exc).removeprefix("averaging: ")
        raise InputError(f"averaging.spectrum: {text}", where="averaging.spectrum",
                         name="system") from None


def _correlation(tau: np.ndarray, modes: dict) -> np.ndarray:
    R = np.zeros(tau.size)
    for k, (lam, alpha, _) in modes.items():
        for i in range(0, tau.size, 512):
            e = np.exp(np.outer(tau[i:i + 512], lam)) @ alpha
            R[i:i + 512] += (1.0 if k == 0 else 2.0) * e.real
    return R


def _lags(modes: dict, n_lags: int | None, env: _Envelope) -> np.ndarray:
    """Lags from 0 to where the modes' bound Σ|α| e^{Re λ τ} is below 1e-4 R(0)."""
    lam = np.concatenate([v[0] for v in modes.values()])
    size = np.concatenate([np.abs(v[1]) * (1 if k == 0 else 2) for k, v in modes.items()])
    R0 = max(float(np.sum(size)), 1e-300)
    O1 = float(np.sum(env.mass * env.c[:, 0] ** 2 * env.omega)
               / max(np.sum(env.mass * env.c[:, 0] ** 2), 1e-300))
    period = 2 * np.pi / max(O1, 1e-300)
    probe = period * np.geomspace(0.1, 4000.0, 400)
    bound = np.exp(np.outer(probe, np.minimum(lam.real, 0.0))) @ size
    below = np.nonzero(bound < 1e-4 * R0)[0]
    tau_max = float(probe[below[0]]) if below.size else float(probe[-1])
    n = n_lags or int(np.clip(32 * tau_max / period, 513, 8193))
    return np.linspace(0.0, tau_max, n)


def _estimate(sol, of, w, S, shape, R, lags, modes, main, deficit, variance, env, n_cells,
              K, n) -> dict[str, Any]:
    """The error estimate (module docstring); the grid part from the main harmonics
    (the others' whole part is already in ``shape``)."""
    from .error_model import estimate as indicator_estimate
    t0 = time.perf_counter()
    half = _Envelope(sol, of, n_cells, K, n, merge=2)
    half_modes = {k: half.modes(k) for k in main}
    mine = {k: modes[k] for k in main}
    grid = np.abs(sum(_density(w, k, modes[k][0], modes[k][1]) - _density(w, k, lam, alpha)
                      for k, (lam, alpha, _) in half_modes.items()))
    grid_R = float(np.max(np.abs(_correlation(lags, mine) - _correlation(lags, half_modes))))
    line = _line(w, env, max(modes) + 1 if modes else 1, deficit)
    ind = indicator_estimate(sol)          # p(H)'s error moves the lines: E[H]'s too
    dens = float(max(ind["E_H"], ind["E_x2" if of == "x" else "E_y2"]))
    err = grid + line + shape + dens * S
    eig = max((v[2] for v in modes.values()), default=0.0)
    R0 = max(float(R[0]), 1e-300)
    top = max(float(np.max(S)), 1e-300)
    width = float(np.max(shape) / top)
    return {"density": err, "relative": float(np.max(err)) / top,
            "variance": dens + deficit / variance,
            "correlation": width + dens + (grid_R + deficit) / R0 + eig,
            "grid": float(np.max(grid)) / top, "line_shape": width, "model": dens,
            "harmonic_deficit": deficit / variance, "eigen": eig,
            "assumes": ASSUMES, "seconds": time.perf_counter() - t0}


def _line(w: np.ndarray, env: _Envelope, k: int, power: float) -> np.ndarray:
    """``power`` spread as Lorentzian lines at ±kΩ(H) of width d/(2H) over p(H)."""
    p = env.mass / max(np.sum(env.mass), 1e-300)
    gam = np.maximum(env.share * env.omega, 1e-12)
    out = np.zeros(w.size)
    for sign in (1.0, -1.0):
        u = w[:, None] - sign * k * env.omega[None, :]
        out += (gam / (gam ** 2 + u ** 2) / np.pi) @ p
    return 0.5 * power * out
