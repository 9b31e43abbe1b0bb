"""The marginal densities of an FE density: p(x), p(y) and p(H).

- ``pdf_x``, ``pdf_y``: on a tensor-product quadrilateral mesh exactly,
  p(x) = Σ_i ψ_i(x) Σ_j P_ij ∫χ_j dy (and likewise in y); on other meshes by a
  composite Gauss rule across the strip split at the mesh's node coordinates.
- ``pdf_energy`` (coarea formula): since ∂H/∂y = y,

      p(H) = ∫ Σ_± p(x, ±√(2H − 2G(x))) / √(2H − 2G(x)) dx   over {G(x) < H} ∩ strip,

  and with x = A sin θ (A the amplitude; docs/theory.md, §Energy and orbits) the
  integrand is smooth:
  dx / √(2H − 2G) = dθ / √(a + b A² (1 + sin²θ)/2); θ runs over the part of
  [−π/2, π/2] inside the strip; Gauss–Legendre in θ.  Needs a monotone G on each
  side (a > 0); otherwise NotImplementedError.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import skfem

__all__ = ["marginal_x", "marginal_y", "energy_density"]

#: Gauss points in θ of the coarea integral of p(H).
NTHETA = 96


def marginal_x(sol, x: Any) -> np.ndarray:
    """p(x) = ∫ p_h(x, y) dy of ``sol`` (exact on tensor quad meshes; module docstring)."""
    x = np.asarray(x, float)
    if sol._tensor is not None:
        xb, yb, P = sol._tensor_factors()
        xf = x.ravel()
        inside = (xf >= sol._x0) & (xf <= sol._x1)
        out = np.zeros(xf.size)
        if inside.any():
            out[inside] = sol._field().line(xb, xb.mesh.p[0], xf[inside],
                                             P @ sol._line_integral(yb))
        return sol._clip(out.reshape(x.shape))
    nodes, w = _composite(np.unique(sol.mesh.p[1]))
    vals = sol._eval(x[..., None], nodes)
    return sol._clip(vals @ w)


def marginal_y(sol, y: Any) -> np.ndarray:
    """p(y) = ∫ p_h(x, y) dx of ``sol`` (exact on tensor quad meshes; module docstring)."""
    y = np.asarray(y, float)
    if sol._tensor is not None:
        xb, yb, P = sol._tensor_factors()
        yf = y.ravel()
        inside = np.abs(yf) <= sol.y_max
        out = np.zeros(yf.size)
        if inside.any():
            out[inside] = sol._field().line(yb, yb.mesh.p[0], yf[inside],
                                             P.T @ sol._line_integral(xb))
        return sol._clip(out.reshape(y.shape))
    nodes, w = _composite(np.unique(sol.mesh.p[0]))
    vals = sol._eval(nodes, y[..., None])
    return sol._clip(vals @ w)


def _composite(breaks: np.ndarray, npts: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the composite Gauss rule split at ``breaks``."""
    qb = skfem.CellBasis(skfem.MeshLine(breaks), skfem.ElementLineP0(),
                         intorder=2 * npts - 1)
    return np.asarray(qb.global_coordinates())[0].ravel(), qb.dx.ravel()


def energy_density(sol, H: Any) -> np.ndarray:
    """Density of H from p_h of ``sol`` by the coarea formula (module docstring)."""
    s = sol.system
    if not sol.has_energy_density(s):
        raise NotImplementedError("pdf_energy of a FEMSolution needs a > 0, or a = 0 "
                                  "< b (G monotone on each side)")
    H = np.asarray(H, float)
    Hf = H.ravel()
    out = np.zeros(Hf.size)
    pos = Hf > 0
    A = s.amplitude(Hf[pos])
    ok = np.isfinite(A) & (A > 0)
    idx = np.flatnonzero(pos)[ok]
    A = A[ok]
    if idx.size:
        t, wt = np.polynomial.legendre.leggauss(NTHETA)
        lo = np.arcsin(np.clip(sol._x0 / A, -1, 1))
        hi = np.arcsin(np.clip(sol._x1 / A, -1, 1))
        th = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * t[None, :]
        jac = 0.5 * (hi - lo)[:, None] * wt[None, :]
        xq = A[:, None] * np.sin(th)
        yq = np.sqrt(np.maximum(2.0 * (Hf[idx][:, None] - s.potential(xq)), 0.0))
        den = np.sqrt(s.a + 0.5 * s.b * A[:, None] ** 2 * (1.0 + np.sin(th) ** 2))
        vals = sol._eval(xq, yq) + sol._eval(xq, -yq)
        out[idx] = np.sum(vals * jac / den, axis=1)
    return sol._clip(out.reshape(H.shape))
