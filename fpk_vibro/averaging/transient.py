"""The averaged FPK in time (docs/theory.md, §Averaged transient):

    ∂p/∂t = −∂(m p)/∂H + ½ ∂²(σ² p)/∂H²  on (floor, H_max),  zero flux at both ends.

Finite volumes on cells of H from the strip's floor (0, or G at the nearest wall
of a preloaded strip), with every wall energy G(x_w) a face (p(H) has its kinks
there).  The flux
is written with the closed-form stationary density p_s of :func:`stationary`:

    J = m p − ½ (σ² p)' = −½ σ² p_s (p / p_s)',

which holds because J(p_s) = 0.  Discretised as J_f = −½ σ²_f p_s(f) Δ(p/p_s)/ΔH,
the scheme conserves mass exactly (a telescoping sum), has p_s as its exact discrete
equilibrium and is an M-matrix generator (non-negative off-diagonals), so densities
stay non-negative.  Time integration: SciPy's L-stable Radau IIA with the sparse
Jacobian (the operator itself).
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from scipy import integrate, sparse, special

from ..initial import parse_initial, parse_times
from ..model import VibroImpactSystem, check_system
from ..orbits import orbit_nodes
from ..solution import TransientResult
from .coefficients import coefficients
from .energy_grid import check_coverage, energy_faces, initial_cell_masses
from .grid_solution import EnergyGridSolution
from .model_error import TransientCheck
from .options import Options
from .regimes import phi_rate
from .stationary import AveragedSolution, solve

__all__ = ["transient", "energy_faces", "averaged_operator", "initial_cell_masses"]


def averaged_operator(system: VibroImpactSystem, faces: np.ndarray,
                      stationary_solution: AveragedSolution) -> sparse.csr_matrix:
    """Generator A with dp/dt = A p for cell-average densities p (module docstring).

    The flux through the face between cells i and i + 1 is Scharfetter–Gummel's,

        J = ½ σ²_f / Δc · [T_f/T_i B(ΔΦ) p_i − T_f/T_(i+1) B(−ΔΦ) p_(i+1)],

    B(z) = z/(e^z − 1), ΔΦ = Φ(c_(i+1)) − Φ(c_i): exact where σ², T and Φ' are
    constant across the two half-cells, it vanishes for the stationary ratio
    p_(i+1)/p_i = T_(i+1)/T_i e^(−ΔΦ) (p_s is the exact discrete equilibrium) and
    turns into upwind transport at the drift where Φ changes by much across a cell
    (a start far above the stationary energies), without overflow.
    """
    c = 0.5 * (faces[1:] + faces[:-1])
    h = np.diff(faces)
    f = faces[1:-1]                       # interior faces
    _, _, s2 = coefficients(system, f)
    dphi = phi_rise(stationary_solution, c[:-1], c[1:])
    T_c = orbit_nodes(system, c).period
    T_f = orbit_nodes(system, f).period
    k = 0.5 * s2 / np.diff(c)
    r_left = T_f / T_c[:-1] / special.exprel(dphi)        # T_f/T_i B(ΔΦ)
    r_right = T_f / T_c[1:] / special.exprel(-dphi)       # T_f/T_(i+1) B(−ΔΦ)
    up = k * r_right / h[:-1]             # A[i, i+1]
    lo = k * r_left / h[1:]               # A[i+1, i]
    diag = np.zeros(c.size)
    diag[:-1] -= k * r_left / h[:-1]
    diag[1:] -= k * r_right / h[1:]
    return sparse.diags([lo, diag, up], [-1, 0, 1], format="csr")


def phi_rise(st: AveragedSolution, lo: np.ndarray, hi: np.ndarray,
             n_nodes: int = 8) -> np.ndarray:
    """Φ(hi) − Φ(lo) for lo ≤ hi: the stationary solution's Φ up to its ``H_end``,
    and above it the integral of Φ' = f = (2c J1 + δ)/J2 (Gauss–Legendre on each
    interval).  ``st.phi`` extends Φ linearly beyond ``H_end``, right for the
    stationary mass there (below e^-phi_cut) but not for a density that starts up
    there, where the impacts' loss makes f grow with H."""
    end = st.H_end
    out = st.phi(np.minimum(hi, end)) - st.phi(np.minimum(lo, end))
    above = hi > end
    if np.any(above):
        a, b = np.maximum(lo[above], end), hi[above]
        t, w = np.polynomial.legendre.leggauss(n_nodes)
        nodes = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * t
        rate, _ = phi_rate(st.system, nodes.ravel(), st.n_theta)
        out[above] += 0.5 * (b - a) * (rate.reshape(nodes.shape) @ w)
    return out


def transient(system: VibroImpactSystem, *, initial: Any, times: Sequence[float],
              n_cells: int = 400, H_max: float | None = None, rtol: float = 1e-8,
              seed: int = 0, n_theta: int = 48, n_panel: int = 24,
              phi_cut: float = 60.0) -> list[EnergyGridSolution]:
    """Solve the averaged FPK for p(H, t) from ``initial``; one solution per time.

    Parameters
    ----------
    system : VibroImpactSystem
        Any walls; G increasing in |x| on the strip (as for :func:`stationary`).
    initial : dict or callable
        ``{"mean": (x0, y0), "std": (sx, sy)}`` (x truncated to the strip, std 0 = a
        point mass) or a sampler ``initial(n, rng)``: the spec shared by every
        transient method (:mod:`fpk_vibro.initial`).
    times : sequence of float
        Output times (≥ 0, any order, repeats allowed; results in the same order).
    n_cells : int
        Finite-volume cells in H up to where the stationary density has fallen to
        e^-40 of its peak (second order in 1/n_cells); above it, cells growing by
        3 % each (:func:`~fpk_vibro.averaging.energy_grid.energy_faces`).
    H_max : float, optional
        Upper end of the H domain; default: where the stationary density has fallen
        to e^-40 of its peak, or beyond the initial density's reach if that is higher.
    rtol : float
        Relative tolerance of the Radau time integration.
    seed : int
        Seed for histogramming a sampler callable.
    n_theta, n_panel, phi_cut
        Of the stationary density that writes the flux (:func:`stationary`).

    Returns
    -------
    list of EnergyGridSolution
        Each with ``.time``, ``.mass`` (1 to round-off) and the Solution interface;
        ``error_estimate()`` gives the model error at its time, by one FE transient
        shared by the list (:mod:`fpk_vibro.averaging.model_error`).
    """
    check_system("averaging.transient", system)
    init = parse_initial(initial, system)
    t_out = parse_times(times, "averaging.transient", increasing=False)
    opts, _ = Options.prepare(system, "transient", locals(), initial=init, times=t_out)
    n_cells, H_max, rtol, seed = opts.n_cells, opts.H_max, opts.rtol, opts.seed
    st = solve(system, opts)
    H_top = _energy_at_phi(st, 40.0)       # where the stationary density ends
    if H_max is None:
        H_max = H_top
        if init.is_gaussian:
            (mx, my), (sx, sy) = init.mean, init.std
            H_max = max(H_max, float(system.energy(abs(mx) + 10 * sx, abs(my) + 10 * sy)))
    faces = energy_faces(system, float(H_max), n_cells, H_top)
    mass0 = initial_cell_masses(init, faces, seed=seed)
    check_coverage(mass0, H_max)
    h = np.diff(faces)
    p0 = mass0 / mass0.sum() / h
    A = averaged_operator(system, faces, st)
    t_sorted, where = np.unique(t_out, return_inverse=True)   # repeats: one output
    t_end = float(t_sorted[-1])
    if t_end > 0:
        P = _integrate(A, p0, h, t_sorted, rtol)
    else:
        P = np.repeat(p0[:, None], t_sorted.size, axis=1)
    out = TransientResult([None] * t_out.size)
    for k, j in enumerate(np.ravel(where)):
        out[k] = EnergyGridSolution(system, faces=faces, density=P[:, j], time=float(t_sorted[j]))
    check = TransientCheck(system, init, t_out)      # one FE transient for the list
    for sol in out:
        if isinstance(sol, EnergyGridSolution):
            sol._check = check
            sol.info.update(n_cells=n_cells, rtol=rtol)
    return out


def equilibrium(A: sparse.csr_matrix, h: np.ndarray) -> np.ndarray | None:
    """The operator's discrete equilibrium (zero flux through every face; p_s at the
    cell centres), normalised to mass 1 (zero in cells it cannot reach: a face whose
    upward coefficient underflows); None if a face coefficient is not finite."""
    lo, up = A.diagonal(-1) * h[1:], A.diagonal(1) * h[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        logp = np.concatenate([[0.0], np.cumsum(np.log(lo) - np.log(up))])
    if np.any(np.isnan(logp)) or np.any(logp == np.inf):
        return None
    p = np.exp(logp - logp.max())
    return p / (p @ h)


#: L1 distance of the cell masses to equilibrium at which the integration stops.
SETTLED = 1e-9


def _integrate(A: sparse.csr_matrix, p0: np.ndarray, h: np.ndarray, t_sorted: np.ndarray,
               rtol: float) -> np.ndarray:
    """p at the (increasing, last > 0) times ``t_sorted``: Radau until the cell masses
    are within ``max(rtol, SETTLED)`` (L1) of the discrete equilibrium, that
    equilibrium after.

    ``exp(A t)`` keeps masses non-negative and their sum fixed (A is a generator), so
    the L1 distance of the masses to the equilibrium never grows: once below that
    bound it stays there, and every later time is the equilibrium to it.  (Below
    ~1e-11 the round-off of the integration keeps it from ever getting there.)
    Without this stop the cost grew with t_end without end (Radau's step stays near
    a few relaxation times at equilibrium: t_end = 1e12 would take ~1e10 steps).
    """
    p_eq = equilibrium(A, h)
    events = None
    if p_eq is not None:
        def settled(t: float, p: np.ndarray) -> float:
            return float(np.abs(p - p_eq) @ h) - max(rtol, SETTLED)
        settled.terminal, settled.direction = True, -1   # type: ignore[attr-defined]
        if settled(0.0, p0) <= 0.0:
            return np.repeat(p_eq[:, None], t_sorted.size, axis=1)
        events = settled
    sol = integrate.solve_ivp(lambda t, p: A @ p, (0.0, float(t_sorted[-1])), p0,
                              method="Radau", t_eval=t_sorted, jac=A, rtol=rtol,
                              atol=rtol * 1e-4 * float(p0.max()), events=events)
    if not sol.success:
        raise RuntimeError(f"averaging.transient: time integration failed: {sol.message}")
    P = np.empty((p0.size, t_sorted.size))
    k = len(sol.t)                     # the times reached before the stop
    if k:
        P[:, :k] = sol.y
    if k < t_sorted.size:              # stopped by the event: p_eq exists
        P[:, k:] = p_eq[:, None]
    return P


def _energy_at_phi(st: AveragedSolution, level: float) -> float:
    """The energy where Φ(H) = level (bisection; Φ is increasing from the floor)."""
    lo, hi = st._layout.floor, st.H_end
    if st.phi(np.array([hi]))[0] <= level:
        return hi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if st.phi(np.array([mid]))[0] < level:
            lo = mid
        else:
            hi = mid
    return hi
