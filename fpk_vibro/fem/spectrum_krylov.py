"""The reduced model of an FE spectrum: rational Krylov on the shifted generator.

With ``M dp/dt = L p`` the FE generator (:mod:`fpk_vibro.fem.generator`), u0 the FE
function (q − m) p_s (mass 0) and g the functional v ↦ ∫ (q − m) v, the correlation
is R(τ) = gᵀ e^{τ M⁻¹L} u0 and its one-sided Laplace transform is the transfer
function H(s) = gᵀ (sM − L)⁻¹ M u0, so S(ω) = Re H(iω) / π.

:func:`reduce` builds an orthonormal real basis V of

    span{u0} + Σ_j K_k((σ_j M − L)⁻¹ M, u0),

one sparse complex LU per shift σ_j (the chains cycled round by round; the real and
imaginary parts of each complex vector go into V, so the model is real and its
poles come in conjugate pairs), and projects:  K = (VᵀMV)⁻¹ VᵀLV, u_r = Vᵀu0,
g_r = Vᵀg.  The reduced model interpolates H at every σ_j (and its conjugate) to the
order of the chain, and matches it at s = ∞ (u0 ∈ V): R_r(0) = gᵀu0 exactly, so the
reduced ∫ S dω over the real line is the FE variance (of a stable model: see
:class:`ReducedModel` for an unstable part).  Every vector has zero mass
(1ᵀ(σM − L) = σ 1ᵀM keeps it), the round-off being removed along p_s, so the null
mode p_s of L never enters and ω = 0 needs no special case.  Rounds are added until
S on the requested ω (and on a check grid over the band) changes by less than
``tol`` (relative to max S) from one round to the next; that change is the
truncation estimate.

R(τ) converges more slowly than S near τ = 0, which depends on the frequencies
beyond the shifts (R_yy has the cusp of the impacts' velocity jumps); the last
round's change of R, which the estimate reports, bounds it (docs/measurements.md,
§FE spectra).
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

__all__ = ["ReducedModel", "reduce", "SPLU", "MAX_SIZE"]

#: SuperLU options of σM − L: minimum degree on Aᵀ + A with diagonal pivots preferred
#: (measured on Q4 16 × 32, 8 385 DOFs: 0.04 s against 0.12 s with COLAMD and 0.7 s
#: without SymmetricMode; at 33 153 DOFs 0.33 s, 1.4 s and 219 s).
SPLU = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.01,
        "options": {"SymmetricMode": True}}
#: The largest reduced basis (real vectors).
MAX_SIZE = 400
#: The eigenvector matrix of the reduced K is trusted for the pole-residue form up to
#: this condition number (else batched solves and matrix exponentials are used).
COND_MAX = 1e8
#: The lag step times the highest frequency that matters (:meth:`ReducedModel.lag_span`).
LAG_STEP = 0.02
#: Rows of ω or τ evaluated at once (memory: CHUNK × basis size complex).
CHUNK = 4096


class _Triple:
    """h(s) = gᵀ (s − K)⁻¹ u and r(τ) = gᵀ e^{τK} u of a small real K: by poles and
    residues where the eigenvectors are well conditioned, else by batched solves
    and matrix exponentials."""

    def __init__(self, K: np.ndarray, u: np.ndarray, g: np.ndarray) -> None:
        self.K, self.u, self.g = K, u, g
        self.size = int(K.shape[0])
        if self.size == 0:
            self.poles, self.residues, self.modal = np.zeros(0, complex), np.zeros(0, complex), True
            return
        self.poles, X = np.linalg.eig(K)
        try:
            right = np.linalg.solve(X, u.astype(complex))
            cond = float(np.linalg.cond(X))
        except np.linalg.LinAlgError:
            right, cond = np.zeros(self.size, complex), math.inf
        #: residues a_j: h(s) = Σ a_j / (s − λ_j), r(τ) = Re Σ a_j e^{λ_j τ}
        self.residues = (g @ X) * right
        r0 = float(g @ u)
        self.modal = bool(cond < COND_MAX and abs(self.residues.sum() - r0)
                          <= 1e-9 * max(abs(r0), 1e-300))

    def transfer(self, omega: np.ndarray) -> np.ndarray:
        out = np.zeros(omega.size, complex)
        if self.size == 0:
            return out
        eye = np.eye(self.size)
        for i in range(0, omega.size, CHUNK):
            s = 1j * omega[i:i + CHUNK]
            if self.modal:
                out[i:i + CHUNK] = (self.residues / (s[:, None] - self.poles)).sum(axis=1)
            else:
                A = s[:, None, None] * eye - self.K
                b = np.broadcast_to(self.u.astype(complex), (s.size, self.size))
                out[i:i + CHUNK] = np.linalg.solve(A, b[..., None])[..., 0] @ self.g
        return out

    def correlation(self, lags: np.ndarray) -> np.ndarray:
        lags = np.asarray(lags, float)
        if self.size == 0:
            return np.zeros(lags.size)
        if self.modal:
            out = np.empty(lags.size)
            for i in range(0, lags.size, CHUNK):
                e = np.exp(np.outer(lags[i:i + CHUNK], self.poles))
                out[i:i + CHUNK] = (e @ self.residues).real
            return out
        # (fallback: e^{ΔK} per distinct step, a k × k product per lag)
        out, v = np.empty(lags.size), sla.expm(self.K * lags[0]) @ self.u
        steps: dict[float, np.ndarray] = {}
        for i in range(lags.size):
            if i:
                h = float(lags[i] - lags[i - 1])
                key = round(h, 12)
                if key not in steps:
                    steps[key] = sla.expm(self.K * h)
                v = steps[key] @ v
            out[i] = self.g @ v
        return out


class ReducedModel:
    """The reduced model of the module docstring, split into its stable and unstable
    parts.

    The Galerkin FE generator itself has a few spurious growing modes at high
    frequency on coarse meshes (measured: Q2 on 6 × 6 cells Re λ = 0.41 at
    |Im λ| = 12.7; Q4 on 9 × 8 cells 1.76 at 54; none on the paper case's levels
    within the reduced models).  A model that picked them up is split by the
    ordered real Schur form, K = Q [[T11, T12], [0, T22]] Qᵀ with the poles of T11 in
    the open left half-plane, and the Sylvester solve T11 X − X T22 = −T12 that
    decouples the blocks: S and R are those of the stable part (so that S is the
    cosine transform of R); the unstable part's share is :attr:`dropped` (its R(0),
    relative) and :meth:`dropped_transfer`, which the estimate adds.
    """

    def __init__(self, K: np.ndarray, ur: np.ndarray, gr: np.ndarray) -> None:
        self.size = int(K.shape[0])
        self.total = float(gr @ ur)
        lam = np.linalg.eigvals(K)
        self.growth = float(lam.real.max())
        if self.growth < 0:
            self.stable, self.unstable = _Triple(K, ur, gr), _Triple(np.zeros((0, 0)),
                                                                    np.zeros(0), np.zeros(0))
        else:
            T, Q, m = sla.schur(K, output="real", sort=lambda re, im: re < 0)
            X = sla.solve_sylvester(T[:m, :m], -T[m:, m:], -T[:m, m:])
            z, h = Q.T @ ur, Q.T @ gr
            self.stable = _Triple(T[:m, :m], z[:m] - X @ z[m:], h[:m])
            self.unstable = _Triple(T[m:, m:], z[m:], h[:m] @ X + h[m:])
        self.poles, self.residues = self.stable.poles, self.stable.residues
        self.modal = self.stable.modal

    @property
    def variance(self) -> float:
        """g_rᵀ u_r: the FE variance (exactly: u0 lies in the basis)."""
        return self.total

    @property
    def dropped(self) -> float:
        """|R(0)| of the unstable part over the variance (0 for a stable model)."""
        r0 = float(self.unstable.g @ self.unstable.u) if self.unstable.size else 0.0
        return abs(r0) / abs(self.total) if self.total else 0.0

    def dropped_transfer(self, omega: np.ndarray) -> np.ndarray:
        """|H(iω)| / π of the unstable part (zeros for a stable model)."""
        return np.abs(self.unstable.transfer(omega)) / math.pi

    def transfer(self, omega: np.ndarray) -> np.ndarray:
        """H_r(iω) of the stable part."""
        return self.stable.transfer(np.asarray(omega, float))

    def density(self, omega: np.ndarray) -> np.ndarray:
        """S_r(ω) = Re H_r(iω) / π (two-sided)."""
        return self.transfer(omega).real / math.pi

    def correlation(self, lags: np.ndarray) -> np.ndarray:
        """R_r(τ) of the stable part at increasing ``lags``."""
        return self.stable.correlation(lags)

    def lag_span(self, decays: float = 10.0) -> tuple[float, float]:
        """(τ_max, τ_step): where the envelope Σ|a_j| e^{Re λ_j τ} falls to e^{−decays}
        of its start (``decays`` decay times of the slowest mode that matters), and the
        step h with h ω = :data:`LAG_STEP` for the highest frequency ω among the poles
        that carry all but 1e-3 of Σ|a_j|: linear interpolation between lags
        (``Spectrum.correlation``) is then within (h ω)²/8 = 5e-5 of R(0)."""
        a, lam = np.abs(self.residues), self.poles
        total = float(a.sum())
        if total <= 0 or not np.isfinite(total):
            return 1.0, 1.0 / 64
        rates = np.maximum(-lam.real, 1e-12)
        grid = np.geomspace(1e-3, 1e6, 2000) / float(np.median(rates))
        env = (a[None, :] * np.exp(-np.outer(grid, rates))).sum(axis=1)
        below = np.nonzero(env <= math.exp(-decays) * total)[0]
        tmax = float(grid[below[0]]) if below.size else float(grid[-1])
        order = np.argsort(a)[::-1]
        keep = order[:int(np.searchsorted(np.cumsum(a[order]), (1 - 1e-3) * total)) + 1]
        w = float(np.max(np.abs(lam[keep].imag)))
        w = max(w, float(np.max(rates[keep])))     # (an overdamped mode: its rate)
        return tmax, LAG_STEP / w


def _change(new: np.ndarray, old: np.ndarray) -> float:
    """max |new − old| / max |new|."""
    top = float(np.max(np.abs(new)))
    return float(np.max(np.abs(new - old))) / top if top > 0 else 0.0


class _Basis:
    """The orthonormal real basis V (grown in blocks) with its projections VᵀLV and
    VᵀMV, each kept up to date as a vector is added (two sparse products with L and
    Lᵀ, one with M, which is symmetric): no n × k copies of LV and MV."""

    def __init__(self, L, M, n: int, limit: int) -> None:
        self.L, self.Lt, self.M = L, L.T.tocsc(), M
        self.limit, self.k = limit, 0
        self.V = np.empty((n, min(64, limit)))
        self.Lr = np.empty((limit, limit))
        self.Mr = np.empty((limit, limit))

    @property
    def full(self) -> bool:
        return self.k >= self.limit

    def orthogonal(self, w: np.ndarray) -> np.ndarray:
        """``w`` less its part in span V (classical Gram–Schmidt, twice)."""
        Vk = self.V[:, :self.k]
        for _ in range(2):
            w = w - Vk @ (Vk.T @ w)
        return w

    def push(self, w: np.ndarray) -> bool:
        """Add the new direction of ``w``; False when there is none (or no room)."""
        norm0 = float(np.linalg.norm(w))
        if norm0 == 0.0 or self.full:
            return False
        w = self.orthogonal(w)
        norm = float(np.linalg.norm(w))
        if norm <= 1e-10 * norm0:
            return False
        k = self.k
        if k == self.V.shape[1]:
            grown = np.empty((self.V.shape[0], min(2 * k, self.limit)))
            grown[:, :k] = self.V
            self.V = grown
        v = w / norm
        self.V[:, k] = v
        Vk = self.V[:, :k + 1]
        lv, mv = Vk.T @ (self.L @ v), Vk.T @ (self.M @ v)
        self.Lr[:k + 1, k], self.Mr[:k + 1, k] = lv, mv
        self.Lr[k, :k], self.Mr[k, :k] = Vk[:, :k].T @ (self.Lt @ v), mv[:k]
        self.k += 1
        return True

    def model(self, u0: np.ndarray, g: np.ndarray) -> "ReducedModel":
        k, Vk = self.k, self.V[:, :self.k]
        K = np.linalg.solve(self.Mr[:k, :k], self.Lr[:k, :k])
        return ReducedModel(K, Vk.T @ u0, Vk.T @ g)


def reduce(L, M, u0: np.ndarray, g: np.ndarray, p: np.ndarray, unit: np.ndarray,
           shifts: list[complex], omega: np.ndarray, check: np.ndarray, *, tol: float,
           max_size: int = MAX_SIZE, min_rounds: int = 2
           ) -> tuple[ReducedModel, ReducedModel | None, dict[str, Any]]:
    """The reduced model of the module docstring, grown round by round until S on
    ``omega`` and on ``check`` changes by at most ``tol`` (relative to max S there).

    Returns (model, the model one round smaller or None, info): ``size``, ``rounds``,
    ``change`` (the last change on ``omega``, relative), ``lu_seconds``, ``seconds``.
    """
    t0 = time.perf_counter()
    basis = _Basis(L, M, u0.size, max_size)
    basis.push(u0)
    lus = [spla.splu((s * M - L).tocsc(), **SPLU) for s in shifts]
    t_lu = time.perf_counter() - t0
    chains: list[np.ndarray | None] = [basis.V[:, 0].astype(complex) for _ in shifts]
    model = previous = None
    change, rounds = math.inf, 0
    S_old = None
    while True:
        rounds += 1
        for j, lu in enumerate(lus):
            if chains[j] is None:
                continue
            w = lu.solve(M @ chains[j])
            w -= (unit @ w) * p                 # (round-off mass, along p_s)
            w = basis.orthogonal(w)
            norm = float(np.linalg.norm(w))
            chains[j] = w / norm if norm > 0 else None
            if not (basis.push(w.real) | basis.push(w.imag)):
                chains[j] = None
        previous, model = model, basis.model(u0, g)
        S = model.density(np.concatenate([omega, check]))
        if S_old is not None:
            change = max(_change(S[:omega.size], S_old[:omega.size]),
                         _change(S[omega.size:], S_old[omega.size:]))
        S_old = S
        if (rounds >= min_rounds and change <= tol) or basis.full or \
                all(c is None for c in chains):
            break
    info = {"size": basis.k, "rounds": rounds, "change": change, "lu_seconds": t_lu,
            "shifts": len(shifts), "seconds": time.perf_counter() - t0}
    return model, previous, info
