"""Stochastic averaging of the energy envelope, for any walls.

Theory: docs/theory.md, §Averaging to §Averaged transient (Section 3 of the paper).

Applies when the potential increases with |x| on the strip x_L < x < x_R (one orbit
per energy level; :func:`fpk_vibro.orbits.require_single_well` names the reason
otherwise): symmetric or asymmetric walls, each with its own r, a wall at or beyond
the equilibrium (docs/averaging_walls.md).

- :func:`coefficients` — averaged drift m(H), diffusion σ²(H), quasi-period T(H);
- :func:`stationary`   — the closed-form stationary density → :class:`AveragedSolution`;
- :func:`transient`    — the 1-D averaged FPK in time → :class:`EnergyGridSolution` per time;
- :func:`spectrum`     — the energy-envelope spectrum S(ω) and correlation R(τ).
"""
from .coefficients import coefficients
from .grid_solution import EnergyGridSolution
from .options import Options
from .stationary import AveragedSolution, stationary
from .transient import transient
from .first_passage import first_passage
from .spectrum import spectrum
from .inter_impact import estimate as _inter_impact_estimate
from .inter_impact import inter_impact as _inter_impact
from .stationary import INTER_IMPACT as _INTER_IMPACT

_INTER_IMPACT.update(law=_inter_impact, estimate=_inter_impact_estimate)

__all__ = ["Options", "coefficients", "stationary", "transient", "first_passage", "spectrum",
           "AveragedSolution", "EnergyGridSolution"]
