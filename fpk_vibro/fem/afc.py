"""Algebraic upwinding and flux correction of the Galerkin generator (docs/theory.md,
§Positivity).

For general (loaded or triangular) meshes, where the tensor-grid generator of
:mod:`fpk_vibro.fem.positivity` does not apply.

``"upwind"``: L + D with d_ij = max(0, −l_ij, −l_ji) removes the negative
off-diagonals of the Q1/P1 Galerkin L (a generator).  ``"afc"``: Kuzmin's
algebraic flux correction of D's antidiffusive fluxes (Zalesak limiter) by
defect correction with the low-order LU.

AFC status (``"afc"``; retired, it goes in the next release with what only it
uses here): on the hard cases the defect correction oscillates (relative change
0.1–1.5 after 300 iterations with ω = 0.5); frozen-α, FCT pseudo-time stepping,
``scipy.optimize.anderson`` and ``newton_krylov`` did not converge either, and
on the paper case and the exact case it stops at 300 iterations too, 12–290 times
farther from the reference than ``"auto"`` (docs/measurements.md, §Which option
when).
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .solve import SolveInfo, grid_nested_dissection, nd_lu, pinned_system, relative_residual

__all__ = ["discrete_upwinding", "AFCLimiter", "stationary_afc"]


def discrete_upwinding(L: sp.spmatrix) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """(L_low, D): D symmetric, zero row sums, removes negative off-diagonals of L."""
    L = sp.csr_matrix(L)
    off = L - sp.diags(L.diagonal())
    neg = (-off).maximum(-off.T).maximum(0.0)
    neg = sp.csr_matrix(neg)
    neg.eliminate_zeros()
    D = neg - sp.diags(np.asarray(neg.sum(axis=1)).ravel())
    return sp.csr_matrix(L + D), sp.csr_matrix(D)


class AFCLimiter:
    """Zalesak-limited antidiffusive fluxes of D (module docstring)."""

    def __init__(self, L_low: sp.csr_matrix, D: sp.csr_matrix):
        up = sp.triu(D, k=1).tocoo()
        self.i, self.j, self.d = up.row, up.col, up.data
        off = L_low - sp.diags(L_low.diagonal())
        self.q = np.asarray(off.sum(axis=1)).ravel()
        pattern = (abs(L_low) + abs(D)).tocsr()
        self.pattern = pattern
        self.n = L_low.shape[0]

    def _local_extrema(self, p):
        P = self.pattern
        rows = np.repeat(np.arange(self.n), np.diff(P.indptr))
        vals = p[P.indices]
        pmax = p.copy()
        pmin = p.copy()
        np.maximum.at(pmax, rows, vals)
        np.minimum.at(pmin, rows, vals)
        return pmax, pmin

    def correction(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(F, α): F_i = Σ_j α_ij f_ij for the current iterate p."""
        i, j = self.i, self.j
        f = self.d * (p[i] - p[j])                # flux into i; −f into j
        n = self.n
        Pp = np.bincount(i, np.maximum(f, 0), n) + np.bincount(j, np.maximum(-f, 0), n)
        Pm = np.bincount(i, np.minimum(f, 0), n) + np.bincount(j, np.minimum(-f, 0), n)
        pmax, pmin = self._local_extrema(p)
        Qp = self.q * (pmax - p)
        Qm = self.q * (pmin - p)
        with np.errstate(divide="ignore", invalid="ignore"):
            Rp = np.where(Pp > 0, np.minimum(1.0, Qp / Pp), 1.0)
            Rm = np.where(Pm < 0, np.minimum(1.0, Qm / Pm), 1.0)
        alpha = np.where(f > 0, np.minimum(Rp[i], Rm[j]), np.minimum(Rm[i], Rp[j]))
        af = alpha * f
        F = np.bincount(i, af, n) - np.bincount(j, af, n)
        return F, alpha


def stationary_afc(L: sp.spmatrix, M: sp.spmatrix, unit: np.ndarray, *, solver: str = "auto",
                   grid=None, limit: bool = True, omega: float = 0.5, tol: float = 1e-9,
                   maxiter: int = 300) -> tuple[np.ndarray, SolveInfo, dict]:
    """Non-negative stationary density: upwinded L, then AFC (module docstring).

    Parameters
    ----------
    L : sparse matrix
        Galerkin generator (Q1/P1), zero column sums.
    M : sparse matrix
        Mass matrix (unused by the stationary limiter; kept for the transient API).
    unit : ndarray
        ∫ φ_i.
    limit : bool
        False: return the first-order upwinded solution.
    omega : float
        Under-relaxation of the defect correction.
    tol : float
        Stop when the relative change ‖Δp‖∞/‖p‖∞ < tol.

    Returns
    -------
    p, info, extra
        ``extra`` has the AFC iterations, final change and mean α.
    """
    t0 = time.perf_counter()
    L_low, D = discrete_upwinding(L)
    A, b, pin = pinned_system(L_low, unit)
    if grid is not None:
        solve = nd_lu(A, grid_nested_dissection(*grid))
    else:
        lu = spla.splu(A.tocsc(), permc_spec="COLAMD")
        solve = lu.solve
    p = solve(b)
    p /= unit @ p
    extra = {"afc_iterations": 0, "afc_change": 0.0, "afc_mean_alpha": 0.0,
             "afc_defect": 0.0}
    if limit:
        lim = AFCLimiter(L_low, D)
        scale = p[pin]
        change = np.inf
        it = 0
        for it in range(1, maxiter + 1):
            F, alpha = lim.correction(p)
            rhs = -F
            rhs[pin] = scale
            pn = solve(rhs)
            pn = (1 - omega) * p + omega * pn
            change = np.max(np.abs(pn - p)) / np.max(np.abs(pn))
            p = pn
            if change < tol:
                break
        if change >= tol:
            import warnings
            warnings.warn(f"AFC defect correction did not converge: relative change "
                          f"{change:.1e} after {it} iterations (omega={omega}); the "
                          "result is not a converged limited solution", RuntimeWarning,
                          stacklevel=3)
        F, alpha = lim.correction(p)
        defect = np.max(np.abs(L_low @ p + F)) / (abs(L_low).sum(axis=1).max() * np.max(np.abs(p)))
        p = p / (unit @ p)
        extra.update(afc_iterations=it, afc_change=float(change),
                     afc_mean_alpha=float(alpha.mean()) if alpha.size else 1.0,
                     afc_defect=float(defect))
        res = float(defect)
    else:
        res = relative_residual(L_low, p, np.zeros_like(p))
    info = SolveInfo("direct+afc" if limit else "direct-upwind", time.perf_counter() - t0,
                     res, extra["afc_iterations"], {"pin": pin, "ordering":
                                                      "nested-dissection" if grid is not None else "COLAMD"})
    return p, info, extra


# --------------------------------------------------------------------------
# The positive tensor-grid operator (SG in y, upwind/limited in x and for the
# Hamiltonian y-drift; conservative walls) — module docstring, part A.
# --------------------------------------------------------------------------
