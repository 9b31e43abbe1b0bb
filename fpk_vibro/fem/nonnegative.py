"""A non-negative density from a Galerkin one, by local mass redistribution.

The Galerkin density p_h undershoots next to the singular wall corners (x_w, 0)
(docs/fem_hard_cases.md).  The correction keeps the mass of every nodal value and
moves it only a few nodes: with m_i = w_i p_i the nodal masses (w_i = ∫ φ_i > 0 for
the Lagrange bases used here) and d_i = max(−m_i, 0) the deficits, each deficit is
taken from the positive masses m_j⁺ in the (2s+1)² block of nodes around it, in
proportion to them::

    take_j = m_j⁺ Σ_{i ∈ N(j)} d_i / Σ_{k ∈ N(i)} m_k⁺,       Σ_j take_j = Σ_i d_i.

Where a block is too poor to pay its deficit some nodes go negative again, and the
next pass uses a block twice as wide (s = 1, 2, 4, …).  After :data:`PASSES` passes
any deficit left is paid by all positive nodes in proportion (p ← max(p, 0),
renormalised).  The total mass ∫ p is unchanged to round-off.

What it costs in accuracy is measured, not assumed: :func:`correction` returns the
L1 distance ∫|p_h − p_c| (by a Gauss rule on the cells, the 1-D bases evaluated
there) and the changes of the moments, and the error estimate adds them
(:mod:`fpk_vibro.fem.estimate`).  Between the nodes a density of degree ≥ 2 with
non-negative nodal values can still dip below 0; the evaluations of
:class:`~fpk_vibro.fem.FEMSolution` return max(p, 0) and the mass of the dips
(``negative_mass_between_nodes``) enters the estimate too.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import convolve1d

from .compare import difference
from .solution import FEMSolution

__all__ = ["redistribute", "PASSES"]

#: Passes of widening blocks (half-widths 1, 2, 4, …) before the global fallback.
PASSES = 10


def redistribute(values: np.ndarray, weights: np.ndarray, classes: np.ndarray | None = None,
                 adjacency=None) -> tuple[np.ndarray, dict]:
    """Non-negative nodal values with the mass ``weights · values`` kept; with
    ``classes`` (an integer label per node) mass moves only within a class and each
    class keeps its own mass (used to keep P_impact: nodes above and below the
    barrier energy).

    Parameters
    ----------
    values, weights : ndarray
        Nodal values and positive weights (∫ φ_i), both shaped as the tensor grid
        of nodes (any number of dimensions), or flat with ``adjacency``.
    classes : ndarray of int, optional
    adjacency : sparse matrix, optional
        Symmetric 0/1 pattern of the DOFs sharing a cell (diagonal included) of an
        unstructured mesh: pass k's block is then the nodes 2^k such steps away.

    Returns
    -------
    values, info
        ``info``: ``passes`` used, ``global`` (True if the fallback paid the rest),
        ``moved`` = Σ |Δm| / Σ m (the fraction of mass moved).
    """
    if classes is not None:
        w = np.asarray(weights, float)
        out = np.array(values, dtype=float)
        total = float(np.sum(w * out))
        passes, moved = 0, 0.0
        for label in np.unique(classes):
            inside = classes == label
            part = np.where(inside, out, 0.0)
            if not float(np.sum(w * np.maximum(part, 0.0))) > float(np.sum(w * np.maximum(
                    -part, 0.0))):      # a class that cannot pay its own deficit: below
                continue
            fixed, how = redistribute(part, w, adjacency=adjacency)
            out = np.where(inside, fixed, out)
            passes = max(passes, how["passes"])
            moved += how["moved"] * float(np.sum(w * part)) / total
        rest, how = redistribute(out, w, adjacency=adjacency)
        return rest, {"passes": max(passes, how["passes"]), "global": how["global"],
                      "moved": moved + how["moved"]}
    w = np.asarray(weights, float)
    m = w * np.asarray(values, float)
    total = float(m.sum())
    start = m.copy()
    used, fallback = 0, False
    for k in range(PASSES):
        deficit = np.maximum(-m, 0.0)
        if not deficit.any():
            break
        used = k + 1
        pos = np.maximum(m, 0.0)
        size = 2 * 2 ** k + 1
        pool = _block_sum(pos, size, adjacency)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(pool > 0, deficit / pool, 0.0)
        take = pos * _block_sum(ratio, size, adjacency)
        m = np.where(deficit > 0, 0.0, pos - take)
        # deficits whose block held no positive mass at all are carried over
        m = m - np.where(pool > 0, 0.0, deficit)
    if (m < 0).any():
        fallback = True
        m = np.maximum(m, 0.0)
        if not m.sum() > 0:
            raise ValueError("no positive mass to correct the density with")
        m *= total / float(m.sum())
    moved = float(np.abs(m - start).sum()) / max(abs(total), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(w > 0, m / w, 0.0)
    return out, {"passes": used, "global": fallback, "moved": moved}


def _block_sum(a: np.ndarray, size: int, adjacency=None) -> np.ndarray:
    """Σ over the size^d block around each entry (zero outside), by direct 1-D sums
    along each axis: a running sum (uniform_filter) leaves round-off where the sum
    is 0, and a deficit divided by it explodes.  The block is symmetric, which
    makes Σ take = Σ deficit.  With ``adjacency`` A: A^((size-1)/2) a (a symmetric
    weighting of the nodes that many cell-steps away)."""
    if adjacency is not None:
        for _ in range((size - 1) // 2):
            a = adjacency @ a
        return a
    kernel = np.ones(size)
    for axis in range(a.ndim):
        a = convolve1d(a, kernel, axis=axis, mode="constant")
    return a


def nodal_weights(sol) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """(values, weights, index, energies) of ``sol`` on its node grid: for a tensor
    mesh the (x-DOFs × y-DOFs) arrays and the map ``dofs = values.ravel()[index]``
    (None: the identity); else the flat DOFs, ∫ φ_i and None.  ``energies``: H at
    each node."""
    if sol._tensor is not None:
        xb, yb, P = sol._tensor_factors()
        W = np.outer(sol._line_integral(xb), sol._line_integral(yb))
        index = None
        if sol.degree <= 2:
            from .generator import tensor_index
            index = tensor_index(xb, yb, sol._doflocs())
        X, Y = np.meshgrid(xb.doflocs[0], yb.doflocs[0], indexing="ij")
        return np.asarray(P, float), W, index, sol.system.energy(X, Y)
    x, y = sol.basis.doflocs
    return sol.dofs, _lumped(sol.basis), None, sol.system.energy(x, y)


def _mass_matrix(basis):
    import skfem
    return skfem.asm(skfem.BilinearForm(lambda u, v, w: u * v), basis).tocsr()


def _lumped(basis) -> np.ndarray:
    """Positive nodal weights of an unstructured basis: the diagonal of the mass
    matrix scaled to the area (HRZ lumping; ∫ φ_i itself is 0 at the vertices of
    P2 triangles)."""
    M = _mass_matrix(basis)
    d = M.diagonal()
    return d * (float(M.sum()) / float(d.sum()))


def correct(sol):
    """The non-negative :class:`~fpk_vibro.fem.FEMSolution` of a Galerkin ``sol``
    (itself if it has no negative nodal value), with ``info["correction"]``:
    ``L1`` = ∫|p_h − p_c|, the relative moment changes (keys of the error
    estimate), ``moved`` and ``passes`` (:func:`redistribute`)."""
    if sol.dofs.min() >= 0.0:
        sol._info["nonnegative"] = True
        sol._info["correction"] = {"L1": 0.0, "moved": 0.0, "passes": 0,
                                   "dips": _dips(sol)}
        return sol
    values, weights, index, H = nodal_weights(sol)
    classes = energy_bands(sol.system, H)
    adjacency = None
    if sol._tensor is None:
        import scipy.sparse as sp
        A = _mass_matrix(sol.basis)
        adjacency = sp.csr_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
    fixed, how = redistribute(values, weights, classes, adjacency)
    flat = fixed.ravel()
    dofs = flat if index is None else flat[index]
    if adjacency is not None:        # HRZ weights keep Σ w p, not ∫ p: renormalise
        import skfem
        unit = np.asarray(skfem.asm(skfem.LinearForm(lambda v, w: v), sol.basis), float)
        dofs = dofs * (sol.mass / float(unit @ dofs))
    info = dict(sol._info)
    out = FEMSolution(sol.system, sol.mesh, sol.degree, dofs, residual=sol.residual,
                      info=info, tensor=sol._tensor, mass=sol.mass)
    out._options = sol._options
    change = difference(out, sol)
    out._info.update(nonnegative=True, galerkin_min_ratio=float(sol.dofs.min() / sol.dofs.max()),
                     correction={**change, **how, "dips": _dips(out)})
    out._resolution = None          # judged again, now with the correction (_record)
    return out


#: Energy bands of the correction: mass moves only between nodes of about the same H.
BANDS = 8


def energy_bands(system, H: np.ndarray) -> np.ndarray:
    """A band label per node: :data:`BANDS` quantiles of H, split at the barrier
    energy.  Why: a deficit in the far tail paid from the bulk moves E[H] by the mass
    times H_tail / E[H] (measured 3e-4 relative for 3e-5 of mass moved); within a band
    H hardly changes, and the split keeps P(H > barrier energy)."""
    edges = np.quantile(H, np.linspace(0.0, 1.0, BANDS + 1)[1:-1])
    if system.has_barrier:
        edges = np.append(edges, system.barrier_energy)
    return np.searchsorted(np.unique(edges), H)


def _dips(sol) -> float:
    """∫ max(−p, 0) of the polynomial density (0 for degree 1 with p_i >= 0)."""
    if sol.degree == 1 and sol.dofs.min() >= 0.0:
        return 0.0
    return float(sol.resolution()["negative_mass"])
