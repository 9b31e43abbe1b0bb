"""Σ_t X_t ⊗ Y_t of 1-D FE matrices, written straight into CSR (docs/theory.md,
§Assembly and solve).

The terms of the tensor assembly (:func:`fpk_vibro.fem.generator.assemble_tensor`)
are Kronecker products of 1-D matrices on one x-basis and one y-basis, so all X_t
share the pattern of the x-basis' element connectivity and all Y_t that of the
y-basis.  Row (i, k) of Σ_t X_t ⊗ Y_t holds Σ_t X_t[i, j] Y_t[k, l] at column
j·n_y + l, for j in row i of the x-pattern and l in row k of the y-pattern: in that
order the CSR arrays are written directly (no COO sort), one compiled loop over
the nonzeros.

Measured (issue 31, Q4 on 64 × 256 cells, 263 425 DOFs, 9.5e6 nonzeros, this
2-core machine): the former NumPy version, a 4-D broadcast over rows padded to the
widest one (9 entries for a Q4 vertex, 5 inside a cell: 2.4× the nonzeros) took
0.6–1.2 s per matrix, as long as the factorisation of Q4 at 32 × 128; this kernel
takes about 0.05 s (its compilation is cached on disk by numba).
"""
from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numba import njit

__all__ = ["kron_sum"]


@njit(cache=True)
def _fill(ipx, jx, xv, ipy, jy, yv, indptr, indices, data):  # pragma: no cover - compiled
    n_terms = xv.shape[0]
    nrx, nry = ipx.size - 1, ipy.size - 1
    for i in range(nrx):
        for k in range(nry):
            pos = indptr[i * nry + k]
            for a in range(ipx[i], ipx[i + 1]):
                col = jx[a] * nry
                for b in range(ipy[k], ipy[k + 1]):
                    s = 0.0
                    for t in range(n_terms):
                        s += xv[t, a] * yv[t, b]
                    data[pos] = s
                    indices[pos] = col + jy[b]
                    pos += 1


def _common(mats: list) -> tuple[sp.csr_matrix, np.ndarray]:
    """(pattern, values): the union pattern of ``mats`` (CSR, sorted) and each
    matrix's values on it, shape (len(mats), nnz)."""
    pat = sp.csr_matrix(sum(abs(sp.csr_matrix(m)) for m in mats))
    pat.sum_duplicates()
    pat.sort_indices()
    rows = np.repeat(np.arange(pat.shape[0]), np.diff(pat.indptr))
    vals = np.empty((len(mats), pat.nnz))
    for t, m in enumerate(mats):
        vals[t] = np.asarray(sp.csr_matrix(m)[rows, pat.indices]).ravel()
    return pat, vals


def kron_sum(terms: list[tuple[sp.spmatrix, ...]]) -> sp.csr_matrix:
    """Σ_t X_t ⊗ Y_t (module docstring), or Σ_t X_t ⊗ Y_t ⊗ Z_t ⊗ … with more factors.

    Parameters
    ----------
    terms : list of (X_t, Y_t[, Z_t, ...])
        Square sparse matrices, factor k of one size in every term.  With three or
        more factors the leading ones are folded first: terms that share their last
        factor (the same object) are summed there, so the compiled fill runs once
        over the full pattern (the coloured-noise operator: three ζ-factors).

    Returns
    -------
    scipy.sparse.csr_matrix
        Of size (Π n_k)², DOF (i, k) ↦ i·n_y + k (the last factor fastest), sorted
        indices.
    """
    if len({len(t) for t in terms}) != 1 or len(terms[0]) < 2:
        raise ValueError("kron_sum: every term needs the same number (≥ 2) of factors")
    if len(terms[0]) > 2:
        groups: dict[int, tuple[Any, list]] = {}
        for t in terms:
            groups.setdefault(id(t[-1]), (t[-1], []))[1].append(t[:-1])
        terms = [(kron_sum(lead), last) for last, lead in groups.values()]
    px, xv = _common([t[0] for t in terms])
    py, yv = _common([t[1] for t in terms])
    nx, ny = px.shape[0], py.shape[0]
    counts = np.outer(np.diff(px.indptr), np.diff(py.indptr)).ravel()
    indptr = np.zeros(nx * ny + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    nnz = int(indptr[-1])
    index_type = np.int32 if max(nnz, nx * ny) < 2 ** 31 else np.int64
    indices = np.empty(nnz, dtype=index_type)
    data = np.empty(nnz)
    _fill(px.indptr.astype(np.int64), px.indices.astype(np.int64), xv,
          py.indptr.astype(np.int64), py.indices.astype(np.int64), yv,
          indptr, indices, data)
    out = sp.csr_matrix((data, indices, indptr.astype(index_type)),
                        shape=(nx * ny, nx * ny))
    out.has_sorted_indices = True
    return out
