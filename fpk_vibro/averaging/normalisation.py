"""The closed form of the stationary averaged density: Φ on its panels, Z and moments.

:func:`normalise` builds Φ (:mod:`fpk_vibro.averaging.regimes`), the normalisation
Z and the moments, and refuses a density with a power-law tail.  It is the work of
:func:`fpk_vibro.averaging.stationary` without the solution object, so the option
check (``Options.validate_for(probe=True)``) can refuse such a system before a run
without importing the solver.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..model import VibroImpactSystem
from .regimes import Layout, Regime, build_all, phi_rate

__all__ = ["Normalised", "normalise"]


class Normalised(NamedTuple):
    """Φ's regimes (amplitude regime first), Z, the end of the panels and the moments."""
    regimes: tuple[Regime, ...]
    Z: float
    H_end: float
    f_end: float
    moments: dict[str, float]


def normalise(system: VibroImpactSystem, n_theta: int, n_panel: int,
              phi_cut: float) -> Normalised:
    """Φ, Z and the moments of the stationary averaged density of ``system``.

    Raises
    ------
    ValueError
        Where the density has a power-law tail (its mass or moments do not converge).
    """
    low, highs, nodes, H_end, n_low = build_all(system, Layout(system), n_theta, n_panel,
                                                phi_cut)
    f_end = float(phi_rate(system, np.array([H_end]), n_theta)[0][0])

    H = np.concatenate([n[0] for n in nodes])
    w = np.concatenate([n[1] * np.exp(-n[2]) for n in nodes])
    sums = {k: np.concatenate([n[3][k] for n in nodes]) for k in nodes[0][3]}
    Z = float(np.sum(w * sums["T"]))
    mom = {"E_H": float(np.sum(w * sums["T"] * H)) / Z,
           "E_x2": float(np.sum(w * sums["x2"])) / Z,
           "E_y2": float(np.sum(w * sums["y2"])) / Z,
           "E_x4": float(np.sum(w * sums["x4"])) / Z,
           "E_y4": float(np.sum(w * sums["y4"])) / Z}
    # a power-law tail reaches Φ ≥ phi_cut only at astronomic H: its last panel
    # then still carries mass (or moment weight), which a light tail never does
    last = nodes[-1]
    w_last = last[1] * np.exp(-last[2]) * last[3]["T"]
    for name, g in (("the density", 1.0), ("E_H", last[0]), ("E_y4", last[3]["y4"] / last[3]["T"])):
        share = float(np.sum(w_last * g)) / (Z * (mom.get(name, 1.0)))
        if not share < 1e-10:
            raise ValueError(
                f"averaging: {name} does not converge: the averaged density has a power-law "
                f"tail (the last energy panel, H ≈ {float(last[0][-1]):.3g}, holds a share "
                f"{share:.2g}); parametric noise D2={system.D2} is too strong for damping "
                f"c={system.c} here")
    if system.has_barrier:
        k0 = sum(n[0].size for n in nodes[:n_low])
        mom["P_impact"] = float(np.sum(w[k0:] * sums["T"][k0:])) / Z
    return Normalised((low, *highs), Z, H_end, f_end, mom)
