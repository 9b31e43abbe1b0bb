"""Composite Gauss rules on the intervals of a 1-D grid (shared by the methods'
comparisons of densities)."""
from __future__ import annotations

import numpy as np

__all__ = ["gauss_grid"]


def gauss_grid(nodes: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights of the n-point Gauss–Legendre rule on every interval
    [nodes[i], nodes[i+1]], flattened interval by interval."""
    t, w = np.polynomial.legendre.leggauss(n)
    a, b = nodes[:-1, None], nodes[1:, None]
    pts = 0.5 * (a + b) + 0.5 * (b - a) * t[None, :]
    wts = 0.5 * (b - a) * w[None, :]
    return pts.ravel(), wts.ravel()
