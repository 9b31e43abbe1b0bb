"""The impact coupling B± of the conservative weak form.

Theory: docs/theory.md, §Impact coupling.

At a wall x = x_w with outflow direction ``side`` (+1 at the right wall, −1 at the
left one) the impact condition p(x_w, −r v) = p(x_w, v)/r² turns the boundary term
into (a law r(u): −r v reads −φ(v) = −v r(v) below, p(x_w, −φ) = v p(x_w, v)/(φ φ′); the
weak form needs no Jacobian)

    B(p, q) = ∫_{side·v > 0} |v| p(x_w, v) [ q(x_w, v) − q(x_w, −r v) ] dv,

so that ∫ ∂p/∂t q = ∫ J·∇q − B₊ − B₋, and B(p, 1) = 0: mass is conserved for every
0 ≤ r ≤ 1 (r = 0 re-injects at v = 0).

Discretisation.  The integral runs over the outflow half only.  Its integrand is
a polynomial times q(x_w, −r v), which is only piecewise polynomial in v: it has a
kink wherever −r v crosses a mesh node of the inflow half.  The outflow half is
therefore split at the wall's nodes *and* at the pre-images v = −y_n / r of the
inflow-half nodes y_n; on that 1-D mesh a Gauss rule from skfem is exact for the
polynomial degrees used.  For a law the pre-images are φ⁻¹(|y_n|)
(:mod:`fpk_vibro.fem.rebound`) and a table's knots are breakpoints too; q(x_w, −φ(v))
is then smooth, not polynomial, on each piece (the rule is of Gauss accuracy there),
but B(p, 1) = 0 still holds exactly for every rule: the test functions sum to one at
the mapped points as at the points, so mass stays exact for every law.  With the quadrature points v_k, weights w_k,

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
from .rebound import kinks

__all__ = ["wall_quadrature", "coupling_matrix", "wall_matrix_1d", "coupling_parts",
           "wall_parts_1d"]


def wall_quadrature(wall: StripEnd, y_wall_nodes: np.ndarray, y_max: float,
                    intorder: int, speed_limit: float | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    speed_limit : float, optional
        An extra breakpoint at this speed (where a first passage out of
        ``impact_speed=u_c`` makes the coupling absorbing).

    Returns
    -------
    y, y_mapped, weight : ndarray
        Quadrature points v_k, their images −r v_k (a law: −sign(v_k) φ(|v_k|)), and
        w_k |v_k|.
    """
    s = wall.side * np.asarray(y_wall_nodes, dtype=float)     # outflow if s > 0
    bp = [s[s >= 0], [0.0, y_max]]
    law = not isinstance(wall.r, (int, float))          # a law r(u)
    if law:
        # pre-images φ⁻¹ of the inflow nodes' speeds, and the law's own kinks
        speeds = -s[s < 0]
        speeds = speeds[speeds < wall.rebound(np.array([y_max]))[0]]
        bp += [wall.preimage(speeds, y_max), kinks(wall.r, y_max)]
    elif wall.r > 0:
        pre = -s[s < 0] / wall.r
        bp.append(pre[pre < y_max])
    if speed_limit is not None and 0 < speed_limit < y_max:
        bp.append([speed_limit])
    bp = np.unique(np.concatenate(bp))
    keep = np.concatenate([[True], np.diff(bp) > 1e-12 * y_max])
    bp = bp[keep]
    bp[-1] = y_max
    qb = skfem.CellBasis(skfem.MeshLine(bp), skfem.ElementLineP0(), intorder=intorder)
    sq = np.asarray(qb.global_coordinates())[0].ravel()
    wq = qb.dx.ravel()
    y = wall.side * sq
    return y, (-wall.side * wall.rebound(sq) if law else -wall.r * y), wq * sq


def coupling_parts(basis: skfem.CellBasis, wall: StripEnd, y_max: float,
                   intorder: int, speed_limit: float | None = None
                   ) -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray]:
    """(P, P_r, w) of one wall on a general 2-D mesh: the basis at the quadrature
    points and at their images, and the weights w_k |v_k| (module docstring)."""
    p = basis.mesh.p
    on_wall = np.abs(p[0] - wall.x) <= 1e-12 * max(1.0, abs(wall.x))
    # a mesh whose height varies along x (e.g. fitted to a level set) ends lower here
    y_max = min(y_max, float(np.max(np.abs(p[1, on_wall]))))
    y, ym, w = wall_quadrature(wall, p[1, on_wall], y_max, intorder, speed_limit)
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
    return sp.csr_matrix(P), sp.csr_matrix(Pr), w


def coupling_matrix(basis: skfem.CellBasis, wall: StripEnd, y_max: float,
                    intorder: int) -> sp.csr_matrix:
    """The matrix B of one wall on a general 2-D mesh (module docstring).

    The generator gets ``L -= B``.
    """
    P, Pr, w = coupling_parts(basis, wall, y_max, intorder)
    return ((P - Pr).T @ sp.diags(w) @ P).tocsr()


def wall_parts_1d(ybasis: skfem.CellBasis, wall: StripEnd, y_max: float, intorder: int,
                  speed_limit: float | None = None
                  ) -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray]:
    """(P, P_r, w) of one wall for Kronecker assembly: the 1-D y-basis at the
    quadrature points and at their images, and the weights w_k |v_k|."""
    y, ym, w = wall_quadrature(wall, ybasis.mesh.p[0], y_max, intorder, speed_limit)
    return (sp.csr_matrix(ybasis.probes(y[None, :])),
            sp.csr_matrix(ybasis.probes(ym[None, :])), w)


def wall_matrix_1d(ybasis: skfem.CellBasis, wall: StripEnd, y_max: float,
                   intorder: int) -> sp.csr_matrix:
    """The y-factor C of one wall for Kronecker assembly.

    On a tensor-product mesh the trace of φ_(i,j) = ψ_i(x) χ_j(y) on the wall is
    δ_(i,w) χ_j(y) (Lagrange basis), so B = (e_w e_wᵀ) ⊗ C with
    C[k, l] = Σ_q w_q |v_q| χ_l(v_q) [χ_k(v_q) − χ_k(−r v_q)].
    """
    P, Pr, w = wall_parts_1d(ybasis, wall, y_max, intorder)
    return ((P - Pr).T @ sp.diags(w) @ P).tocsr()
