"""Assembly of the FPK generator L and the mass matrix M.

Theory: docs/theory.md, §Impact coupling and §Assembly and solve.

The semi-discrete FPK is ``M dp/dt = L p`` with

    (L)_{ij} = ∫ J(φ_j)·∇φ_i − B₊(φ_j, φ_i) − B₋(φ_j, φ_i),     (M)_{ij} = ∫ φ_j φ_i

(rows: test functions).  Since B±(p, 1) = 0 and ∫ J(p)·∇1 = 0, every column of L
sums to zero: ``1ᵀ L = 0`` is discrete mass conservation, and the stationary density
is the null vector of L.  A transient solver reuses (L, M) unchanged.

Two assemblers give the same matrices:

- :func:`assemble` — general skfem 2-D assembly on any mesh of the strip
  (quadrilaterals or triangles, degree 1 or 2);
- :func:`assemble_tensor` — on a tensor-product mesh each term of J·∇q is
  (function of x) × (function of y), so L is a short sum of Kronecker products of
  1-D matrices: far fewer quadrature points and no 2-D element loop.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem

from ..model import VibroImpactSystem
from . import forms
from .impact import coupling_matrix, wall_matrix_1d
from .kron import kron_sum
from .mesh import Domain, StripEnd, ends_at_wall, wall_restitutions

__all__ = ["assemble", "assemble_tensor", "TensorOperator", "mesh_domain",
           "assemble_tensor_bases", "tensor_index", "tensor_to_basis", "kron_sum",
           "quadrature_order", "element_for", "tensor_terms"]


def quadrature_order(degree: int) -> int:
    """Gauss exactness used: 2k + 3 integrates the cubic restoring term exactly
    against Q_k / P_k products (coefficients cubic in x; docs/theory.md,
    §Assembly and solve)."""
    return 2 * degree + 3


def element_for(mesh: skfem.Mesh, degree: int) -> skfem.Element:
    """Lagrange element of ``degree`` (1 or 2) for a quad or triangle mesh."""
    if isinstance(mesh, skfem.MeshQuad1):
        return {1: skfem.ElementQuad1(), 2: skfem.ElementQuad2()}[degree]
    if isinstance(mesh, skfem.MeshTri1):
        return {1: skfem.ElementTriP1(), 2: skfem.ElementTriP2()}[degree]
    raise ValueError(f"mesh: a linear quadrilateral or triangle mesh is required, "
                     f"got {type(mesh).__name__}")


def mesh_domain(system: VibroImpactSystem, mesh: skfem.Mesh) -> Domain:
    """The walls of the strip covered by ``mesh`` (docs/theory.md, §Walls).

    Each wall of the system carries its own r; a truncated side without a wall is
    an elastic wall (r = 1), and so is an edge between the cut and a wall beyond the
    density's support (:func:`fpk_vibro.fem.mesh.beyond_support`).  Raises ValueError
    if a wall is not on the mesh edge.
    """
    x0, x1 = float(mesh.p[0].min()), float(mesh.p[0].max())
    y0, y1 = float(mesh.p[1].min()), float(mesh.p[1].max())
    tol = 1e-9 * max(1.0, x1 - x0)
    rs, beyond = list(wall_restitutions(system)), []
    for k, (side, edge, wall) in enumerate((("left", x0, system.left),
                                            ("right", x1, system.right))):
        if wall is not None and abs(edge - wall.position) > tol:
            if not ends_at_wall(system, side, edge, tol):
                raise ValueError(f"mesh: its {side} edge x = {edge} is not the {side} wall "
                                 f"x = {wall.position}")
            rs[k] = 1.0          # the elastic cut of a wall beyond the support
            beyond.append(f"the {side} wall x = {wall.position:g} lies beyond the "
                          f"density's support: the mesh ends at x = {edge:.4g} with an "
                          "elastic end, as without that wall")
    if abs(y0 + y1) > 1e-9 * max(1.0, y1):
        raise ValueError(f"mesh: y-range [{y0}, {y1}] must be symmetric about y = 0")
    if not np.any(np.abs(mesh.p[1]) <= 1e-12 * y1):
        raise ValueError("mesh: y = 0 must be a mesh line (the walls' outflow and inflow "
                         "halves must be unions of cell edges)")
    return Domain(x0, x1, y1, (StripEnd(x0, rs[0], -1), StripEnd(x1, rs[1], +1)),
                  tuple(beyond))


def assemble(system: VibroImpactSystem, basis: skfem.CellBasis, *,
             only_walls: bool = False) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """General 2-D assembly of (L, M) on any strip mesh (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
    basis : skfem.CellBasis
        Scalar Lagrange basis on a mesh of the strip (walls at its x-extremes).
    only_walls : bool
        Couple only the system's walls, not the elastic walls of truncated ends (for
        a caller that fixes the values there, e.g. an absorbing end).

    Returns
    -------
    L, M : scipy.sparse.csr_matrix
        Generator (∂p/∂t = L p weakly; docs/theory.md, §Impact coupling) and mass
        matrix, basis DOF order.
    """
    dom = mesh_domain(system, basis.mesh)
    s = system
    L = skfem.asm(forms.transport_x, basis)
    if s.a != 0 or s.b != 0:
        L = L + skfem.asm(forms.restoring, basis, a=s.a, b=s.b)
    if s.c != 0:
        L = L + skfem.asm(forms.damping, basis, c=s.c)
    L = L + skfem.asm(forms.diffusion_external, basis, D1=s.D1)
    if s.D2 != 0:
        L = L + skfem.asm(forms.diffusion_parametric, basis, D2=s.D2)
    deg = _degree(basis.elem)
    real = {"left": system.left, "right": system.right}
    for wall in dom.walls:
        if only_walls and real["left" if wall.side < 0 else "right"] is None:
            continue           # a truncated end the caller makes absorbing
        L = L - coupling_matrix(basis, wall, dom.y_max, 2 * deg + 1)
    M = skfem.asm(forms.mass, basis)
    return L.tocsr(), M.tocsr()


def _degree(elem: skfem.Element) -> int:
    return 2 if isinstance(elem, (skfem.ElementQuad2, skfem.ElementTriP2,
                                  skfem.ElementLineP2)) else 1


@dataclass
class TensorOperator:
    """(L, M) assembled by Kronecker products, DOF (i, j) ↦ i·ny + j.

    Attributes
    ----------
    L : csr_matrix
        Generator in Kronecker order.
    unit : ndarray
        ∫ φ_(i,j) = (∫ψ_i)(∫χ_j): the normalisation row.
    xbasis, ybasis : skfem.CellBasis
        The 1-D bases; DOF coordinates ``xbasis.doflocs[0]``, ``ybasis.doflocs[0]``.
    domain : Domain
    mass_factors : (Mx, My)
        The 1-D mass matrices: ``M`` = Mx ⊗ My, assembled on first use (a
        stationary solve never needs it: issue 31 measured it at a third of the
        assembly of Q4 on 64 × 256 cells).
    """
    L: sp.csr_matrix
    unit: np.ndarray
    xbasis: skfem.CellBasis
    ybasis: skfem.CellBasis
    domain: Domain
    mass_factors: tuple
    _M: sp.csr_matrix | None = None

    @property
    def M(self) -> sp.csr_matrix:
        """The mass matrix in Kronecker order."""
        if self._M is None:
            self._M = kron_sum([self.mass_factors])
        return self._M

    @property
    def shape(self) -> tuple[int, int]:
        return self.xbasis.N, self.ybasis.N


def assemble_tensor(system: VibroImpactSystem, xnodes: np.ndarray, ynodes: np.ndarray,
                    degree: int = 1, dom: Domain | None = None) -> TensorOperator:
    """Kronecker assembly of (L, M) on the tensor mesh ``xnodes × ynodes``.

    With ψ_i(x) the 1-D x-basis and χ_j(y) the y-basis, the terms of ∫ J·∇q factor:

        ∫ y p ∂q/∂x            = (∫ ψ_j ψ_i')        ⊗ (∫ y χ_l χ_k)
        −∫ c y p ∂q/∂y         = −c (∫ ψ_j ψ_i)      ⊗ (∫ y χ_l χ_k')
        −∫ (a x + b x³) p ∂q/∂y = −(∫ (a x+b x³) ψ_j ψ_i) ⊗ (∫ χ_l χ_k')
        −∫ (D1 + D2 x²) p_y q_y = −(∫ (D1+D2x²) ψ_j ψ_i) ⊗ (∫ χ_l' χ_k')
        B_wall                 = (e_w e_wᵀ) ⊗ C_wall   (see impact.wall_matrix_1d)
    """
    if dom is None:
        xs, ys = np.sort(xnodes), np.sort(ynodes)
        mesh = skfem.MeshQuad.init_tensor(xs[[0, -1]], np.array([ys[0], 0.0, ys[-1]]))
        dom = mesh_domain(system, mesh)
    bx, by = assemble_tensor_bases(xnodes, ynodes, degree)
    terms, (Mx, My) = tensor_terms(system, bx, by, dom, degree)
    L = kron_sum(terms)
    unit = np.kron(np.asarray(Mx.sum(axis=0)).ravel(), np.asarray(My.sum(axis=0)).ravel())
    return TensorOperator(L, unit, bx, by, dom, (Mx, My))


def tensor_terms(system: VibroImpactSystem, bx: skfem.CellBasis, by: skfem.CellBasis,
                 dom: Domain, degree: int, *, external: bool = True
                 ) -> tuple[list, tuple[sp.csr_matrix, sp.csr_matrix]]:
    """The Kronecker terms (X_t, Y_t) of :func:`assemble_tensor`'s L, the walls
    included, and the 1-D masses (Mx, My); ``external=False`` leaves out the white
    external diffusion D1 (the coloured-noise operator puts ζ there instead,
    :mod:`fpk_vibro.fem.coloured_operator`)."""
    s = system

    def m1(b, *coef):
        return skfem.asm(forms.weighted_mass_1d, b, coef=tuple(coef))

    def c1(b, *coef):
        return skfem.asm(forms.convection_1d, b, coef=tuple(coef))

    Mx, My = m1(bx, 1.0), m1(by, 1.0)
    terms = [(c1(bx, 1.0), m1(by, 0.0, 1.0))]                    # y p ∂q/∂x
    if s.c != 0:
        terms.append((-s.c * Mx, c1(by, 0.0, 1.0)))              # −c y p ∂q/∂y
    if s.a != 0 or s.b != 0:
        terms.append((-m1(bx, 0.0, s.a, 0.0, s.b), c1(by, 1.0)))  # −(ax+bx³) p ∂q/∂y
    D1 = s.D1 if external else 0.0
    if D1 != 0 or s.D2 != 0:
        D = m1(bx, D1, 0.0, s.D2) if s.D2 != 0 else D1 * Mx
        terms.append((-D, skfem.asm(forms.stiffness_1d, by)))    # −D(x) p_y q_y
    xd = bx.doflocs[0]
    for wall in dom.walls:
        iw = int(np.argmin(np.abs(xd - wall.x)))
        E = sp.csr_matrix(([1.0], ([iw], [iw])), shape=(bx.N, bx.N))
        terms.append((-E, wall_matrix_1d(by, wall, dom.y_max, 2 * degree + 1)))
    return terms, (Mx, My)


def assemble_tensor_bases(xnodes: np.ndarray, ynodes: np.ndarray, degree: int
                          ) -> tuple[skfem.CellBasis, skfem.CellBasis]:
    """The 1-D Lagrange bases on the x- and y-nodes: skfem's P1/P2, and for degree
    3 or 4 the nodal Gauss–Lobatto element of :mod:`fpk_vibro.fem.highorder`."""
    q = quadrature_order(degree)
    if degree >= 3:
        from .highorder import ElementLineGLL
        e1 = ElementLineGLL(degree)
    else:
        e1 = {1: skfem.ElementLineP1(), 2: skfem.ElementLineP2()}[degree]
    bx = skfem.CellBasis(skfem.MeshLine(np.asarray(xnodes, float)), e1, intorder=q)
    by = skfem.CellBasis(skfem.MeshLine(np.asarray(ynodes, float)), e1, intorder=q)
    return bx, by


def tensor_to_basis(op: TensorOperator, basis: skfem.CellBasis) -> np.ndarray:
    """Index array ``k`` with ``p_basis = p_kron[k]`` for a tensor mesh basis."""
    return tensor_index(op.xbasis, op.ybasis, basis)


def tensor_index(xbasis: skfem.CellBasis, ybasis: skfem.CellBasis,
                 basis: skfem.CellBasis) -> np.ndarray:
    """Kronecker index (i·ny + j) of every DOF of the 2-D ``basis``."""
    xd, yd = xbasis.doflocs[0], ybasis.doflocs[0]
    ix, iy = np.argsort(xd), np.argsort(yd)
    loc = basis.doflocs

    def find(sorted_idx, coords, targets):
        c = coords[sorted_idx]
        pos = np.clip(np.searchsorted(c, targets), 1, len(c) - 1)
        left = np.abs(c[pos - 1] - targets) < np.abs(c[pos] - targets)
        pos = np.where(left, pos - 1, pos)
        if np.max(np.abs(c[pos] - targets)) > 1e-9 * max(1.0, np.ptp(c)):
            raise ValueError("mesh: not the tensor-product mesh of the 1-D node arrays")
        return sorted_idx[pos]

    return find(ix, xd, loc[0]) * len(yd) + find(iy, yd, loc[1])
