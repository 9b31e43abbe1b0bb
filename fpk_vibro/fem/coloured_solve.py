"""The stationary 3-D system L p = 0, ∫ p = 1 of coloured noise: GMRES in the
ζ-eigenmodes, preconditioned by exact 2-D solves (:class:`ModeSolver`).

Theory: docs/theory.md, §Coloured noise; measurements: docs/measurements.md,
§Coloured noise.  The ζ-factor of L (:mod:`fpk_vibro.fem.coloured_operator`) is the
OU generator K_ζ; its generalised eigenvectors K_ζ V = M_ζ V Λ (with left vectors U,
Uᵀ M_ζ V = I) are the discrete Hermite functions, λ_n ≈ −n/τ.  In them

    (I ⊗ Uᵀ) L (I ⊗ V) = A ⊗ I + (M_x ⊗ M_y) ⊗ Λ + C ⊗ W̃,   W̃ = Uᵀ W_ζ V,

and W̃ is tridiagonal (ζ moves mode n to n ± 1).  Each mode is a 2-D problem
T_n = A + λ_n M_xy, coupled to its neighbours by C W̃: the unknowns are the mode
coefficients q_n(x, y), q_0 the ζ-marginal p(x, y) (times the mode's norm), and the
mass constraint is one pinned row of the q_0 block.

Preconditioner, two sweeps in turn:

1. modal: the first ``coupled`` modes (default 2) solved together by one sparse LU
   of their block system (mode 0 alone is the noise-free transport A, whose balance
   with mode 1 is the energy diffusion the noise drives: treating that coupling
   explicitly took 150-290 GMRES iterations where the coupled block needs 50-60, on
   the paper case at 4·10⁴ unknowns), the other modes by one upward block
   Gauss–Seidel sweep with their own 2-D LU;
2. nodal (``smoother``; by default added only when the modal sweep alone has not
   converged within :data:`MODAL_FIRST` iterations): on the residual the modal sweep leaves, one symmetric block
   Gauss–Seidel sweep over the ζ-slices, each slice's diagonal block
   A M_ζ[k,k] + C W_ζ[k,k] + M_xy K_ζ[k,k] by its own 2-D LU.  In the modes the drift
   ζ ∂/∂y couples neighbours, and on fine y-scales more strongly than their damping
   n/τ separates them (the modal sweep alone: 55 iterations on 16 × 24 × 12 cells,
   299 on 16 × 48 × 12); on a ζ-slice that drift is local, so the slices take those
   scales (65 iterations on 16 × 48 × 12), the modes the ζ-coupling.

GMRES on the mode system, restarted every ``restart`` iterations.  Measured
alternatives (paper case, 4·10⁴ unknowns): pyamg's smoothed aggregation
(nonsymmetric) stalls at residual 1, pyamg's AIR did not finish its setup in 300 s,
SciPy's ILU (drop 1e-3) 28 s, direct SuperLU 66 s; this solver about 1 s
(docs/measurements.md, §Coloured noise).
"""
from __future__ import annotations

import math
import time
from typing import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..budget import MEMORY_SHARE, available_memory, forced, human_bytes
from .._checks import InputError
from ..progress import Progress
from .amg import SolverNotConverged
from .coloured_operator import ColouredOperator
from .direct import pinned_system

__all__ = ["ModeSolver", "zeta_modes", "solve_lu", "MODAL_FIRST"]

#: GMRES iterations with the modal sweep alone before ``smoother="auto"`` adds the
#: slice sweep (paper case: 24 × 36 × 18 cells converge in 128 modal-only iterations,
#: 17 s, against 89 with both sweeps, 27 s; 16 × 48 × 12 needs 299 modal-only, 34 s,
#: against 65 with both, 16 s).
MODAL_FIRST = 200


def zeta_modes(op: ColouredOperator) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(λ, U, V, W̃) of the module docstring, λ in decreasing order (λ_0 = 0)."""
    Kz, Mz, Wz = (op.parts[k].toarray() for k in ("Kz", "Mz", "Wz"))
    lam, U, V = sla.eig(Kz, Mz, left=True, right=True)
    if np.max(np.abs(lam.imag)) > 1e-8 * np.max(np.abs(lam)):
        raise RuntimeError("fem: the discrete ζ-generator has complex eigenvalues "
                           f"(largest imaginary part {np.max(np.abs(lam.imag)):.2e}); "
                           "refine nz")
    order = np.argsort(-lam.real)
    lam, U, V = lam.real[order], U.real[:, order], V.real[:, order]
    U = U / np.diag(U.T @ Mz @ V)[None, :]
    return lam, U, V, U.T @ Wz @ V


#: Resident bytes per entry of a SuperLU factor (measured: 106 MB for 4.7·10⁶ entries;
#: its supernodes hold more than the 12 bytes of a CSR entry).
FACTOR_BYTES = 22

#: Modes below this keep factors of their own; above, modes whose λ − σ lie within a
#: factor GROUP of each other share the factors of one representative (a preconditioner
#: need not be exact: SuperLU keeps ~106 MB per 2-D factor of 2.5·10⁴ unknowns, so
#: 161 ζ-modes would need 17 GB; grouped, 40).
EXACT_MODES = 16
GROUP = 1.15


def _shared_shift(lam: float, k: int) -> float:
    """The λ whose factors mode k uses (:data:`EXACT_MODES`, :data:`GROUP`)."""
    if k < EXACT_MODES or lam >= -1e-12:
        return float(lam)
    step = math.log(GROUP)
    return -math.exp(round(math.log(-lam) / step) * step)


def _lu(A: sp.spmatrix) -> tuple[Callable, int]:
    """COLAMD SuperLU of A (as Aᵀ in CSC, solved transposed): (solve, nnz of factors)."""
    lu = spla.splu(sp.csr_matrix(A).T.tocsc(), permc_spec="COLAMD", diag_pivot_thresh=0.1)
    return (lambda v: lu.solve(v, trans="T")), int(lu.L.nnz + lu.U.nnz)


class ModeSolver:
    """The preconditioned mode system of one :class:`ColouredOperator` (module
    docstring); ``info`` holds the factor memory and set-up seconds.

    Raises
    ------
    InputError
        Before the bulk of the factorisations, when the factors of the first mode
        predict more memory than :data:`fpk_vibro.budget.MEMORY_SHARE` of what is
        available (``budget.unlimited()`` lifts it).
    """

    def __init__(self, op: ColouredOperator, *, coupled: int = 2, restart: int = 100,
                 smoother: bool | str = "auto", shift: float = 0.0,
                 progress: bool | None = None) -> None:
        t0 = time.perf_counter()
        # shift σ > 0: the factors are those of L − σM (a time step's), no pin
        self.shift = float(shift)
        self.pinned = self.shift == 0.0
        self.op = op
        P = op.parts
        self.A, self.Mxy, self.C = P["A"].tocsr(), P["Mxy"].tocsr(), P["C"].tocsr()
        self.lam, self.U, self.V, self.Wt = zeta_modes(op)
        lam = self.lam - self.shift
        n2, nm = self.A.shape[0], self.lam.size
        self.n2, self.nm, self.restart = n2, nm, int(restart)
        self._Uinv, self._Vinv = np.linalg.inv(self.U), np.linalg.inv(self.V)
        self._sigma = self.shift
        self.K = K = max(1, min(int(coupled), nm))
        unit2 = np.asarray(self.Mxy.sum(axis=0)).ravel()
        self.pin = int(np.argmax(unit2))
        # "auto": the slice sweep is added (factorised) only when GMRES with the modal
        # sweep alone has not converged after MODAL_FIRST iterations
        self.smoother = smoother is True
        self._auto = smoother == "auto"
        steps = nm * (2 if self.smoother else 1)
        bar = Progress(progress, "fem coloured: factorising the ζ-modes and slices",
                       float(steps))
        try:
            self._solve, nnz, shared = {}, 0, {}
            for k in range(K, nm):
                key = _shared_shift(lam[k], k)
                if key in shared:                   # a high mode: a neighbour's factors
                    self._solve[k] = shared[key]
                    continue
                solve, f = _lu(self.A + key * self.Mxy)
                self._solve[k] = shared[key] = solve
                nnz += f
                if k == K:
                    distinct = len({_shared_shift(lam[j], j) for j in range(K, nm)})
                    self._check_memory(f * (distinct + K * K * 3
                                            + (nm if self.smoother else 0)),
                                       op.size)     # ("auto": the slices when added)
                bar.update(k - K + 1)
            rows = [[(self.A + lam[i] * self.Mxy if i == j else None) for j in range(K)]
                    for i in range(K)]
            for i in range(K):
                for j in range(K):
                    if self.Wt[i, j] != 0.0:
                        extra = self.Wt[i, j] * self.C
                        rows[i][j] = extra if rows[i][j] is None else rows[i][j] + extra
            block = sp.bmat(rows, format="csr")
            if self.pinned:
                block = pinned_system(block, np.ones(K * n2), self.pin)[0]
            self._block, f = _lu(block)
            nnz += f
            bar.update(nm)
            if self.smoother:
                nnz += self._factor_slices(bar)
        finally:
            bar.close()
        self.info = {"modes": nm, "coupled_modes": K, "mode_factors": len(shared),
                     "factor_nnz": nnz,
                     "factor_bytes": FACTOR_BYTES * nnz,
                     "setup_seconds": time.perf_counter() - t0}
        self._describe()

    def _describe(self) -> None:
        self.info["solver"] = (f"gmres on ζ-modes ({self.K} coupled + block Gauss-Seidel"
                               + (", symmetric ζ-slice sweep)" if self.smoother else ")"))

    def _add_smoother(self) -> bool:
        """Factorise the slices for the slice sweep; False (and ``info["smoother"]``
        says why) when their predicted memory is beyond the limit: GMRES goes on with
        the modal sweep alone."""
        per = self.info["factor_nnz"] / max(1, self.info["mode_factors"] + 3 * self.K ** 2)
        try:       # (what this adds, against the memory available now)
            self._check_memory(per * self.nm, self.op.size)
        except InputError as exc:
            self.info["smoother"] = f"not added: {exc}"
            self._auto = False
            return False
        t0 = time.perf_counter()
        bar = Progress(None, "fem coloured: factorising the ζ-slices", float(2 * self.nm))
        try:
            nnz = self._factor_slices(bar)
        finally:
            bar.close()
        self.smoother = True
        self.info["factor_nnz"] += nnz
        self.info["factor_bytes"] += FACTOR_BYTES * nnz
        self.info["setup_seconds"] += time.perf_counter() - t0
        self._describe()
        return True

    def _factor_slices(self, bar: Progress) -> int:
        """The diagonal blocks of L over the ζ-slices, factorised, and each slice's
        neighbours (l, M_ζ[k, l], W_ζ[k, l], K_ζ[k, l]); nnz of the factors."""
        P = self.op.parts
        Mz, Wz, Kz = (P[k].toarray() for k in ("Mz", "Wz", "Kz"))
        Kz = Kz - self.shift * Mz
        self._slice, self._neighbours, nnz = {}, {}, 0
        for k in range(self.nm):
            self._slice[k], f = _lu(self.A * Mz[k, k] + self.C * Wz[k, k] + self.Mxy * Kz[k, k])
            nnz += f
            cols = np.flatnonzero((Mz[k] != 0) | (Wz[k] != 0) | (Kz[k] != 0))
            self._neighbours[k] = [(int(l), (Mz[k, l], Wz[k, l], Kz[k, l]))
                                   for l in cols if l != k]
            bar.update(self.nm + k + 1)
        return nnz

    @staticmethod
    def _check_memory(factor_nnz: float, size: int) -> None:
        need = FACTOR_BYTES * factor_nnz + 8.0 * size * 110
        limit = MEMORY_SHARE * available_memory()
        if need > limit and not forced():
            raise InputError(f"fem: the coloured-noise solve of {size} unknowns needs an "
                             f"estimated {human_bytes(need)} (factors of every ζ-mode and "
                             f"the Krylov basis); the limit is {human_bytes(limit)}; use "
                             "smaller nx, ny, nz or force it (--force)", where="fem",
                             name="nz")

    # mode coefficients Q (n2 × nm) <-> p (Kronecker order, ζ fastest)
    def to_density(self, q: np.ndarray) -> np.ndarray:
        return (q.reshape(self.n2, self.nm) @ self.V.T).ravel()

    def _apply(self, q: np.ndarray, shift: float | None = None) -> np.ndarray:
        """L − σM in the modes (σ = ``shift``, default the factors'); the pinned row
        when σ = 0."""
        sigma = self.shift if shift is None else shift
        Q = q.reshape(self.n2, self.nm)
        Y = self.A @ Q + (self.Mxy @ Q) * (self.lam - sigma) + self.C @ (Q @ self.Wt.T)
        if sigma == 0.0:
            Y[self.pin, 0] = Q[self.pin, 0]
        return Y.ravel()

    def _modal_sweep(self, r: np.ndarray) -> np.ndarray:
        R = r.reshape(self.n2, self.nm)
        K = self.K
        Q = np.zeros_like(R)
        rhs = R[:, :K].copy()
        Q[:, :K] = self._block(rhs.T.ravel()).reshape(K, self.n2).T
        for k in range(K, self.nm):                  # upward (W̃ is tridiagonal only
            # for the resolved low modes)
            Q[:, k] = self._solve[k](R[:, k] - self.C @ (Q[:, :k] @ self.Wt[k, :k]))
        return Q.ravel()

    def _slice_sweep(self, R: np.ndarray) -> np.ndarray:
        """Symmetric block Gauss–Seidel over the ζ-slices (nodal residual R, n2 × nm);
        A z_l, C z_l, M_xy z_l are kept per slice, so each slice solve costs three
        2-D products."""
        Z = np.zeros_like(R)
        AZ, CZ, MZ = np.zeros_like(R), np.zeros_like(R), np.zeros_like(R)
        order = list(range(self.nm)) + list(range(self.nm - 2, -1, -1))
        for k in order:
            rhs = R[:, k].copy()
            for l, (mz, wz, kz) in self._neighbours[k]:
                rhs -= mz * AZ[:, l] + wz * CZ[:, l] + kz * MZ[:, l]
            z = self._slice[k](rhs)
            Z[:, k], AZ[:, k], CZ[:, k], MZ[:, k] = z, self.A @ z, self.C @ z, self.Mxy @ z
        return Z

    def _precondition(self, r: np.ndarray) -> np.ndarray:
        """The modal sweep, then (``smoother``) one symmetric sweep over the ζ-slices
        on what it left (module docstring)."""
        z = self._modal_sweep(r)
        if not self.smoother:
            return z
        left = (r - self._apply(z, self._sigma)).reshape(self.n2, self.nm) @ self._Uinv
        return z + (self._slice_sweep(left) @ self._Vinv.T).ravel()

    def _gmres(self, b: np.ndarray, sigma: float, tol: float, maxiter: int,
               progress: bool | None, x0: np.ndarray | None = None
               ) -> tuple[np.ndarray, int]:
        """GMRES to ``tol``; with ``smoother="auto"`` first with the modal sweep alone
        for :data:`MODAL_FIRST` iterations, then on from there with the slice sweep."""
        first = 0
        if self._auto and not self.smoother:
            q, first, res = self._krylov(b, sigma, tol, min(MODAL_FIRST, maxiter), progress, x0)
            if np.isfinite(res) and res <= 10 * tol:
                return q, first
            x0 = q if np.all(np.isfinite(q)) else x0
            self._add_smoother()
        q, its, res = self._krylov(b, sigma, tol, maxiter - first, progress, x0)
        if not np.isfinite(res) or res > 10 * tol:
            raise SolverNotConverged("fem coloured gmres", first + its, res, tol)
        return q, first + its

    def _krylov(self, b, sigma, tol, maxiter, progress, x0):
        N = self.n2 * self.nm
        self._sigma = sigma
        A = spla.LinearOperator((N, N), matvec=lambda q: self._apply(q, sigma), dtype=float)
        M = spla.LinearOperator((N, N), matvec=self._precondition, dtype=float)
        count = [0]
        bar = Progress(progress, "fem coloured: GMRES", float(maxiter), unit="it")

        def step(_):
            count[0] += 1
            bar.update(count[0])
        try:
            q, _ = spla.gmres(A, b, x0=x0, M=M, rtol=tol, restart=min(self.restart, N),
                              maxiter=max(1, -(-maxiter // self.restart)), callback=step,
                              callback_type="pr_norm")
        finally:
            bar.close()
        res = float(np.linalg.norm(A @ q - b) / max(np.linalg.norm(b), 1e-300))
        return q, count[0], res

    def solve(self, *, tol: float = 1e-10, maxiter: int = 1000,
              progress: bool | None = None) -> tuple[np.ndarray, dict]:
        """The stationary density (σ = 0): (p normalised to ∫ p = 1 in Kronecker order,
        info: iterations, residual (the backward error of L p = 0), seconds).

        Raises
        ------
        SolverNotConverged
            If GMRES misses ``tol`` (never an unconverged density).
        """
        if not self.pinned:
            raise ValueError("ModeSolver.solve: the stationary solve needs shift = 0")
        t0 = time.perf_counter()
        b = np.zeros(self.n2 * self.nm)
        b[self.pin * self.nm] = 1.0
        q, its = self._gmres(b, 0.0, tol, maxiter, progress)
        p = self.to_density(q)
        p /= float(self.op.unit @ p)
        L = self.op.L
        backward = float(np.max(np.abs(L @ p)) / (abs(L).sum(axis=1).max() * np.max(np.abs(p))))
        return p, {"iterations": its, "residual": backward,
                   "solve_seconds": time.perf_counter() - t0}

    def step(self, rhs: np.ndarray, sigma: float, *, tol: float = 1e-10,
             x0: np.ndarray | None = None) -> tuple[np.ndarray, int]:
        """x with (σ M − L) x = ``rhs`` (Kronecker order), σ > 0, preconditioned by the
        factors of this solver's shift (exact when σ equals it); (x, iterations)."""
        R = -rhs.reshape(self.n2, self.nm) @ self.U
        q0 = None if x0 is None else (x0.reshape(self.n2, self.nm) @ self._Vinv.T).ravel()
        q, its = self._gmres(R.ravel(), sigma, tol, 600, False, q0)
        return self.to_density(q), its


def solve_lu(op: ColouredOperator) -> tuple[np.ndarray, dict]:
    """The same density by one sparse LU of the pinned 3-D system (COLAMD): the
    benchmark's comparison; it does not scale (66 s at 4·10⁴ unknowns)."""
    t0 = time.perf_counter()
    A, b, _ = pinned_system(op.L, op.unit)
    solve, nnz = _lu(A)
    p = solve(b)
    p /= float(op.unit @ p)
    return p, {"factor_nnz": nnz, "factor_bytes": FACTOR_BYTES * nnz,
               "solve_seconds": time.perf_counter() - t0}
