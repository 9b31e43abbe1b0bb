"""The comparison of two FE densities: the L1 distance and the moment differences.

Both the error estimate (:mod:`fpk_vibro.fem.estimate`: a density against one level
richer) and the non-negative correction (:mod:`fpk_vibro.fem.nonnegative`: the
corrected density against the Galerkin one) measure what separates two densities
by :func:`difference`; :data:`JUDGED` and :func:`worst` say which of its entries an
accuracy goal judges.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..keys import JUDGED, moment_scale
from ..quadrature import gauss_grid

__all__ = ["KEYS", "JUDGED", "worst", "difference", "l1_difference"]

KEYS = ("L1", "E_H", "E_x2", "E_y2", "P_impact")

#: The entries ``rtol`` and ``under_resolved`` judge: the relative moments.  The L1
#: error of the density is reported but not aimed at: near the corners (x_w, 0) of
#: r < 1 and where D2 makes D(x) kink it converges slowly (measured: 2.5e-4 at Q4,
#: nx = 64, r = 0.9, D2 = 0.1, while the moments were within 2e-6).


def worst(est: dict[str, Any]) -> float:
    return max(float(est[k]) for k in JUDGED if k in est)


_gauss_grid = gauss_grid          # (the name the estimate's tests import)


def _matrix(basis, pts: np.ndarray):
    """Sparse (points × DOFs) values of a 1-D basis at ``pts`` (cells located by
    searchsorted: skfem's ``probes`` takes O(points × cells) memory on a MeshLine,
    1.1 GB at 6·10⁴ points on 2·10⁴ cells)."""
    import scipy.sparse as sp

    from .tensor_eval import TensorField, _locate
    nodes = np.asarray(basis.mesh.p[0], float)
    c, t = _locate(nodes, np.asarray(pts, float))
    vals = TensorField._values(basis, t)                 # (points, local)
    cols = basis.element_dofs[:, c].T                    # (points, local)
    rows = np.repeat(np.arange(pts.size), vals.shape[1])
    return sp.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=(pts.size, basis.N))


def l1_difference(a, b) -> float:
    """∫|p_a − p_b| over the strip of the richer ``b`` (tensor Gauss rule on b's grid,
    or b's element quadrature on other meshes)."""
    if a._tensor is not None and b._tensor is not None:
        n = max(a.degree, b.degree) + 2
        xq, wx = _gauss_grid(np.asarray(b._tensor[0], float), n)
        yq, wy = _gauss_grid(np.asarray(b._tensor[1], float), n)
        mats = []
        for s in (a, b):
            xb, yb, P = s._tensor_factors()
            mats.append((_matrix(xb, np.clip(xq, s._x0, s._x1)),
                         _matrix(yb, np.clip(yq, -s.y_max, s.y_max)), P))
        total = 0.0
        step = max(1, 2_000_000 // max(yq.size, 1))
        for i in range(0, xq.size, step):
            sl = slice(i, i + step)
            va, vb = (np.asarray(By @ np.asarray(Bx[sl] @ P).T).T for Bx, By, P in mats)
            total += float(wx[sl] @ np.abs(va - vb) @ wy)
        return total
    basis = b.basis
    xy = np.asarray(basis.global_coordinates())
    vb = basis.interpolate(b.dofs).value
    va = a.pdf_joint(xy[0].ravel(), xy[1].ravel()).reshape(vb.shape)
    return float(np.sum(np.abs(va - vb) * basis.dx))


def _moments(sol) -> dict[str, float]:
    m = sol.moments()
    return {k: m[k] for k in ("E_H", "E_x2", "E_y2", "P_impact") if k in m}


def difference(a, b) -> dict[str, float]:
    """{"L1", "E_H", "E_x2", "E_y2"[, "P_impact"]}: ∫|p_a − p_b| and the relative
    differences of the moments (P_impact absolute where P⁺ < 1e-3)."""
    out = {"L1": l1_difference(a, b)}
    ma, mb = _moments(a), _moments(b)
    for k, vb in mb.items():
        scale = moment_scale(k, vb)
        out[k] = abs(ma[k] - vb) / scale if scale > 0 else abs(ma[k] - vb)
    return out
