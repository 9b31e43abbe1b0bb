"""Harmonic balance for the periodic FPK: the time-Fourier coefficients of the
periodic density on one FE discretisation (:func:`solve_harmonics`).

Under F cos ψ, ψ = Ωt + φ0, the semi-discrete FPK is M ṗ = (L0 + F cos ψ L1) p, with
L0 the generator of the unforced system (:mod:`fpk_vibro.fem.generator`) and L1 the
Galerkin form of the forcing's drift, (L1)_{ij} = ∫ φ_j ∂φ_i/∂y (the y-transport
term of ∫ J·∇q with drift 1; its columns sum to zero, so it keeps the mass).  With
p(t) = Σ_{k=−K..K} p_k e^{ikψ}, p_{−k} = conj(p_k):

    (L0 − ikΩ M) p_k + (F/2) L1 (p_{k−1} + p_{k+1}) = 0,   p_{±(K+1)} = 0,

with ∫ p_0 = 1 (one row of the k = 0 block replaced, as the stationary solve does;
the k ≠ 0 rows keep ∫ p_k = 0 by themselves since 1ᵀL0 = 1ᵀL1 = 0).  Unknowns
are real: u_0 = p_0 and (u_k, v_k) = (Re p_k, Im p_k), k = 1..K.

The block-tridiagonal system is solved by GMRES preconditioned with one block
Gauss–Seidel sweep over the harmonics (:class:`HarmonicSystem`): z_0 = A_0⁻¹ r_0,
z_k = A_k⁻¹ (r_k − (F/2) L1 z_{k−1}) upward, with A_0 the pinned L0 (real LU) and
A_k = L0 − ikΩM (one complex LU per k, COLAMD-ordered: :func:`_complex_lu`; it
solves the real 2 × 2 block of (u_k, v_k) at once).  The sweep is exact for the cascade p_k ≈ −A_k⁻¹ (F/2) L1
p_{k−1} that carries the forcing up the harmonics, and leaves out only the
back-reaction of p_{k+1} on p_k; near resonance, where A_1⁻¹ is large, the block
diagonal (Jacobi) preconditioner needed 60–150 iterations (growing with K) where
the sweep needs a few times fewer at the same cost per iteration.  The factors
are kept per k, so raising K or solving again reuses them, and a previous
solution starts GMRES.  One sparse LU of the whole system was measured 10–40×
slower (Q3, 16 × 30 cells, K = 4: 4.4 s against 0.3 s; the couplings between the
harmonics fill its factors like a third dimension); exact block elimination
would need the dense Schur complements A_k − h A_{k+1}⁻¹ h.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem

from . import forms
from .direct import _superlu, pinned_system

__all__ = ["Harmonics", "HarmonicSystem", "forcing_matrix", "solve_harmonics",
           "moment_rows"]


def forcing_matrix(xbasis: skfem.CellBasis, ybasis: skfem.CellBasis,
                   Mx: sp.spmatrix) -> sp.csr_matrix:
    """L1 = Mx ⊗ (∫ χ_l χ_k') in Kronecker order (module docstring)."""
    Cy = skfem.asm(forms.convection_1d, ybasis, coef=(1.0,))
    return sp.kron(Mx, Cy).tocsr()


def moment_rows(xbasis: skfem.CellBasis, ybasis: skfem.CellBasis, Mx, My
                ) -> dict[str, np.ndarray]:
    """Rows w with w·p = ∫ f p for f = 1, x, y (Kronecker order)."""
    ox, oy = np.ones(Mx.shape[0]), np.ones(My.shape[0])
    ix, iy = Mx @ ox, My @ oy
    x1 = skfem.asm(forms.weighted_mass_1d, xbasis, coef=(0.0, 1.0)) @ ox
    y1 = skfem.asm(forms.weighted_mass_1d, ybasis, coef=(0.0, 1.0)) @ oy
    return {"1": np.kron(ix, iy), "x": np.kron(x1, iy), "y": np.kron(ix, y1)}


@dataclass
class Harmonics:
    """The solved coefficients: ``coef[0]`` = p_0 (real, mass 1), ``coef[k]`` = p_k
    (complex, mass 0), k = 1..K, in the discretisation's (Kronecker) order."""
    coef: np.ndarray
    frequency: float
    iterations: int
    residual: float
    seconds: float
    info: dict = field(default_factory=dict)

    @property
    def K(self) -> int:
        return self.coef.shape[0] - 1

    def at(self, phi: float) -> np.ndarray:
        """p at phase φ: p_0 + 2 Σ Re(p_k e^{ikφ})."""
        k = np.arange(1, self.K + 1)
        return self.coef[0].real + 2.0 * (np.exp(1j * k * phi) @ self.coef[1:]).real

    def tail(self, unit: np.ndarray) -> np.ndarray:
        """‖2 p_k‖ (lumped L1: Σ |p_k|_i ∫φ_i) for k = 0..K (k = 0: ‖p_0‖)."""
        out = np.abs(self.coef) @ np.abs(unit)
        out[1:] *= 2.0
        return out


class HarmonicSystem:
    """The harmonic-balance system of one discretisation (module docstring), its
    factorisations A_k kept across solves (raise K, solve again, warm start).

    ``sweep``: "gs" (one upward block Gauss–Seidel sweep, default), "sgs" (up and
    down: twice the solves per iteration) or "jacobi" (the block diagonal).
    """

    def __init__(self, L0: sp.csr_matrix, M: sp.csr_matrix, L1: sp.csr_matrix,
                 unit: np.ndarray, F: float, Omega: float, *, sweep: str = "gs") -> None:
        t0 = time.perf_counter()
        self.L0, self.M, self.unit = L0.tocsr(), M.tocsr(), unit
        self.F, self.Omega, self.sweep = float(F), float(Omega), sweep
        self.hL = ((0.5 * F) * L1).tocsr()
        # pin where the unforced density peaks (the one at max ∫φ may sit in its tail,
        # scaling the pinned solution by 1e14 and GMRES's residual with it)
        A0, b0, pin = pinned_system(L0, unit)
        p_s = _superlu(A0)(b0)
        A0, _, pin = pinned_system(L0, unit, int(np.argmax(p_s * np.abs(unit))))
        self.pin = pin
        self.p_unforced = p_s / float(unit @ p_s)
        self._lu = {0: _superlu(A0)}
        self.factor_seconds = time.perf_counter() - t0
        self._norm = max(abs(L0).sum(axis=1).max(), abs(M).sum(axis=1).max(), 1.0)

    def factors(self, k: int):
        """The solve of A_k (factorised on first use)."""
        if k not in self._lu:
            t0 = time.perf_counter()
            self._lu[k] = _complex_lu(sp.csr_matrix(self.L0 - (1j * k * self.Omega) * self.M))
            self.factor_seconds += time.perf_counter() - t0
        return self._lu[k]

    # complex blocks P (n × (K + 1), column 0 real) <-> GMRES's real vector
    # [u_0, u_1, v_1, ..., u_K, v_K]
    @staticmethod
    def _blocks(x: np.ndarray, n: int, K: int) -> np.ndarray:
        X = x.reshape(2 * K + 1, n)
        P = np.empty((n, K + 1), complex)
        P[:, 0] = X[0]
        P[:, 1:] = (X[1::2] + 1j * X[2::2]).T
        return P

    @staticmethod
    def _vector(P: np.ndarray) -> np.ndarray:
        n, K = P.shape[0], P.shape[1] - 1
        X = np.empty((2 * K + 1, n))
        X[0] = P[:, 0].real
        X[1::2], X[2::2] = P[:, 1:].real.T, P[:, 1:].imag.T
        return X.ravel()

    def _apply(self, P: np.ndarray) -> np.ndarray:
        """The block-tridiagonal operator on complex blocks (pin row of block 0)."""
        K = P.shape[1] - 1
        k = np.arange(K + 1)
        out = self.L0 @ P - (1j * self.Omega) * (self.M @ P) * k
        if K:
            Q = np.zeros_like(P)
            Q[:, :-1] += P[:, 1:]               # p_{k+1}
            Q[:, 1:] += P[:, :-1]               # p_{k−1}
            Q[:, 0] = 2.0 * P[:, 1].real        # p_{−1} + p_1 = 2 Re p_1
            out += self.hL @ Q
        out[:, 0] = out[:, 0].real
        out[self.pin, 0] = P[self.pin, 0].real
        return out

    def _couple0(self, z1: np.ndarray) -> np.ndarray:
        c = 2.0 * (self.hL @ z1.real)
        c[self.pin] = 0.0
        return c

    def _precondition(self, R: np.ndarray) -> np.ndarray:
        K = R.shape[1] - 1
        Z = np.empty_like(R)
        if self.sweep == "jacobi":
            Z[:, 0] = self._lu[0](R[:, 0].real)
            for k in range(1, K + 1):
                Z[:, k] = self._lu[k](R[:, k])
            return Z
        Z[:, 0] = self._lu[0](R[:, 0].real)
        for k in range(1, K + 1):              # upward: the forcing's cascade
            Z[:, k] = self._lu[k](R[:, k] - self.hL @ Z[:, k - 1])
        if self.sweep == "sgs" and K:          # downward: the back-reaction
            for k in range(K - 1, 0, -1):
                Z[:, k] = self._lu[k](R[:, k] - self.hL @ (Z[:, k - 1] + Z[:, k + 1]))
            Z[:, 0] = self._lu[0](R[:, 0].real - self._couple0(Z[:, 1]))
        return Z

    def solve(self, K: int, *, start: "Harmonics | None" = None, tol: float = 1e-13,
              maxiter: int = 400) -> "Harmonics":
        """The coefficients p_0..p_K (module docstring); ``start``: a previous solution
        (any K) on this discretisation, padded or cut to K.

        Raises
        ------
        RuntimeError
            If GMRES does not reach a backward error of 1e-9 (never an unconverged
            density).
        """
        t0 = time.perf_counter()
        f0 = self.factor_seconds
        for k in range(1, K + 1):
            self.factors(k)
        n = self.L0.shape[0]
        N = (2 * K + 1) * n
        # the pinned value of the normalised unforced density: the solution has the
        # density's scale, so a backward error of round-off is an absolute residual
        # GMRES can reach (pinned to 1, |x| reached 4e6 and GMRES a relative 1e-10
        # of ‖b‖ only after 100-600 iterations where 8 gave 1e-13 backward error)
        b = np.zeros(N)
        b[self.pin] = self.p_unforced[self.pin]
        scale = max(self._norm, self.Omega * K * self._norm) * np.max(
            np.abs(self.p_unforced))
        x0 = None
        if start is not None:
            P = np.zeros((n, K + 1), complex)
            m = min(K, start.K) + 1
            P[:, :m] = (start.coef[:m] * (b[self.pin] / start.coef[0][self.pin].real)).T
            x0 = self._vector(P)
        count = [0]
        A = spla.LinearOperator(
            (N, N), dtype=float,
            matvec=lambda x: self._vector(self._apply(self._blocks(x, n, K))))
        Pre = spla.LinearOperator(
            (N, N), dtype=float,
            matvec=lambda x: self._vector(self._precondition(self._blocks(x, n, K))))
        x, _ = spla.gmres(A, b, x0=x0, M=Pre, rtol=0.0, atol=tol * scale,
                          restart=min(N, 60),
                          maxiter=max(1, maxiter // 60),
                          callback=lambda _: count.__setitem__(0, count[0] + 1),
                          callback_type="pr_norm")
        r = A.matvec(x) - b
        res = float(np.max(np.abs(r)) / (scale / np.max(np.abs(self.p_unforced))
                                          * np.max(np.abs(x)) + 1e-300))
        if not np.isfinite(res) or res > 1e-9:
            raise RuntimeError(f"fem.periodic: the harmonic-balance GMRES stopped at "
                               f"backward error {res:.2e} after {count[0]} iterations "
                               f"(K = {K})")
        P = self._blocks(x, n, K)
        mass = float(self.unit @ P[:, 0].real)
        coef = np.ascontiguousarray(P.T) / mass
        coef[0] = coef[0].real
        return Harmonics(coef, self.Omega, count[0], res, time.perf_counter() - t0,
                         {"factor_seconds": self.factor_seconds - f0, "pin": self.pin,
                          "sweep": self.sweep})


def _complex_lu(A: sp.csr_matrix):
    """SuperLU of a complex block by COLAMD (Aᵀ in CSC, solved transposed).  The MMD
    order of :func:`~fpk_vibro.fem.direct._superlu` gave 2.3× less fill but took
    1.7-4 s instead of 0.05-0.09 s for some k at the same fill (Q3, 5e3 DOFs,
    measured; subnormal entries, presumably), which no later solve repays."""
    lu = spla.splu(A.T, permc_spec="COLAMD", diag_pivot_thresh=0.01,
                   options={"SymmetricMode": True})
    return lambda v: lu.solve(v, trans="T")


def solve_harmonics(L0: sp.csr_matrix, M: sp.csr_matrix, L1: sp.csr_matrix,
                    unit: np.ndarray, F: float, Omega: float, K: int, *,
                    tol: float = 1e-13, maxiter: int = 400, sweep: str = "gs"
                    ) -> Harmonics:
    """The coefficients p_0..p_K of the module docstring (one
    :class:`HarmonicSystem`, solved once)."""
    return HarmonicSystem(L0, M, L1, unit, F, Omega, sweep=sweep).solve(
        K, tol=tol, maxiter=maxiter)
