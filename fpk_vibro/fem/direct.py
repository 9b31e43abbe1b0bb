"""The sparse direct solve (SuperLU) of the pinned stationary system and of step
matrices, with the orderings that keep its fill low.

Two measured facts shape the direct solver.  (i) The normalisation row uᵀ is
dense; with it SuperLU's fill explodes (a 17k-DOF Q1 system filled 1.5·10⁷
entries).  We therefore replace row k by e_kᵀ (pin p_k = 1, sparse) and rescale
by ∫ p afterwards — the same normalised null vector.  (ii) On a tensor-product
mesh the geometric nested-dissection ordering of the DOF grid
(:func:`grid_nested_dissection`) fills ~1.5–2× less than COLAMD and is ~1.8×
faster than MMD on A + Aᵀ for Q1.  For Q2–Q4 and general meshes MMD_AT_PLUS_A is
used (4–5× less fill than the grid ND for Q2; for Q4 up to 10× less, the wall
couplings crossing its separators).  Issue 30 ordered grids at least 5 times longer
in x than in y by the grid ND, MMD's fill having grown like n² there (Q2, paper
case, 2000 × 2 cells: 1.8e8 entries, 238 s); that was the row swaps of the pivot
threshold 0.01, not MMD: with (iii) MMD takes 0.02 s there (ND 0.04 s), 0.04 s at
200 × 20 (5.9 s with 0.01), and Q4 at 156 × 28, 0.31 s against 3.7 s by the
grid ND.  The backward error is checked and, if above 1e-10, improved by GMRES
preconditioned with the LU factors.

(iii) The stationary solve prefers the diagonal pivot unless it is below
:data:`PIVOT` times the largest in its column (issue 31).  SuperLU's threshold
0.01, used before, swapped rows on the Galerkin generator of weakly damped systems
and filled their factors many times over: Q4 on 32 × 32 cells of a double well with
c = 0.01 (16 641 DOFs) filled 1.3e7 entries in 2.0 s, 1.5e6 in 0.05 s with 1e-6;
at 32 × 64, 9.0e6 in 0.77 s against 3.7e6 in 0.14 s.  On 24 other systems and
degrees (tests of the hard cases, random scenes) the fill was the same within 10 %
and the backward error at most 2e-13 (1e-19 – 6e-15 with 0.01).  Where the
backward error is above 1e-10 GMRES on the factors mends it (Q2 at 2000 × 2:
2e-9, one iteration), or where 20 iterations do not (the hard corner r = 0 at Q4,
80 × 44: it needed 374 iterations, 42 s) the matrix is factorised again with
:data:`SAFE_PIVOT` = 0.01, as before.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["PIVOT", "SAFE_PIVOT", "ELONGATED", "pinned_system", "relative_residual",
           "grid_nested_dissection", "is_p1", "nd_lu", "solve_direct"]


def pinned_system(L: sp.spmatrix, unit: np.ndarray, pin: int | None = None
                  ) -> tuple[sp.csr_matrix, np.ndarray, int]:
    """(A, b, k): L with row k replaced by e_kᵀ, b = e_k (then p ← p / uᵀp).

    The row is overwritten in a copy of L's CSR arrays (one pass; the product
    diag(keep)·L + e_k e_kᵀ it replaces cost 0.2–0.5 s at 2.6e5 Q4 DOFs)."""
    A = sp.csr_matrix(L, copy=True)
    n = A.shape[0]
    if pin is None:
        pin = int(np.argmax(unit))
    lo, hi = A.indptr[pin], A.indptr[pin + 1]
    A.data[lo:hi] = 0.0
    diag = lo + np.flatnonzero(A.indices[lo:hi] == pin)
    if diag.size:
        A.data[diag[0]] = 1.0
    else:                                   # (no stored diagonal: add it)
        A = sp.csr_matrix(A + sp.csr_matrix(([1.0], ([pin], [pin])), shape=(n, n)))
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


def is_p1(rank: np.ndarray) -> bool:
    return bool(np.all(rank == np.arange(len(rank))))


#: The stationary solve's diagonal pivot threshold (module docstring, (iii)), and
#: the one it factorises with again where the backward error is above 1e-10.
PIVOT = 1e-6
SAFE_PIVOT = 0.01


def nd_lu(K: sp.spmatrix, perm: np.ndarray, pivot: float = 0.01):
    """The solve x = K⁻¹ b by SuperLU on K permuted symmetrically by ``perm`` (a
    nested-dissection order, :func:`grid_nested_dissection`), no further column
    ordering, diagonal pivots preferred (``diag_pivot_thresh=pivot``)."""
    lu = spla.splu(K[perm][:, perm].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=pivot,
                   options={"SymmetricMode": True})

    def solve(v: np.ndarray) -> np.ndarray:
        out = np.empty_like(v)
        out[perm] = lu.solve(v[perm])
        return out
    return solve


#: x-DOFs / y-DOFs (or the inverse) of a tensor grid from which the factorisation is
#: ordered by COLAMD, not MMD on A + Aᵀ: MMD's fill grows without bound there (Q4,
#: 194 × 32 cells of a b = −300 spring, 100 233 DOFs: no factors after 10 min, the
#: default solve hung; COLAMD 2.8 s, the grid's nested dissection 5.7 s).
ELONGATED = 5.0


def _superlu(A: sp.csr_matrix, pivot: float = PIVOT, ordering: str = "MMD_AT_PLUS_A"):
    """SuperLU of A by ``ordering`` (MMD on A + Aᵀ, or COLAMD) with diagonal pivots
    preferred (``pivot``); the CSR arrays of A are those of Aᵀ in CSC, so Aᵀ is
    factorised without a copy and solved transposed (the CSR → CSC conversion took as
    long as 15 % of the factorisation at 2.6e5 Q4 DOFs)."""
    lu = spla.splu(A.T, permc_spec=ordering, diag_pivot_thresh=pivot,
                   options={"SymmetricMode": ordering == "MMD_AT_PLUS_A"})
    return lambda v: lu.solve(v, trans="T")


def _refine(A, b, x, apply, tol: float, restarts: int):
    """x improved by GMRES preconditioned with the factors ``apply`` (restarts of 20
    iterations); (x, iterations, backward error)."""
    M = spla.LinearOperator(A.shape, matvec=apply)
    count = [0]
    x, _ = spla.gmres(A, b, x0=x, M=M, rtol=tol, restart=20, maxiter=restarts,
                      callback=lambda _: count.__setitem__(0, count[0] + 1),
                      callback_type="pr_norm")
    return x, count[0], relative_residual(A, x, b)


def solve_direct(A: sp.csr_matrix, b: np.ndarray, grid, tol: float):
    """x = A⁻¹ b by SuperLU (module docstring): factors with the pivot threshold
    :data:`PIVOT`; where the backward error is above 1e-10, up to 20 GMRES iterations
    on them, then factors with :data:`SAFE_PIVOT` and GMRES on those.  The grid's
    nested dissection orders Q1 (``grid`` the 1-D DOF ranks), MMD on A + Aᵀ the rest.
    Returns (x, GMRES iterations, ordering, backward error)."""
    shape = None if grid is None else sorted(len(r) for r in grid)
    elongated = shape is not None and shape[1] >= ELONGATED * max(shape[0], 1)
    if grid is not None and not all(is_p1(r) for r in grid):
        grid = None                      # measured: MMD beats this ND 4-5x for Q2
    ordering = ("nested-dissection" if grid is not None else
                "COLAMD" if elongated else "MMD_AT_PLUS_A")
    it = 0
    for pivot, restarts in ((PIVOT, 1), (SAFE_PIVOT, 20)):
        if grid is not None:
            apply = nd_lu(A, grid_nested_dissection(*grid), pivot)
        else:
            apply = _superlu(sp.csr_matrix(A), pivot, ordering)
        x = apply(b)
        res = relative_residual(A, x, b)
        if res > 1e-10:             # static pivoting lost accuracy
            x, n, res = _refine(A, b, x, apply, tol, restarts)
            it += n
        if res <= 1e-10:
            break
    return x, it, ordering, res
