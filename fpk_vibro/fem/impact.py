"""The impact coupling B± of the conservative weak form.

Theory: docs/theory.md, §Impact coupling.

At a wall x = x_w with outflow direction ``side`` (+1 at the right wall, −1 at the
left one) the impact condition p(x_w, −r v) = p(x_w, v)/r² turns the boundary term
into

    B(p, q) = ∫_{side·v > 0} |v| p(x_w, v) [ q(x_w, v) − q(x_w, −r v) ] dv,

so that ∫ ∂p/∂t q = ∫ J·∇q − B₊ − B₋, and B(p, 1) = 0: mass is conserved for every
0 ≤ r ≤ 1 (r = 0 re-injects at v = 0).

Discretisation.  The integral runs over the outflow half only.  Its integrand is
a polynomial times q(x_w, −r v), which is only piecewise polynomial in v: it has a
kink wherever −r v crosses a mesh node of the inflow half.  The outflow half is
therefore split at the wall's nodes *and* at the pre-images v = −y_n / r of the
inflow-half nodes y_n; on that 1-D mesh a Gauss rule from skfem is exact for the
polynomial degrees used.  With the quadrature points v_k, weights w_k,

    B[i, j] = Σ_k w_k |v_k| φ_j(x_w, v_k) [ φ_i(x_w, v_k) − φ_i(x_w, −r v_k) ],

i.e. ``B = (P − P_r)ᵀ W P`` with P, P_r the point-evaluation ("probe") matrices
of the basis at the points and at the mapped points.  The test functions are
evaluated at the mapped points by ``Basis.probes``; nothing is matched node to node
and no row is dropped.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import skfem

from .mesh import StripEnd

__all__ = ["wall_quadrature", "coupling_matrix", "wall_matrix_1d"]


def wall_quadrature(wall: StripEnd, y_wall_nodes: np.ndarray, y_max: float,
                    intorder: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quadrature on the outflow half of ``wall``, split at the mapped nodes.

    Parameters
    ----------
    wall : StripEnd
    y_wall_nodes : ndarray
        y-coordinates of the mesh nodes on the wall.
    y_max : float
        Half-height of the strip.
    intorder : int
        Exactness degree of the Gauss rule on each piece.

    Returns
    -------
    y, y_mapped, weight : ndarray
        Quadrature points v_k, their images −r v_k, and w_k |v_k|.
    """
    s = wall.side * np.asarray(y_wall_nodes, dtype=float)     # outflow if s > 0
    bp = [s[s >= 0], [0.0, y_max]]
    if wall.r > 0:
        pre = -s[s < 0] / wall.r
        bp.append(pre[pre < y_max])
    bp = np.unique(np.concatenate(bp))
    keep = np.concatenate([[True], np.diff(bp) > 1e-12 * y_max])
    bp = bp[keep]
    bp[-1] = y_max
    qb = skfem.CellBasis(skfem.MeshLine(bp), skfem.ElementLineP0(), intorder=intorder)
    sq = np.asarray(qb.global_coordinates())[0].ravel()
    wq = qb.dx.ravel()
    y = wall.side * sq
    return y, -wall.r * y, wq * sq


def coupling_matrix(basis: skfem.CellBasis, wall: StripEnd, y_max: float,
                    intorder: int) -> sp.csr_matrix:
    """The matrix B of one wall on a general 2-D mesh (module docstring).

    The generator gets ``L -= B``.
    """
    p = basis.mesh.p
    on_wall = np.abs(p[0] - wall.x) <= 1e-12 * max(1.0, abs(wall.x))
    # a mesh whose height varies along x (e.g. fitted to a level set) ends lower here
    y_max = min(y_max, float(np.max(np.abs(p[1, on_wall]))))
    y, ym, w = wall_quadrature(wall, p[1, on_wall], y_max, intorder)
    xw = np.full_like(y, wall.x)
    try:
        P = basis.probes(np.vstack([xw, y]))
        Pr = basis.probes(np.vstack([xw, ym]))
    except ValueError:
        # skfem's point search can miss points exactly on a boundary edge of a
        # non-rectangular cell: a hair inside (the trace is continuous)
        xw = xw - wall.side * 1e-12 * max(1.0, abs(wall.x))
        P = basis.probes(np.vstack([xw, y]))
        Pr = basis.probes(np.vstack([xw, ym]))
    return ((P - Pr).T @ sp.diags(w) @ P).tocsr()


def wall_matrix_1d(ybasis: skfem.CellBasis, wall: StripEnd, y_max: float,
                   intorder: int) -> sp.csr_matrix:
    """The y-factor C of one wall for Kronecker assembly.

    On a tensor-product mesh the trace of φ_(i,j) = ψ_i(x) χ_j(y) on the wall is
    δ_(i,w) χ_j(y) (Lagrange basis), so B = (e_w e_wᵀ) ⊗ C with
    C[k, l] = Σ_q w_q |v_q| χ_l(v_q) [χ_k(v_q) − χ_k(−r v_q)].
    """
    y, ym, w = wall_quadrature(wall, ybasis.mesh.p[0], y_max, intorder)
    P = ybasis.probes(y[None, :])
    Pr = ybasis.probes(ym[None, :])
    return ((P - Pr).T @ sp.diags(w) @ P).tocsr()
