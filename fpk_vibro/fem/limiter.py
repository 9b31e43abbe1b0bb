"""The clipped high-order flux factors g of the positive generator (QUICK or van
Albada face values; part B of :mod:`fpk_vibro.fem.positivity`)."""
from __future__ import annotations

import numpy as np

__all__ = ["LIMITERS", "G_MAX", "limiter_factors"]


#: Transport schemes of the limited operator (module docstring, part B).
LIMITERS = ("quick", "van-albada")

#: Upper bound on the flux factors g (conditioning safeguard; part B).
G_MAX = 4.0


def _face_factor(P: np.ndarray, eps: float, scheme: str) -> np.ndarray:
    """Flux factors g ∈ [0, G_MAX] for transport towards increasing index (axis 0).

    The face flux out of node i is the face value p_{i+½} = g_i p_i, with
    a = p_{i+1} − p_i, b = p_i − p_{i−1}:

    - ``"quick"``: p_{i+½} = p_i + 3a/8 + b/8 (Leonard's κ = ½ upwind-biased
      quadratic, third-order face value), g clipped to [0, G_MAX] — clipping is
      the only limiting; it is what keeps the generator property.
    - ``"van-albada"``: p_{i+½} = p_i + s/2, s = ab(a + b)/(a² + b²) if ab > 0
      else 0; |s| ≤ 2 min(|a|, |b|), so the face value lies between p_i and
      p_{i+1} (TVD; g ≥ 0 whenever p ≥ 0).

    First order (g = 1) at the first and last node of each line.
    """
    g = np.ones_like(P)
    a = P[2:] - P[1:-1]
    b = P[1:-1] - P[:-2]
    with np.errstate(divide="ignore", invalid="ignore"):
        if scheme == "quick":
            half = 0.375 * a + 0.125 * b
        else:
            half = 0.5 * np.where(a * b > 0, a * b * (a + b) / (a * a + b * b + eps), 0.0)
        g[1:-1] = np.where(P[1:-1] > 0, 1.0 + half / P[1:-1], 1.0)
    return np.clip(g, 0.0, G_MAX)


def limiter_factors(p: np.ndarray, xnodes: np.ndarray, ynodes: np.ndarray, system,
                    scheme: str = "quick") -> tuple[np.ndarray, np.ndarray]:
    """(gx, gy) of module docstring part B for the nodal density ``p`` (nx, ny).

    ``gx`` weights the x-transport fluxes (upwind direction sign(y)), ``gy`` the
    Hamiltonian y-drift fluxes (direction −sign(a x + b x³)).  Always in
    [0, G_MAX], so :func:`positive_generator` stays a generator for any ``p``.
    """
    if scheme not in LIMITERS:
        raise ValueError(f"scheme must be one of {LIMITERS}; got {scheme!r}")
    eps = (1e-12 * float(np.max(np.abs(p)))) ** 2 + 1e-300
    yn = np.asarray(ynodes)
    xn = np.asarray(xnodes)
    gx = np.ones_like(p)
    gy = np.ones_like(p)
    pos, neg = yn > 0, yn < 0
    gx[:, pos] = _face_factor(p[:, pos], eps, scheme)
    gx[:, neg] = _face_factor(p[::-1, neg], eps, scheme)[::-1]
    G = system.a * xn + system.b * xn ** 3
    up, dn = G < 0, G > 0
    gy[up, :] = _face_factor(p[up, :].T, eps, scheme).T
    gy[dn, :] = _face_factor(p[dn, ::-1].T, eps, scheme).T[:, ::-1]
    return gx, gy
