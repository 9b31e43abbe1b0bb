"""Linear solvers for the singular stationary system L p = 0, ∫ p = 1 (docs/theory.md,
§Assembly and solve).

Normalisation by a *replaced row*: since 1ᵀ L = 0 the rows of L are linearly
dependent, so any one row ``k`` is implied by the others and can be replaced by the
normalisation row u = (∫ φ_i)_i without changing the (unique, if the null space
is one-dimensional) normalised null vector:

    A = L with row k replaced by uᵀ,     A p = e_k.

Which row is replaced therefore changes only round-off, not the discrete solution.
In the comparison that chose it, this solved 5–20× faster with SciPy's SuperLU than a
bordered (Lagrange-multiplier) system; the orderings used are discussed below.

Solvers
-------
``"direct"``  SuperLU (``scipy.sparse.linalg.splu``) on A, orderings below.
``"amg"``     GMRES on the pinned −L preconditioned by a pyamg AIR hierarchy
              (``"amg-sa"``: smoothed aggregation).  An unconverged solve raises
              :class:`SolverNotConverged` (a RuntimeError naming the solver);
              no density is ever returned from it.
``"auto"``    the direct solver: AMG would need the generator sign pattern
              (off-diagonals ≥ 0, the positive generator) and at least
              :data:`AMG_MIN_DOFS_STATIONARY` unknowns, which is infinite because
              AMG does not scale on the pinned system (measured, below).  Were AMG
              tried and missed its tolerance, SuperLU runs and ``SolveInfo.solver``
              reads ``"direct (fallback: …)"``, ``extra["fallback"]`` the reason.

:func:`factorised` gives the implicit-step solve x = K⁻¹b for a transient's
matrix K = a·M − h·L: SuperLU, or AMG when K is an M-matrix (lumped M, positive
generator) too large for its LU to fit (see its docstring).

Where AMG fits (``fpk-vibro bench fem-scale --amg-sizes``; the measurements,
up to 10⁷ DOFs with peak memory, are in ``docs/fem_solvers.md``).  On the Galerkin L
(pinned, or M − dt L with the consistent mass) AIR, smoothed aggregation and
root-node do not converge: the Galerkin transport couplings are negative, not an
M-matrix.  On the positive generator A, AIR + GMRES converges in a size-independent
7–11 iterations on M − dt A; one solve costs less time and memory than SuperLU from
about 10⁶ DOFs on, and at 10⁷ DOFs AMG solves where SuperLU runs out of memory.  A
reused LU costs only its solves, so AMG is chosen by size for one-off solves, and
for reused step matrices only when the LU would not fit (:func:`factorised`).  On the
pinned −A (stationary) the iterations grow with size and AMG misses 1e-10 at 10⁶
DOFs, so the stationary "auto" stays direct (:data:`AMG_MIN_DOFS_STATIONARY`).
The direct solver and its orderings: :mod:`fpk_vibro.fem.direct`; AMG:
:mod:`fpk_vibro.fem.amg`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .amg import (SolverNotConverged, amg_hierarchy, is_generator_pattern, is_m_matrix_pattern,
                  krylov, solve_amg)
from .direct import (grid_nested_dissection, is_p1, nd_lu, pinned_system, relative_residual,
                     solve_direct)

__all__ = [
    "AMG_MIN_DOFS",
    "AMG_MIN_DOFS_STATIONARY",
    "SOLVERS",
    "Factorised",
    "SolveInfo",
    "SolverNotConverged",
    "factorised",
    "grid_nested_dissection",
    "is_generator_pattern",
    "is_m_matrix_pattern",
    "lu_bytes",
    "nd_lu",
    "pinned_system",
    "relative_residual",
    "solve_stationary",
]

SOLVERS = ("auto", "direct", "amg", "amg-sa")

#: Unknowns from which :func:`factorised` ``"auto"`` may use AMG (only on
#: M-matrix-pattern matrices): the measured single-solve crossover (module
#: docstring, ``bench fem-scale --amg-sizes``).
AMG_MIN_DOFS = 1_000_000
#: The same for the stationary (pinned) system: never (math.inf).  Measured on the
#: pinned positive generator: AIR + GMRES iterations grow 14, 20, 46, > 100 at 1e4,
#: 6.6e4, 2.6e5, 1e6 DOFs (not converged at 1e6: residual 2e-8 after 139 s, while
#: SuperLU took 66 s and 1.7 GB), so "auto" keeps SuperLU for it at every size.
AMG_MIN_DOFS_STATIONARY = math.inf
#: Relative residual ‖Ap − b‖₂/‖b‖₂ the AMG solves must reach (stationary, step).
AMG_TOL = 1e-10
AMG_TOL_STEP = 1e-10


@dataclass
class SolveInfo:
    """What the solve did: solver used, seconds, relative residual, iterations."""
    solver: str
    seconds: float
    residual: float
    iterations: int = 0
    extra: dict = field(default_factory=dict)


def solve_stationary(L: sp.spmatrix, unit: np.ndarray, *, solver: str = "auto",
                     pin: int | None = None, tol: float = 1e-12,
                     maxiter: int = 100, grid: tuple[np.ndarray, np.ndarray] | None = None
                     ) -> tuple[np.ndarray, SolveInfo]:
    """Normalised null vector of the generator L (module docstring).

    Parameters
    ----------
    L : sparse matrix
        Generator with zero column sums.
    unit : ndarray
        ∫ φ_i (normalisation row).
    solver : {"auto", "direct", "amg", "amg-sa"}
        ``"auto"``: AMG (AIR + GMRES) when L has the generator sign pattern
        (off-diagonals ≥ 0, :func:`is_generator_pattern`) and at least
        :data:`AMG_MIN_DOFS_STATIONARY` (= ∞, measured) unknowns, else the direct
        solver; if AMG does not
        reach its tolerance the direct solver is run and ``info.solver`` /
        ``info.extra["fallback"]`` say so.  ``"amg"``/``"amg-sa"`` on request:
        :class:`SolverNotConverged` if the tolerance is not reached (never an
        unconverged density).
    pin : int, optional
        Row to replace (default: the DOF with the largest ∫φ_i).
    tol : float
        Relative tolerance of the iterative solvers (AMG: at least
        :data:`AMG_TOL`, measured as ‖A p − b‖₂/‖b‖₂ after the solve).
    grid : (xrank, yrank), optional
        Tensor structure (spatial ranks of the 1-D DOFs) for the nested-dissection
        ordering of the direct solver.

    Returns
    -------
    p, info

    Raises
    ------
    SolverNotConverged
        ``solver="amg"``/``"amg-sa"`` did not reach its tolerance.
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}; got {solver!r}")
    requested = solver
    if solver == "auto":
        solver = ("amg" if L.shape[0] >= AMG_MIN_DOFS_STATIONARY and is_generator_pattern(L)
                  else "direct")
    t0 = time.perf_counter()
    it = 0
    extra: dict = {}
    res = None
    if solver == "direct":
        A, b, pin = pinned_system(L, unit, pin)
        p, it, extra["ordering"], res = solve_direct(A, b, grid, tol)
    else:
        # AMG wants positive diagonals: pin −L (same null vector, same e_k row)
        A, b, pin = pinned_system(-sp.csr_matrix(L), unit, pin)
        kind = "sa" if solver == "amg-sa" else "air"
        try:
            p, it = solve_amg(A, b, kind=kind, tol=max(tol, AMG_TOL), maxiter=maxiter)
            extra["ordering"] = f"amg-{kind}"
        except SolverNotConverged as exc:
            if requested != "auto":
                raise
            extra["fallback"] = str(exc)
            A, b, pin = pinned_system(L, unit, pin)
            p, it, extra["ordering"], res = solve_direct(A, b, grid, tol)
            solver = f"direct (fallback: {exc.solver} did not converge)"
    extra["pin"] = pin
    if res is None:
        res = relative_residual(A, p, b)
    p = p / float(unit @ p)
    dt = time.perf_counter() - t0
    return p, SolveInfo(solver, dt, res, it, extra)


def lu_bytes(n: int) -> float:
    """Peak bytes of the SuperLU (grid ND) factorisation of an n-DOF Q1 step matrix,
    fitted to the measured peaks (1.7 GB at 1.0e6, 7.6 GB at 4.0e6 DOFs, process
    included; ~n^1.08 — the n log n fill of nested dissection)."""
    return 7.6 * 2**30 * (n / 4.0e6) ** 1.08


def _available() -> float:
    from ..budget import available_memory
    return available_memory()


class Factorised:
    """A reusable solver x = K⁻¹ b for one matrix K (the implicit-step matrix
    a·M − h·L of a transient).  Call it: ``x = f(b)``.  ``f.kind`` is "lu" or
    "amg"; ``f.info`` (dict) records the choice, setup seconds, iterations of the
    last solve and any fallback.  See :func:`factorised`."""

    def __init__(self, K: sp.spmatrix, *, solver: str, tol: float, maxiter: int,
                 grid, ordering: str, reuse: bool = True) -> None:
        self.K = sp.csr_matrix(K)
        self.tol, self.maxiter, self.grid, self.ordering = tol, maxiter, grid, ordering
        self.requested = solver
        self.info: dict = {"requested": solver}
        self._lu = self._ml = None
        t0 = time.perf_counter()
        if solver == "auto":
            n = self.K.shape[0]
            big = lu_bytes(n) > 0.5 * _available() if reuse else True
            solver = ("amg" if n >= AMG_MIN_DOFS and big and is_m_matrix_pattern(self.K)
                      else "direct")
        self.kind = "lu" if solver == "direct" else "amg"
        if self.kind == "amg":
            try:
                self._ml = amg_hierarchy(self.K, "sa" if solver == "amg-sa" else "air")
            except (ValueError, ArithmeticError, FloatingPointError) as exc:
                self._fallback(SolverNotConverged(solver, 0, float("nan"), tol,
                                                  f"setup failed: {exc}"))
        else:
            self._factor()
        self.info.update(kind=self.kind, setup_seconds=time.perf_counter() - t0)

    def _factor(self) -> None:
        K, grid = self.K, self.grid
        if grid is not None and all(is_p1(r) for r in grid):
            self._lu = nd_lu(K, grid_nested_dissection(*grid))
        else:
            self._lu = spla.splu(K.tocsc(), permc_spec=self.ordering).solve

    def _fallback(self, exc: SolverNotConverged) -> None:
        if self.requested != "auto":
            raise exc
        self.info["fallback"] = f"{exc}; switched to SuperLU"
        self.kind, self._ml = "lu", None
        self._factor()

    def __call__(self, b: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        if self.kind == "amg":
            try:
                x, it = krylov(self.K, b, self._ml.aspreconditioner(cycle="V"), tol=self.tol,
                                maxiter=self.maxiter, x0=x0, solver="amg-air")
                self.info["iterations"] = it
                return x
            except SolverNotConverged as exc:
                self._fallback(exc)
        return self._lu(b)


def factorised(K: sp.spmatrix, *, solver: str = "auto", tol: float = AMG_TOL_STEP,
               maxiter: int = 100, grid: tuple[np.ndarray, np.ndarray] | None = None,
               ordering: str = "COLAMD", reuse: bool = True) -> Factorised:
    """A solve callable for the implicit-step matrix K (e.g. ``a·M − h·L``).

    ``solver="auto"`` (default): AIR-AMG-preconditioned GMRES when K has the
    M-matrix sign pattern (positive generator with lumped masses,
    :func:`is_m_matrix_pattern`), at least :data:`AMG_MIN_DOFS` unknowns *and* the
    LU factor would take more than half the available memory (:func:`lu_bytes`).
    Reason: the LU is factorised once and reused by every step with the same
    matrix (measured at 4·10⁶ DOFs: factor 553 s, then ~4 s per solve, 7.6 GB;
    AMG setup 328 s, then ~67 s per solve, 4.1 GB), so LU wins over a
    many-step transient wherever it fits, and AMG is the way past its memory.
    (A quieter run: LU 409 s / 7.2 GB, AMG setup 166 s + 19 s per solve / 3.9 GB.)
    ``reuse=False`` (the matrix is solved once, e.g. the limited positive
    transient's new matrix per step): AMG from :data:`AMG_MIN_DOFS` on, the
    measured single-solve crossover (1e6 DOFs: AMG 79 s / 1.06 GB, SuperLU 91 s /
    1.74 GB; 2.6e5: AMG 29 s, SuperLU 20 s);
    otherwise SuperLU (``grid``: the nested-dissection ordering of a Q1 tensor
    grid, else ``ordering``).  The Galerkin K (consistent mass) always gets LU:
    AMG does not converge on it (measured, module docstring).  If an AMG solve
    misses ``tol`` (true relative residual) the matrix is factorised by SuperLU,
    that solve and all later ones use it, and ``info["fallback"]`` says why.
    ``solver="direct"`` forces LU; ``"amg"`` forces AMG and raises
    :class:`SolverNotConverged` instead of falling back.
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}; got {solver!r}")
    return Factorised(K, solver=solver, tol=tol, maxiter=maxiter, grid=grid, ordering=ordering,
                      reuse=reuse)
