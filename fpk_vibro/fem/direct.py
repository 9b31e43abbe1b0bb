"""The sparse direct solve (SuperLU) of the pinned stationary system and of step
matrices, with the orderings that keep its fill low.

Two measured facts shape the direct solver.  (i) The normalisation row uᵀ is
dense; with it SuperLU's fill explodes (a 17k-DOF Q1 system filled 1.5·10⁷
entries).  We therefore replace row k by e_kᵀ (pin p_k = 1, sparse) and rescale
by ∫ p afterwards — the same normalised null vector.  (ii) On a tensor-product
mesh the geometric nested-dissection ordering of the DOF grid
(:func:`grid_nested_dissection`) with SuperLU's diagonal pivoting
(``diag_pivot_thresh=0.01``) fills ~1.5–2× less than COLAMD and is ~1.8× faster than
MMD on A + Aᵀ for Q1.  For Q2–Q4 and general meshes MMD_AT_PLUS_A with the same
diagonal pivoting is used (4–5× less fill than the grid ND for Q2, measured), except
on a DOF grid at least :data:`ELONGATED` times longer in x than in y, where MMD's fill
grows like n² (Q2, paper case, cells nx × ny: 100 × 20 1.2e6 entries in 0.06 s,
128 × 16 6.9e6 in 1.2 s, 200 × 20 5.5e7 in 62 s, 2000 × 2 1.8e8 in 238 s: the
MemoryError of ``error_estimate()`` at nx = 1e5, ny = 2) and the grid ND stays linear
(0.06, 0.06, 0.25, 0.04 s).  The backward error is checked and, if above 1e-10,
improved by GMRES preconditioned with the LU factors.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["ELONGATED", "pinned_system", "relative_residual", "grid_nested_dissection",
           "is_p1", "nd_lu", "solve_direct"]


def pinned_system(L: sp.spmatrix, unit: np.ndarray, pin: int | None = None
                  ) -> tuple[sp.csr_matrix, np.ndarray, int]:
    """(A, b, k): L with row k replaced by e_kᵀ, b = e_k (then p ← p / uᵀp)."""
    L = sp.csr_matrix(L)
    n = L.shape[0]
    if pin is None:
        pin = int(np.argmax(unit))
    keep = np.ones(n)
    keep[pin] = 0.0
    A = sp.diags(keep) @ L + sp.csr_matrix(([1.0], ([pin], [pin])), shape=(n, n))
    A = sp.csr_matrix(A)
    A.eliminate_zeros()
    b = np.zeros(n)
    b[pin] = 1.0
    return A, b, pin


def relative_residual(A: sp.spmatrix, p: np.ndarray, b: np.ndarray) -> float:
    """‖A p − b‖∞ / (‖A‖∞ ‖p‖∞ + ‖b‖∞): the normwise backward error."""
    r = A @ p - b
    normA = float(abs(A).sum(axis=1).max())
    return float(np.max(np.abs(r)) / (normA * np.max(np.abs(p)) + np.max(np.abs(b))))


def grid_nested_dissection(xrank: np.ndarray, yrank: np.ndarray, leaf: int = 6
                           ) -> np.ndarray:
    """Nested-dissection ordering of a tensor DOF grid (DOF (i, j) ↦ i·ny + j).

    ``xrank[i]``, ``yrank[j]`` are the spatial ranks of the 1-D DOFs (P2 numbers
    vertices before midpoints).  The grid is cut recursively across its longer
    side along a line of *vertex* DOFs (even rank for P2, any for P1: detected as
    separators that decouple the halves), separators numbered last.
    """
    nx, ny = len(xrank), len(yrank)
    xs, ys = np.argsort(xrank), np.argsort(yrank)      # spatial position -> dof
    step = 1 if nx < 2 or (nx - 1) % 2 or is_p1(xrank) else 2
    out: list[np.ndarray] = []
    stack = [(0, nx, 0, ny, False)]
    while stack:
        i0, i1, j0, j1, emit = stack.pop()
        if emit:                           # separator block marker
            out.append((xs[i0:i1, None] * ny + ys[None, j0:j1]).ravel())
            continue
        ni, nj = i1 - i0, j1 - j0
        if ni <= leaf * step and nj <= leaf * step:
            out.append((xs[i0:i1, None] * ny + ys[None, j0:j1]).ravel())
            continue
        if ni >= nj:
            m = i0 + (ni // 2) // step * step
            # order: left, right, then separator (stack is LIFO)
            stack += [(m, m + 1, j0, j1, True), (m + 1, i1, j0, j1, False), (i0, m, j0, j1, False)]
        else:
            m = j0 + (nj // 2) // step * step
            stack += [(i0, i1, m, m + 1, True), (i0, i1, m + 1, j1, False), (i0, i1, j0, m, False)]
    return np.concatenate(out)


#: x-DOFs / y-DOFs of a tensor grid from which the high-degree solve orders by the
#: grid nested dissection, not MMD (module docstring; Q2 at cells 120 × 20 and Q4 at
#: 48 × 8, ratio 6: ND 0.07 and 0.04 s, MMD 0.12 and 0.08 s; Q4 32 × 8: both 0.02 s).
ELONGATED = 5.0


def is_p1(rank: np.ndarray) -> bool:
    return bool(np.all(rank == np.arange(len(rank))))


def nd_lu(K: sp.spmatrix, perm: np.ndarray):
    """The solve x = K⁻¹ b by SuperLU on K permuted symmetrically by ``perm`` (a
    nested-dissection order, :func:`grid_nested_dissection`), no further column
    ordering, diagonal pivots preferred (``diag_pivot_thresh=0.01``)."""
    lu = spla.splu(K[perm][:, perm].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.01,
                   options={"SymmetricMode": True})

    def solve(v: np.ndarray) -> np.ndarray:
        out = np.empty_like(v)
        out[perm] = lu.solve(v[perm])
        return out
    return solve


def solve_direct(A: sp.csr_matrix, b: np.ndarray, grid, tol: float):
    if grid is not None and not all(is_p1(r) for r in grid) \
            and len(grid[0]) < ELONGATED * len(grid[1]):
        grid = None                      # measured: MMD beats this ND 4-5x for Q2
    if grid is not None:
        apply = nd_lu(A, grid_nested_dissection(*grid))
        x = apply(b)
        ordering = "nested-dissection"
    else:
        lu = spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.01,
                       options={"SymmetricMode": True})
        x = lu.solve(b)
        ordering = "MMD_AT_PLUS_A"
        apply = lu.solve
    it = 0
    if relative_residual(A, x, b) > 1e-10:         # static pivoting lost accuracy
        M = spla.LinearOperator(A.shape, matvec=apply)
        count = [0]
        x, _ = spla.gmres(A, b, x0=x, M=M, rtol=tol, restart=20, maxiter=20,
                          callback=lambda _: count.__setitem__(0, count[0] + 1),
                          callback_type="pr_norm")
        it = count[0]
    return x, it, ordering
