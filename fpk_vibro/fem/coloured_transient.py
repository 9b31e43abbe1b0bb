"""The transient FPK in (x, y, ζ) for coloured external noise
(:func:`transient_coloured`, reached through :func:`fpk_vibro.fem.transient`).

M ṗ = L p on the mesh of :mod:`fpk_vibro.fem.coloured` by BDF2 with a constant step
h ≤ ``dt`` between two output times (the interval divided evenly; the first step
implicit Euler, the first after a change of h variable-step BDF2).  Each step solves
(σ M − L) x = b by GMRES preconditioned with the factors of a shift within 25 % of σ
(:meth:`fpk_vibro.fem.coloured_solve.ModeSolver.step`; new factors otherwise: a 4×
mismatch stalled GMRES).  Mass: 1ᵀL = 0, so 1ᵀM p is kept to the GMRES
tolerance.

Initial density: the given (x, y) density (as :func:`fpk_vibro.fem.transient` takes
it) times the stationary N(0, D1/τ) of ζ, independent of (x, y), as in
:func:`fpk_vibro.montecarlo.transient`.

Error estimate (on first call, for all times): one richer transient (nx, ny, nz × 1.5,
h/2); the differences of E[H], E[x²], E[y²] (relative to the larger of the value and
a tenth of the stationary one) and the L1 of p(x, y), divided by 1 − 1.5⁻², the
richer run's share were it second order.
"""
from __future__ import annotations

import math
import time
from types import SimpleNamespace
from typing import Any, Sequence

import numpy as np

from ..initial import parse_times
from ..model import VibroImpactSystem, check_system
from ..progress import Progress
from ..solution import TransientResult
from .coloured import RICHER, _even, _solution, check_grid, compare
from .coloured_operator import assemble_coloured, zeta_nodes
from .coloured_solution import ColouredFEMSolution
from .coloured_solve import ModeSolver
from .initial_density import default_dt, initial_vector
from .mesh import axis_nodes, domain, wall_nodes

__all__ = ["transient_coloured"]

WHERE = "fem.transient"


def transient_coloured(system: VibroImpactSystem, *, initial: Any, times: Sequence[float],
                       dt: float | None = None, nx: int | None = None, ny: int | None = None,
                       nz: int | None = None, degree: int | None = None,
                       y_max: float | None = None, tol: float = 1e-10,
                       progress: bool | None = None) -> TransientResult:
    """Densities at ``times`` (module docstring).

    Returns
    -------
    TransientResult of ColouredFEMSolution
        Each with ``.time`` and ``error_estimate()``.
    """
    check_system(WHERE, system, coloured=True)
    t_out = parse_times(times, WHERE)
    nx, ny, nz, degree, y_max = check_grid(nx, ny, nz, degree, y_max, WHERE)
    grid = (nx, ny, nz)
    h = float(dt) if dt is not None else default_dt(system)
    if not (math.isfinite(h) and h > 0):
        from .._checks import invalid
        raise invalid(WHERE, "dt", "a finite number > 0", dt)
    dom = domain(system.replace(external=None), y_max)
    xs = wall_nodes(dom, grid[0], 1.0)
    ys = axis_nodes(-dom.y_max, dom.y_max, grid[1], centre=0.0)
    zs = zeta_nodes(system, grid[2])
    op = assemble_coloured(system, xs, ys, zs, degree, dom=dom)
    bx, by, bz = op.xbasis, op.ybasis, op.zbasis
    X, Y = np.meshgrid(bx.doflocs[0], by.doflocs[0], indexing="ij")
    unit2 = np.asarray(op.parts["Mxy"].sum(axis=0)).ravel()
    flat = SimpleNamespace(points=(X.ravel(), Y.ravel()), unit=unit2, system=system)
    p0 = initial_vector(flat, initial)
    var = system.external.variance(system.D1)
    g = np.exp(-0.5 * bz.doflocs[0] ** 2 / var)
    p = np.kron(p0, g)
    p /= float(op.unit @ p)
    M = op.M
    solvers: list[ModeSolver] = [ModeSolver(op, shift=1.5 / h, progress=progress)]

    def solver_for(sigma: float) -> ModeSolver:
        """Factors of a shift within 25 % of σ (a 4× mismatch stalled GMRES), else new."""
        near = [m for m in solvers if 0.8 < m.shift / sigma < 1.25]
        if not near:
            solvers.append(ModeSolver(op, shift=sigma, progress=progress))
            near = solvers[-1:]
        return near[0]
    n_total = int(sum(math.ceil((b - a) / h - 1e-9)
                      for a, b in zip(np.r_[0.0, t_out[:-1]], t_out)))
    bar = Progress(progress, "fem.transient (coloured)", total=n_total, unit="step")
    out = TransientResult()
    out.times_requested = tuple(float(t) for t in t_out)
    t_now, p_prev, h_prev, steps, its, t0 = 0.0, None, None, 0, 0, time.perf_counter()
    try:
        for t_next in t_out:
            n_steps = max(1, math.ceil((t_next - t_now) / h - 1e-9))
            h_interval = (t_next - t_now) / n_steps
            while t_now < t_next - 1e-12 * max(1.0, t_next):
                hk = min(h_interval, t_next - t_now)
                if p_prev is None:                      # implicit Euler
                    sigma, rhs = 1.0 / hk, (M @ p) / hk
                else:                                   # variable-step BDF2
                    w = hk / h_prev
                    a0 = (1 + 2 * w) / (1 + w)
                    sigma = a0 / hk
                    rhs = M @ ((1 + w) * p - (w * w / (1 + w)) * p_prev) / hk
                x, k = solver_for(sigma).step(rhs, sigma, tol=tol, x0=p)
                p_prev, p, h_prev = p, x, hk
                t_now += hk
                steps, its = steps + 1, its + k
                bar.update(steps)
            sol = _solution(system, op, p / float(op.unit @ p), xs, ys, zs, degree, {
                "unknowns": op.size, "nx": grid[0], "ny": grid[1], "nz": grid[2],
                "degree": degree, "time": float(t_now), "dt": h, "steps": steps,
                "iterations": its, "residual": 0.0, "mass_drift": float(op.unit @ p) - 1.0,
                "seconds": time.perf_counter() - t0, "discretisation": "galerkin-3d"})
            sol.time = float(t_now)
            out.append(sol)
    except KeyboardInterrupt:
        out.partial = True
        for s in out:
            s.info["partial"] = True
        if not out:
            raise
    finally:
        bar.close()
    _attach_estimate(out, system, initial, dict(grid=grid, degree=degree, y_max=y_max,
                                                dt=h, tol=tol))
    return out


def _attach_estimate(out: TransientResult, system, initial, args: dict) -> None:
    cache: dict[str, Any] = {}

    def estimate(sol: ColouredFEMSolution) -> dict[str, Any]:
        if "richer" not in cache:
            nx, ny, nz = (_even(RICHER * n) for n in args["grid"])
            cache["richer"] = transient_coloured(
                system, initial=initial, times=[s.time for s in out], dt=args["dt"] / 2,
                nx=nx, ny=ny, nz=nz, degree=args["degree"], y_max=args["y_max"],
                tol=args["tol"])
        fine = cache["richer"][[s.time for s in out].index(sol.time)]
        est = compare(sol, fine, order=2.0)
        est["assumes"] = ("the richer transient (nx, ny, nz × 1.5, dt/2) is much closer "
                          "to the exact density than this one")
        return est

    for s in out:
        s.estimator = estimate          # (an instance attribute: called as estimate(s))
