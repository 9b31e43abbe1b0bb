"""The initial density of an FE transient on a discretisation's unknowns, and the
default time step (shared by :mod:`fpk_vibro.fem.transient`,
:mod:`fpk_vibro.fem.exponential` and :mod:`fpk_vibro.fem.coloured_transient`)."""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import scales
from ..initial import parse_initial
from ..model import VibroImpactSystem
from ..solution import Solution

__all__ = ["initial_vector", "default_dt"]


def initial_vector(disc: Any, initial: Any) -> np.ndarray:
    """Nodal values of the initial density, renormalised to ∫p = 1 (non-negative).

    ``disc``: anything with ``points`` (the unknowns' coordinates), ``unit`` (∫φ_i)
    and ``system`` (a :class:`~fpk_vibro.fem.discretisation.Discretisation`)."""
    x, y = disc.points
    if isinstance(initial, Solution):
        p0 = initial.pdf_joint(x, y)
    elif callable(initial) and not isinstance(initial, dict):
        p0 = np.asarray(initial(x, y), dtype=float)
        if p0.shape != x.shape or not np.all(np.isfinite(p0)) or np.any(p0 < 0):
            raise ValueError("initial: a callable p0(x, y) must return finite values >= 0 of "
                             "the shape of its arguments")
    else:
        init = parse_initial(initial, disc.system)
        (mx, my), (sx, sy) = init.mean, init.std
        # a mesh cannot hold a point mass: a zero std becomes one cell width
        hx = np.ptp(x) / max(1, np.unique(x).size - 1)
        hy = np.ptp(y) / max(1, np.unique(y).size - 1)
        p0 = (np.exp(-0.5 * ((x - mx) / max(sx, hx)) ** 2)
              * np.exp(-0.5 * ((y - my) / max(sy, hy)) ** 2))
    total = float(disc.unit @ p0)
    if not total > 0:
        raise ValueError("initial: the initial density has no mass on the mesh "
                         f"(|y| < {np.max(np.abs(y)):.3g}); move it inside or raise y_max")
    return p0 / total


def default_dt(system: VibroImpactSystem) -> float:
    """A twentieth of the system's period T0 (:func:`fpk_vibro.scales.period`)."""
    return scales.period(system) / 20.0
