"""Degrees 3 and 4 on the structured tensor mesh (issue 23, §4).

The space is Q_k on each rectangle, k = 3, 4: tensor products ψ_i(x) χ_j(y) of 1-D
Lagrange bases of degree k, so the operator is the Kronecker assembly of
:func:`fpk_vibro.fem.generator.assemble_tensor` with 1-D element matrices that
skfem assembles exactly by Gauss quadrature of order 2k + 3 (the coefficients are
polynomials of degree ≤ 3: y, c y + a x + b x³, D1 + D2 x²).

skfem's own arbitrary-degree line and quad elements (``ElementLinePp``,
``ElementQuadP``) are hierarchical (integrated Legendre): their coefficients are
not point values, so the nodal minimum, the DOF locations (nested dissection,
``Discretisation.points``) and the wall trace δ_(i,w) would all need a change of
basis.  :class:`ElementLineGLL` is the nodal Lagrange element of degree k written
as a skfem :class:`~skfem.element.ElementH1` (skfem then does the mapping,
quadrature, assembly and point evaluation ``probes``), with its interior nodes at
the Gauss–Lobatto points of the cell.  The space is the same as with equispaced
nodes — so is the discrete density, in exact arithmetic — but the Lobatto nodes keep
the basis better conditioned (Lebesgue constant 1.50 / 1.64 for k = 3 / 4 against
1.63 / 2.21 equispaced; 2.0 against 10.9 at k = 8: a small gain at these k that
grows with k) and the nodal values are the density at points that cluster like the
cell's quadrature.

No 2-D skfem element matches: an H1 quad element with k − 1 ≥ 2 nodal DOFs per
edge needs the edge orientation shared between neighbours, which skfem's quads do
not give.  The :class:`~fpk_vibro.fem.FEMSolution` of degree 3 or 4 therefore
keeps p_h as the nx·k + 1 by ny·k + 1 array of its Kronecker coefficients and
evaluates it with the 1-D bases only, by the tensor path every structured-mesh
density uses (:mod:`fpk_vibro.fem.tensor_eval`: points, moments, level split).
"""
from __future__ import annotations

import numpy as np
import skfem
from skfem.element import ElementH1
from skfem.refdom import RefLine

__all__ = ["ElementLineGLL", "lobatto_nodes", "l1_error", "HIGH_DEGREES"]

#: Degrees served by this module (tensor mesh only).
HIGH_DEGREES = (3, 4)


def lobatto_nodes(k: int) -> np.ndarray:
    """The k + 1 Gauss–Lobatto nodes on [0, 1] (ends included, increasing)."""
    P = np.polynomial.legendre.Legendre.basis(k).deriv()
    inner = np.sort(np.real(P.roots())) if k > 1 else np.array([])
    return np.concatenate([[0.0], 0.5 * (inner + 1.0), [1.0]])


class ElementLineGLL(ElementH1):
    """1-D nodal Lagrange element of degree ``k`` with Gauss–Lobatto nodes.

    DOF order as skfem's line elements: the two vertices (0, 1), then the k − 1
    interior nodes in increasing position.
    """

    nodal_dofs = 1
    refdom = RefLine

    def __init__(self, k: int) -> None:
        if k < 1:
            raise ValueError(f"degree must be >= 1; got {k}")
        t = lobatto_nodes(k)
        self.k = k
        self.maxdeg = k
        self.interior_dofs = k - 1
        self.dofnames = ["u"] * k
        nodes = np.concatenate([[t[0], t[-1]], t[1:-1]])
        self.doflocs = nodes[:, None]
        # monomial coefficients of each Lagrange polynomial: V c = I
        V = np.vander(nodes, k + 1, increasing=True)
        self._coef = np.linalg.solve(V, np.eye(k + 1))          # column i: ℓ_i
        self._dcoef = self._coef[1:] * np.arange(1, k + 1)[:, None]

    def lbasis(self, X, i):
        if not 0 <= i <= self.k:
            self._index_error()
        x = X[0]
        phi = np.polynomial.polynomial.polyval(x, self._coef[:, i])
        dphi = np.polynomial.polynomial.polyval(x, self._dcoef[:, i])
        return phi, np.array([dphi])


def l1_error(sol, density, box: tuple[float, float, float, float] | None = None,
             npts: int = 8) -> float:
    """∫ |p_h − p| over ``box`` = (x0, x1, y0, y1) (default: the strip) for a tensor
    FEMSolution (any degree), ``p = density(x, y)`` normalised to 1 on the box.

    Composite Gauss rule with ``npts`` points on every piece between the mesh lines
    and the box edges (p_h is a polynomial on each piece; ``npts`` = 8 integrates
    p_h of degree ≤ 4 and the smooth exact density to round-off at the meshes
    used); p_h is 0 outside the strip.  Values by the 1-D bases: Bx · P · Byᵀ.
    """
    xb, yb, P = sol._tensor_factors()
    xs, ys = (np.asarray(a, float) for a in sol._tensor)
    if box is None:
        box = (xs[0], xs[-1], ys[0], ys[-1])
    t, w = np.polynomial.legendre.leggauss(npts)

    def rule(nodes, lo, hi):
        br = np.unique(np.clip(np.concatenate([nodes, [lo, hi]]), lo, hi))
        mid, half = 0.5 * (br[1:] + br[:-1]), 0.5 * np.diff(br)
        q = (mid[:, None] + half[:, None] * t).ravel()
        return q, (half[:, None] * w).ravel()

    xq, wx = rule(xs, box[0], box[1])
    yq, wy = rule(ys, box[2], box[3])
    inx = (xq >= xs[0]) & (xq <= xs[-1])
    iny = (yq >= ys[0]) & (yq <= ys[-1])
    ph = np.zeros((xq.size, yq.size))
    Bx = xb.probes(xq[inx][None, :])
    By = yb.probes(yq[iny][None, :])
    ph[np.ix_(inx, iny)] = (Bx @ (By @ P.T).T)
    X, Y = np.meshgrid(xq, yq, indexing="ij")
    W = wx[:, None] * wy[None, :]
    p = density(X, Y)
    p = p / float(np.sum(p * W))
    return float(np.sum(np.abs(ph - p) * W))
