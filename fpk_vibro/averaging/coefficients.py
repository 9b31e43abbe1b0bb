"""Averaged drift and diffusion of the energy envelope (paper Eqs. 20–21), any walls.

For one traversal of the orbit of energy H (x ∈ [x_lo, x_hi], |y| = sqrt(2H − 2G),
:mod:`fpk_vibro.orbits`):

    T  = 2 ∫ dx/|y|,   J1 = ∫ |y| dx,   J2 = ∫ |y| (2 D1 + 2 D2 x²) dx,
    K  = ∫ (D1 + D2 x²)/|y| dx,
    m  = (2/T)(−c J1 + K) − δ(H)/T,    σ² = (2/T) J2,

δ(H) the impact loss per quasi-period (:func:`fpk_vibro.orbits.energy_loss`).  At
the floor of a preloaded strip the orbit is a point at the wall x_w: T → 0 and the
limits m → D1 + D2 x_w², σ² → 0 are returned there.
"""
from __future__ import annotations

import numpy as np

from .._checks import invalid
from ..model import check_system
from ..model import VibroImpactSystem
from ..orbits import energy_floor, energy_loss, orbit_nodes, require_single_well
from .options import Options

__all__ = ["coefficients"]

def coefficients(system: VibroImpactSystem, H: np.ndarray, *, n_theta: int = 48
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quasi-period T(H), averaged drift m(H) and diffusion σ²(H) (paper Eqs. 20–21).

    Vectorised over ``H`` (H ≥ the strip's floor, 0 when it contains x = 0).  Agrees
    with adaptive ``scipy.integrate.quad`` to relative 1e-12 or better for
    n_theta = 48 (tests/test_averaging.py).

    Parameters
    ----------
    system : VibroImpactSystem
        G increasing in |x| on the strip (:func:`fpk_vibro.orbits.require_single_well`).
    H : array_like
        Energies, finite and ≥ :func:`fpk_vibro.orbits.energy_floor`.
    n_theta : int
        Gauss–Legendre nodes per orbit.

    Returns
    -------
    T, m, sigma2 : ndarray
        Arrays of the shape of ``H``.
    """
    check_system("averaging.coefficients", system)
    require_single_well(system)
    n_theta = Options.declared()["n_theta"].validate("n_theta", n_theta, "averaging.coefficients")
    try:
        H = np.asarray(H, dtype=float)
    except (TypeError, ValueError):
        raise invalid("averaging.coefficients", "H", "finite numbers >= 0", H) from None
    floor = energy_floor(system)
    if np.any(~np.isfinite(H)) or np.any(H < floor):
        raise invalid("averaging.coefficients", "H", f"finite numbers >= {floor:g}"
                      + ("" if floor == 0 else " (the lowest energy on the strip)"), H)
    o = orbit_nodes(system, H, n_theta)
    T = o.period
    v2 = o.v ** 2
    D = system.noise_intensity(o.x)
    J1 = o.integrate(v2)
    J2 = o.integrate(2.0 * v2 * D)
    K = o.integrate(D)
    with np.errstate(divide="ignore", invalid="ignore"):
        m = (2.0 / T) * (K - system.c * J1) - energy_loss(system, H) / T
        s2 = (2.0 / T) * J2
    if np.any(T == 0):                      # the floor of a preloaded strip: a point orbit
        lo, hi = system.x_bounds
        m = np.where(T == 0, system.noise_intensity(hi if hi < 0 else lo), m)
        s2 = np.where(T == 0, 0.0, s2)
    return T, m, s2
