"""The exact Gaussian density of the linear oscillator without walls.

For a = ω0² > 0, b = 0, D2 = 0 and no wall, the state s = (x, y) (white noise) or
(x, y, ζ) (Ornstein–Uhlenbeck external noise, :mod:`fpk_vibro.noise`) is a linear SDE
ds = A s dt + B dW, so its stationary density is the centred Gaussian whose covariance
Σ solves the continuous Lyapunov equation A Σ + Σ Aᵀ + B Bᵀ = 0 (docs/theory.md,
§Coloured noise): with white noise Σ = diag(D1/(a c), D1/c); with coloured noise the
force's memory lowers both variances.

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
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import solve_continuous_lyapunov

from ._checks import InputError
from .model import VibroImpactSystem

__all__ = ["stationary_covariance", "drift_and_noise"]


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
