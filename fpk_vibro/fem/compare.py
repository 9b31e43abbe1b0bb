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

__all__ = ["KEYS", "IMPACT_KEYS", "JUDGED", "AIMED", "worst", "decided_by", "difference", "l1_difference"]

KEYS = ("L1", "E_H", "E_x2", "E_y2", "P_impact")

#: What an FE ``rtol`` bounds (issue 31): the relative moments (:data:`JUDGED`) and
#: the L1 error of the density, which ∫p = 1 makes relative too.  The density is
#: the answer of an FPK solver, the moments its summaries: on the exact double well
#: the moments met rtol = 1e-5 at Q3, nx = 16, with an L1 error of 6e-3.  Near the
#: corners (x_w, 0) of r < 1 the L1 error converges more slowly than the moments
#: (measured: order 1.3–2 in nx at Q4 with wall grading 2, the moments 3–5).
AIMED = ("L1",) + JUDGED


def worst(est: dict[str, Any], keys: tuple[str, ...] = JUDGED) -> float:
    """The largest of the entries ``keys`` of an estimate (default: the moments;
    :data:`AIMED` for what an rtol bounds)."""
    return max(float(est[k]) for k in keys if k in est)


def decided_by(est: dict[str, Any], keys: tuple[str, ...] = AIMED) -> str:
    """The key of the largest entry among ``keys``: the quantity that decided."""
    return max((k for k in keys if k in est), key=lambda k: float(est[k]))


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


#: The impact statistics an estimate carries besides :data:`KEYS` (relative): the
#: total impact rate, the mean time between impacts (1/rate: Kac's identity, which
#: the FE inter-impact solve keeps exactly, so it shares the rate's error) and the
#: mean energy one impact dissipates (the largest over the walls).
IMPACT_KEYS = ("impact_rate", "mean_inter_impact_time", "impact_energy")


def _impact_summary(sol) -> tuple[float, list[float]] | None:
    if not sol.system.walls:
        return None
    imp = sol.impacts()
    rate = sum(v["rate"] for v in imp.values())
    return rate, [v["energy_rate"] / v["rate"] if v["rate"] > 0 else 0.0
                  for v in imp.values()]


def difference(a, b) -> dict[str, float]:
    """{"L1", "E_H", "E_x2", "E_y2"[, "P_impact"]}: ∫|p_a − p_b| and the relative
    differences of the moments (P_impact absolute where P⁺ < 1e-3); with walls also
    :data:`IMPACT_KEYS` (relative)."""
    out = {"L1": l1_difference(a, b)}
    ma, mb = _moments(a), _moments(b)
    for k, vb in mb.items():
        scale = moment_scale(k, vb)
        out[k] = abs(ma[k] - vb) / scale if scale > 0 else abs(ma[k] - vb)
    ia, ib = _impact_summary(a), _impact_summary(b)
    if ia is not None and ib is not None:
        rel = abs(ia[0] - ib[0]) / ib[0] if ib[0] > 0 else 0.0
        out["impact_rate"] = out["mean_inter_impact_time"] = rel
        out["impact_energy"] = max((abs(ea - eb) / eb if eb > 0 else 0.0)
                                   for ea, eb in zip(ia[1], ib[1]))
    return out
