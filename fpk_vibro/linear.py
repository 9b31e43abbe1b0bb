"""The exact Gaussian density of the linear oscillator without walls.

For a = ω0² > 0, b = 0, D2 = 0 and no wall, the state s = (x, y) (white noise) or
(x, y, ζ) (Ornstein–Uhlenbeck external noise, :mod:`fpk_vibro.noise`) is a linear SDE
ds = A s dt + B dW, so its stationary density is the centred Gaussian whose covariance
Σ solves the continuous Lyapunov equation A Σ + Σ Aᵀ + B Bᵀ = 0 (docs/theory.md,
§Coloured noise): with white noise Σ = diag(D1/(a c), D1/c); with coloured noise the
force's memory lowers both variances.

Its spectral matrix is (1/2π) H(ω) B Bᵀ H(ω)ᴴ with H(ω) = (iω − A)⁻¹, two-sided in
rad/s, and its correlation is R(τ) = e^{Aτ} Σ (docs/theory.md, §Spectra and crossings):
:func:`spectrum` gives both for x or y, the exact reference of the methods' spectra.

Examples
--------
>>> from fpk_vibro import VibroImpactSystem, OrnsteinUhlenbeck
>>> from fpk_vibro.linear import stationary_covariance
>>> s = VibroImpactSystem(a=1, b=0, c=0.1, D1=0.01, barriers="none")
>>> (stationary_covariance(s).round(6) + 0.0).tolist()
[[0.1, 0.0], [0.0, 0.1]]
>>> sc = s.replace(external=OrnsteinUhlenbeck(tau=0.5))
>>> (stationary_covariance(sc).round(6) + 0.0).tolist()
[[0.080769, 0.0, 0.003846], [0.0, 0.076923, 0.007692], [0.003846, 0.007692, 0.02]]
>>> sp = spectrum(s, [0.0, 1.0])
>>> (sp.density.round(6)).tolist(), float(sp.correlation(0.0).round(6))
([0.003183, 0.31831], 0.1)
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import solve_continuous_lyapunov

from ._checks import InputError
from .model import VibroImpactSystem

__all__ = ["stationary_covariance", "drift_and_noise", "spectrum"]


def drift_and_noise(system: VibroImpactSystem) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of ds = A s dt + B dW for a linear system without walls (module
    docstring); s = (x, y) or (x, y, ζ)."""
    s = system
    if s.b != 0 or s.D2 != 0 or s.has_barrier or not s.a > 0 or not s.c > 0:
        raise InputError(f"linear: needs a > 0, b = 0, c > 0, D2 = 0 and no wall; got a={s.a}, "
                         f"b={s.b}, c={s.c}, D2={s.D2}, walls={[w for w, _ in s.walls]}",
                         where="linear", name="system")
    if s.external is None:
        A = np.array([[0.0, 1.0], [-s.a, -s.c]])
        B = np.array([[0.0], [np.sqrt(2.0 * s.D1)]])
    else:
        tau = s.external.tau
        A = np.array([[0.0, 1.0, 0.0], [-s.a, -s.c, 1.0], [0.0, 0.0, -1.0 / tau]])
        B = np.array([[0.0], [0.0], [np.sqrt(2.0 * s.D1) / tau]])
    return A, B


def stationary_covariance(system: VibroImpactSystem) -> np.ndarray:
    """Σ of the stationary Gaussian density: A Σ + Σ Aᵀ + B Bᵀ = 0 (module docstring)."""
    A, B = drift_and_noise(system)
    S = solve_continuous_lyapunov(A, -B @ B.T)
    return 0.5 * (S + S.T)


def spectrum(system: VibroImpactSystem, omega: Any, of: str = "x", *,
             n_lags: int = 4097) -> Any:
    """The exact two-sided S(ω) of ``of`` ("x" or "y") and R(τ) on ``n_lags`` lags up
    to 12 decay times of the slowest mode: a :class:`~fpk_vibro.spectrum.Spectrum` of
    method "exact" (module docstring)."""
    from .spectrum import Spectrum, check_omega, check_signal
    where = "linear.spectrum"
    w = check_omega(where, omega)
    q = SIGNALS_INDEX[check_signal(where, of)]
    A, B = drift_and_noise(system)
    n = A.shape[0]
    Q = B @ B.T
    H = np.linalg.solve(1j * w[:, None, None] * np.eye(n) - A, np.eye(n))
    S = np.einsum("wi,ij,wj->w", H[:, q, :], Q, H[:, q, :].conj()).real / (2 * np.pi)
    Sigma = stationary_covariance(system)
    slowest = float(np.min(-np.linalg.eigvals(A).real))
    lags = np.linspace(0.0, 12.0 / slowest, n_lags)
    lam, V = np.linalg.eig(A)                       # e^{Aτ} Σ = V e^{Λτ} V⁻¹ Σ
    right = np.linalg.solve(V, Sigma)[:, q]
    R = np.real(np.exp(np.outer(lags, lam)) @ (V[q, :] * right))
    return Spectrum("exact", system, of, w, S, variance=Sigma[q, q], lags=lags,
                    correlation=R, estimate={"density": np.zeros_like(w), "relative": 0.0,
                                             "variance": 0.0, "correlation": 0.0,
                                             "assumes": "nothing: closed form"})


#: The state index of each signal.
SIGNALS_INDEX = {"x": 0, "y": 1}
