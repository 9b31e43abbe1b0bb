"""Stochastic averaging of the energy envelope (DESIGN §2, paper §3).

- :func:`coefficients` — averaged drift m(H), diffusion σ²(H), quasi-period T(H);
- :func:`stationary`   — the closed-form stationary density → :class:`AveragedSolution`;
- :func:`transient`    — the 1-D averaged FPK in time → :class:`EnergyGridSolution` per time.
"""
from .coefficients import coefficients
from .grid_solution import EnergyGridSolution
from .options import Options
from .stationary import AveragedSolution, stationary
from .transient import transient

__all__ = ["Options", "coefficients", "stationary", "transient", "AveragedSolution", "EnergyGridSolution"]
