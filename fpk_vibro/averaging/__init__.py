"""Stochastic averaging of the energy envelope (DESIGN §2, paper §3).

- :func:`coefficients` — averaged drift m(H), diffusion σ²(H), quasi-period T(H);
- :func:`stationary`   — the closed-form stationary density → :class:`AveragedSolution`;
- :func:`transient`    — the 1-D averaged FPK in time → one solution per time.
"""
from .coefficients import coefficients
from .stationary import AveragedSolution, stationary

__all__ = ["coefficients", "stationary", "AveragedSolution"]
