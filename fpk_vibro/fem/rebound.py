"""The impact map of a strip end for the FE coupling: rebound speed φ(u) = u r(u) and
its inverse, for a number r or a law r(u) (:mod:`fpk_vibro.restitution`).

φ is strictly increasing for every law the package accepts (the law's own check), so
its inverse is found by bisection, vectorised over all speeds at once, to adjacent
floating-point numbers (the coupling needs the pre-images of the mesh nodes, a few
hundred speeds per wall, once per assembly: measured well under a millisecond per
wall).  A number keeps the arithmetic of the constant coupling (``r·u``, ``w/r``), so a
law constant in u given as a number is the number bit for bit; one given as a law
(:attr:`fpk_vibro.restitution.Restitution.constant`) is turned into the number by
:func:`fpk_vibro.fem.mesh.wall_restitutions`.

Examples
--------
>>> import numpy as np
>>> from fpk_vibro import Restitution
>>> law = Restitution.tanh(0.9, 0.2, 1.0)
>>> u = np.array([0.1, 1.0, 3.0])
>>> bool(np.allclose(preimage(law, rebound(law, u), 5.0), u, rtol=1e-14))
True
>>> float(preimage(0.5, np.array([0.2]), 1.0)[0])
0.4
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["rebound", "preimage", "is_elastic", "kinks"]


def _law(r: Any):
    return None if isinstance(r, (int, float, np.floating)) else r


def rebound(r: Any, u: np.ndarray) -> np.ndarray:
    """φ(u) = u r(u) at speeds ``u`` ≥ 0 (``r`` a number or a law)."""
    u = np.asarray(u, dtype=float)
    law = _law(r)
    return float(r) * u if law is None else law.rebound(u)


def preimage(r: Any, w: np.ndarray, u_max: float) -> np.ndarray:
    """u in [0, ``u_max``] with φ(u) = ``w`` (``w`` ≤ φ(u_max); larger ``w`` give
    ``u_max``).  A number r > 0: w / r; a law: bisection to adjacent floats."""
    w = np.asarray(w, dtype=float)
    law = _law(r)
    if law is None:
        return w / float(r)
    lo = np.zeros_like(w)
    hi = np.where(w > 0, float(u_max), 0.0)
    for _ in range(2000):       # 52 + log2(u_max/u) halvings reach adjacent floats
        mid = 0.5 * (lo + hi)
        active = (mid > lo) & (mid < hi)
        if not np.any(active):
            break
        below = law.rebound(mid) < w
        lo = np.where(active & below, mid, lo)
        hi = np.where(active & ~below, mid, hi)
    return np.where(law.rebound(hi) - w <= w - law.rebound(lo), hi, lo)


def is_elastic(r: Any) -> bool:
    """True when every impact keeps its speed (r ≡ 1)."""
    law = _law(r)
    return float(r) == 1.0 if law is None else law.bounds() == (1.0, 1.0)


def kinks(r: Any, u_max: float) -> np.ndarray:
    """Speeds in (0, ``u_max``) where φ is not smooth (a table's knots): breakpoints
    of the coupling's quadrature."""
    law = _law(r)
    if law is None or law.kind != "table":
        return np.empty(0)
    u = np.asarray(law.speeds, dtype=float)
    return u[(u > 0) & (u < u_max)]
