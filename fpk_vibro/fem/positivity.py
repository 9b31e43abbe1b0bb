"""Positivity-preserving discretisations of the stationary FPK.

Theory: docs/theory.md, §Positivity.  Plain Galerkin goes negative next to (±Δ, 0)
for small r and weak noise (−19 … −26 % of max p at r = 0, −5 … −8 % at r = 0.3,
D1 = 0.002; docs/measurements.md, §Positive generator).  Everything here rests on
one fact: a matrix with non-negative off-diagonals and zero column sums (a
*generator*) has a non-negative null vector (Perron–Frobenius); normalised, it is a
density with mass exactly 1.

A. The positive tensor-grid generator: :mod:`fpk_vibro.fem.positive_grid`
(:func:`positive_generator`).

B. Second order: clipped high-order face values, Picard iteration
-----------------------------------------------------------------
Write the high-order transport face value as g·p_upwind: g = 1 + (3a/8 + b/8)/p_i
(QUICK, a = p_{i+1} − p_i, b = p_i − p_{i−1} along the transport direction),
clipped to [0, 4] (:func:`limiter_factors`; ``"van-albada"`` uses the TVD slope
instead).  For *any* g ≥ 0 the matrix A(g) is a generator, so the stationary
problem A(g(p)) p = 0 is solved by Picard iteration p ← null(A(g(p))), Anderson
accelerated (depth 3), from the first-order solution: every returned iterate is
a generator's normalised null vector — non-negative with mass 1 whether or not
the iteration has converged.  Clipping is the only limiting: the scheme is not a
discrete maximum principle, positivity comes from the generator structure.

C. Algebraic upwinding and AFC of the Galerkin matrix (general meshes): see
:mod:`fpk_vibro.fem.afc`.

Measurements (the exact case, the hard cases, geometry, the paper cases, wide
truncated domains; orders, E[H], Picard iterations, seconds): docs/measurements.md,
§Positive generator.

Open: the first-order wall half-cell (max-norm order 1 at the wall); Picard
iterations (20–150, one sparse LU each) dominate the cost — a Newton step with
the (piecewise smooth) Jacobian of the clipped QUICK factors is the next
speed-up; uniform spacing is assumed by the face values (graded y-meshes stay
positive and conservative but lose accuracy).
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from .._checks import check_float, check_int
from .limiter import LIMITERS, limiter_factors
from .positive_grid import bernoulli, dual_weights, positive_generator, wall_injection
from .solve import SolveInfo

__all__ = ["bernoulli", "dual_weights", "wall_injection", "positive_generator",
           "limiter_factors", "stationary_positive", "LIMITERS"]


def _gmres_right(B, b: np.ndarray, x0: np.ndarray, prec, m: int) -> np.ndarray:
    """m steps of right-preconditioned GMRES (B prec(z) = r), modified Gram–Schmidt."""
    r = b - B @ x0
    beta = float(np.linalg.norm(r))
    if beta == 0.0:
        return x0
    V = np.empty((m + 1, r.size))
    Z = np.empty((m, r.size))
    H = np.zeros((m + 1, m))
    V[0] = r / beta
    k = 0
    for k in range(m):
        Z[k] = prec(V[k])
        w = B @ Z[k]
        for i in range(k + 1):
            H[i, k] = w @ V[i]
            w -= H[i, k] * V[i]
        H[k + 1, k] = np.linalg.norm(w)
        if H[k + 1, k] <= 1e-14 * beta:
            break
        V[k + 1] = w / H[k + 1, k]
    k += 1
    e = np.zeros(k + 1)
    e[0] = beta
    yk = np.linalg.lstsq(H[:k + 1, :k], e, rcond=None)[0]
    return x0 + yk @ Z[:k]


class _FrozenLU:
    """The Picard steps' linear solves: GMRES(``inner``) on the pinned system, right-
    preconditioned with the LU of an earlier step's matrix (the limited generators
    of successive steps differ little).  The error is then estimated as
    ‖LU⁻¹(b − B x)‖∞ / ‖x‖∞; above ``err`` the matrix is factorised afresh.
    Used only up to ``max_n`` unknowns (beyond it GMRES cost more than an LU here;
    a size rule, not a timer, so that results do not depend on machine load).  The
    Picard iterate is not required to be ≥ 0; the returned density is (the caller
    ends with an exact solve)."""

    def __init__(self, unit: np.ndarray, grid, pin: int, inner: int = 10,
                 max_n: int = 12000) -> None:
        from .solve import grid_nested_dissection
        self.unit, self.pin, self.inner = unit, pin, inner
        self.perm = grid_nested_dissection(*grid)
        self.lu = None
        self.factorizations = 0
        self.frozen = unit.size <= max_n

    def _apply(self, v: np.ndarray) -> np.ndarray:
        return self.lu(v)

    def _factor(self, B: sp.csr_matrix) -> None:
        from .solve import nd_lu
        self.lu = nd_lu(B, self.perm)
        self.factorizations += 1

    def solve(self, A: sp.spmatrix, x0: np.ndarray, err: float) -> np.ndarray:
        """The null vector of A (pinned at ``pin``) to estimated relative error
        ``err``, normalised to unit mass."""
        from .solve import pinned_system
        B, b, _ = pinned_system(A, self.unit, self.pin)
        done = False
        if self.lu is not None and self.frozen and x0[self.pin] > 0:
            x = _gmres_right(B, b, x0 / x0[self.pin], self._apply, self.inner)
            done = np.max(np.abs(self._apply(b - B @ x))) <= err * np.max(np.abs(x))
        if not done:
            self._factor(B)
            x = self._apply(b)
        return x / float(self.unit @ x)


def stationary_positive(system, xnodes: np.ndarray, ynodes: np.ndarray, walls, *,
                        limit: bool = True, scheme: str = "quick", tol: float = 1e-9,
                        maxiter: int = 300, anderson: int = 3
                        ) -> tuple[np.ndarray, SolveInfo, dict]:
    """Non-negative stationary density on a tensor grid (module docstring A, B).

    Parameters
    ----------
    system : VibroImpactSystem
    xnodes, ynodes : ndarray
        Grid nodes (``ynodes`` contains 0).
    walls : sequence of 2 :class:`~fpk_vibro.fem.mesh.StripEnd`
    limit : bool
        False: the first-order generator (part A), one linear solve.  True: the
        high-order transport fluxes of part B by Picard iteration
        p ← null(A(g(p))), started from the first-order solution.  The returned
        p is always the normalised null vector of a generator, hence ≥ 0 with
        mass 1, converged or not.
    scheme : {"quick", "van-albada"}
        Face values of part B (:func:`limiter_factors`).
    tol : float
        > 0; stop when ‖p_new − x‖∞ / ‖p_new‖∞ < tol (x the Picard input).
    maxiter : int
        ≥ 1; Picard iterations at most; a RuntimeWarning is issued if not converged.
    anderson : int
        ≥ 0; depth of the Anderson acceleration of the Picard map (0: plain
        Picard).  Measured: depth 3 halves the iterations on r = 0.3, D1 = 0.002
        (84 → 42 at nx = 32); deeper did not help.

    Raises
    ------
    ValueError
        Naming ``scheme``, ``tol``, ``maxiter`` or ``anderson``.

    Returns
    -------
    p, info, extra
        ``p`` in Kronecker order (i·ny + k), normalised; ``extra`` holds the
        Picard iterations, the last relative change, the number of sparse LU
        factorisations and the nonlinear defect ‖A(g(p)) p‖∞ / (‖A(g(p))‖∞ ‖p‖∞).
    """
    from .solve import solve_stationary
    if scheme not in LIMITERS:
        raise ValueError(f"scheme must be one of {LIMITERS}; got {scheme!r}")
    check_float("tol", tol, 0.0, 1.0, hi_open=True)
    check_int("maxiter", maxiter, 1)
    check_int("anderson", anderson, 0)
    t0 = time.perf_counter()
    xn, yn = np.asarray(xnodes, float), np.asarray(ynodes, float)
    shape = (xn.size, yn.size)
    grid = (np.arange(shape[0]), np.arange(shape[1]))
    A, unit = positive_generator(system, xn, yn, walls)
    # pin a node where the density is large: the density can span 1e-140 (Δ = 0.1
    # with the Gibbs y_max), and pinning a tail node ruins the conditioning
    pin = (shape[0] // 2) * shape[1] + int(np.argmin(np.abs(yn)))
    p, sinfo = solve_stationary(A, unit, grid=grid, pin=pin)
    it, change = 0, 0.0
    nlu = 1
    if limit:
        change = np.inf
        X, F = [], []                   # Anderson history: iterates, residuals
        x = p
        inner = _FrozenLU(unit, grid, int(np.argmax(p)))
        for it in range(1, maxiter + 1):
            gx, gy = limiter_factors(x.reshape(shape), xn, yn, system, scheme)
            A, _ = positive_generator(system, xn, yn, walls, gx, gy)
            pn = inner.solve(A, x, max(min(1e-4, 1e-2 * change), 1e-3 * tol))
            f = pn - x
            change = float(np.max(np.abs(f)) / np.max(np.abs(pn)))
            if change < tol:
                # the returned p is the exact null vector of A(g(x)): a generator's
                # normalised null vector, p ≥ 0 (the inner solves were inexact)
                p, sinfo = solve_stationary(A, unit, grid=grid, pin=int(np.argmax(x)))
                break
            p = pn
            if anderson:
                X.append(x)
                F.append(f)
                X, F = X[-(anderson + 1):], F[-(anderson + 1):]
                if len(F) > 1:
                    dF = np.array([F[i + 1] - F[i] for i in range(len(F) - 1)]).T
                    dX = np.array([X[i + 1] - X[i] for i in range(len(X) - 1)]).T
                    gamma = np.linalg.lstsq(dF, f, rcond=None)[0]
                    x = x + f - (dX + dF) @ gamma
                else:
                    x = pn
            else:
                x = pn
        nlu = inner.factorizations + 2
        if change >= tol:
            p, sinfo = solve_stationary(A, unit, grid=grid, pin=int(np.argmax(x)))
            import warnings
            warnings.warn(f"limited positive scheme: Picard iteration did not converge "
                          f"(relative change {change:.1e} after {it} iterations); the "
                          "density is non-negative with mass 1 but not the limited "
                          "fixed point", RuntimeWarning, stacklevel=3)
        gx, gy = limiter_factors(p.reshape(shape), xn, yn, system, scheme)
        Ap, _ = positive_generator(system, xn, yn, walls, gx, gy)
    else:
        Ap = A
    defect = float(np.max(np.abs(Ap @ p)) /
                   (abs(Ap).sum(axis=1).max() * np.max(np.abs(p))))
    extra = {"picard_iterations": it, "picard_change": float(change),
             "nonlinear_defect": defect, "factorizations": nlu}
    info = SolveInfo("direct+limited" if limit else "direct-positive",
                     time.perf_counter() - t0, max(defect, sinfo.residual), it,
                     {"ordering": sinfo.extra.get("ordering", "")})
    return p, info, extra
