"""Positivity: discrete upwinding and algebraic flux correction (DESIGN §3).

Plain Galerkin goes negative next to (±Δ, 0) for small r and weak noise
(DESIGN §3, trial facts).  Following the fact quoted there:

1. *Discrete upwinding.*  L has zero column sums.  Add the symmetric, zero-row-sum
   "diffusion" D with d_ij = max(0, −l_ij, −l_ji) (i ≠ j), d_ii = −Σ_j d_ij:

       L_low = L + D

   has non-negative off-diagonals and still zero column sums — a generator — so its
   null vector is ≥ 0 (Perron–Frobenius).  For Q1/P1 the impact injection entries
   are already ≥ 0 (basis functions ≥ 0); D removes the negative Galerkin ones.
   L_low is first order.

2. *Algebraic flux correction* (Kuzmin).  Galerkin is L p = L_low p + Σ_j f_ij with
   the antisymmetric antidiffusive fluxes f_ij = d_ij (p_i − p_j).  They are limited,
   f_ij → α_ij f_ij, α_ij ∈ [0, 1] symmetric, by Zalesak's limiter with local bounds

       Q_i^± = q_i (p_i^max/min − p_i),   q_i = Σ_{j≠i} (L_low)_ij,

   p_i^max/min over the stencil of i; R_i^± = min(1, Q_i^± / P_i^±) with
   P_i^± the sums of positive/negative fluxes into i; α_ij = min(R_i^+, R_j^−) for
   f_ij > 0, else min(R_i^−, R_j^+).  Antisymmetry keeps Σ_i Σ_j α_ij f_ij = 0: mass
   is conserved exactly.  The nonlinear system L_low p + F(p) = 0 is solved by
   defect correction with the LU factors of L_low (pinned row) computed once,
   under-relaxed, from the positive low-order solution.  Where p is smooth α → 1
   and the Galerkin order is recovered.

Measured status (this implementation)
-------------------------------------
- Upwinding alone (``positivity="upwind"``): provably non-negative, mass 1 to
  round-off, but first order with a large constant — on the exact case (Q1,
  nx = 32, ny = 128) E[H] = 0.672 instead of 0.254 (nx = 64: 0.384): it is the
  artificial x-diffusion h_x|y|/2 that DESIGN §3 warns about.
- AFC defect correction: on the smooth exact case it stalls at a relative
  change ~1e-6 after 300 iterations (L1 error 1.4e-4 → 1.9e-4 at nx = 64, i.e.
  close to Galerkin), but on the hard cases (r ≤ 0.3, D1 = 0.002) it oscillates
  (relative change 0.1–1.5 after 300 iterations with ω = 0.5; 7e-3 after 1000
  with ω = 0.1) and the moments are meaningless.  A frozen-α (linearised)
  variant oscillated as well and is not non-negative.  Pseudo-time stepping
  (M_L/Δt − L_low) p⁺ = M_L p/Δt + F(p) is conservative and, for
  Δt ≤ min_i m_i/q_i (the FCT condition), provably non-negative; measured on
  r = 0.3, D1 = 0.002, nx = 32: positive but still drifting after 3000 steps
  (E[H] 0.0876 vs Galerkin 0.0636, change 1e-4/step: the relaxation time ~1/c
  needs ~10⁴ such steps); with 10–1000× that Δt it oscillates again and goes
  negative (−1.4e-3 … −1.2e-2 of max p).  scipy.optimize.anderson (M = 10) and
  newton_krylov on the preconditioned fixed-point residual did not converge
  either (r = 0.3: residual 1e4, min −0.19 max p).  A converging nonlinear
  solver (Newton/Anderson on the limited system, or a transient pseudo-time
  march with BDF2 as in DESIGN §3) is the open item.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .solve import SolveInfo, grid_nested_dissection, pinned_system, relative_residual

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
        perm = grid_nested_dissection(*grid)
        lu = spla.splu(A[perm][:, perm].tocsc(), permc_spec="NATURAL",
                       diag_pivot_thresh=0.01, options={"SymmetricMode": True})

        def solve(rhs):
            out = np.empty_like(rhs)
            out[perm] = lu.solve(rhs[perm])
            return out
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
