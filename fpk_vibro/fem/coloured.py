"""The stationary FPK in (x, y, ζ) for coloured external noise: the face of the 3-D
solve (:func:`stationary_coloured`, reached through :func:`fpk_vibro.fem.stationary`).

Mesh: tensor hexahedra, uniform in x between the walls (or the tail cut): without
diffusion in y (D2 = 0) the wall grading of the 2-D solve put cells 100× thinner in x
than in y at the corners (x_w, 0, ζ), where the Galerkin density then undershot by
40 % and the impact rate was 17 % high (paper case, 32 × 24 × 12 Q2; uniform: 5e-4
and 1e-3);
|y| < y_max from the energy tail of the white system of the same D1 (the coloured
force has less power at the oscillator's frequencies, so the white tail bounds it),
|ζ| < ζ_max = 5.7 sqrt(D1/τ) (:mod:`fpk_vibro.fem.coloured_operator`).  Operator:
:mod:`~fpk_vibro.fem.coloured_operator`; solve: :mod:`~fpk_vibro.fem.coloured_solve`;
result: :class:`~fpk_vibro.fem.coloured_solution.ColouredFEMSolution`.

Error estimate: one richer solve (each of nx, ny, nz × 1.5, rounded to even); the
differences in E[H], E[x²], E[y²], P_impact, E[ζ y] (relative) and in the
ζ-marginal p(x, y) (L1, on a Gauss grid of the richer mesh), divided by
1 − 1.5^{−3} (the richer level's own error, were the order 3 of Q2 reached), are the
estimates of the coarser one's errors; made by ``rtol`` solves, or by
:meth:`error_estimate` on first call.  Measured on the exact linear case
(docs/measurements.md, §Coloured noise): true/estimate 0.6-1.0.
"""
from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np
import skfem

from .._checks import InputError, check_float, check_int
from ..model import VibroImpactSystem, check_system
from . import forms
from .coloured_operator import assemble_coloured, zeta_nodes
from .coloured_solution import ColouredFEMSolution
from .coloured_solve import ModeSolver
from .generator import tensor_index
from .mesh import axis_nodes, domain, wall_nodes
from .options import COLOURED_GRID

__all__ = ["stationary_coloured", "DEFAULT_GRID", "estimate", "check_grid", "compare"]

#: Default (nx, ny, nz, degree) (declared with the options).
DEFAULT_GRID = COLOURED_GRID
#: Largest rtol ladder step: nx, ny, nz times this.
RICHER = 1.5
WHERE = "fem.stationary"


def _even(n: float) -> int:
    return max(2, 2 * int(math.ceil(n / 2.0)))


def stationary_coloured(system: VibroImpactSystem, *, nx: int | None = None,
                        ny: int | None = None, nz: int | None = None, degree: int | None = None,
                        y_max: float | None = None, rtol: float | None = None,
                        coupled: int = 2, tol: float = 1e-10,
                        progress: bool | None = None) -> ColouredFEMSolution:
    """The stationary density of a system with ``external=OrnsteinUhlenbeck(tau=τ)``
    (module docstring); :func:`fpk_vibro.fem.stationary` passes its keywords here.

    Parameters
    ----------
    nx, ny, nz : int, optional
        Cells in x, y (even) and ζ (even); default :data:`DEFAULT_GRID`.
    degree : {1, 2, 3}
        Lagrange degree in every direction (default 2).
    y_max : float, optional
    rtol : float, optional
        Refine nx, ny, nz by 1.5 until the estimated relative errors of E[H], E[x²],
        E[y²], P_impact and E[ζ y] (module docstring; :data:`ESTIMATED`) are below it;
        the L1 error of p(x, y) is estimated but not bounded.
    coupled : int
        ζ-modes solved together in the preconditioner.
    tol : float
        GMRES relative residual.
    progress : bool, optional

    Returns
    -------
    ColouredFEMSolution
    """
    check_system(WHERE, system, coloured=True)
    nx, ny, nz, degree, y_max = check_grid(nx, ny, nz, degree, y_max)
    grid = [nx, ny, nz]
    if rtol is not None:
        rtol = check_float("rtol", rtol, lo=1e-6, hi=0.5, where=WHERE)
    opts = {"degree": degree, "y_max": y_max, "coupled": coupled, "tol": tol,
            "progress": progress}
    sol = solve_level(system, *grid, **opts)
    if rtol is None:
        return sol
    t0 = time.perf_counter()
    while True:
        richer = solve_level(system, *[_even(RICHER * n) for n in grid], **opts)
        est = compare(sol, richer)
        sol._estimate = est
        if max(est[k] for k in ESTIMATED if k in est) <= rtol:
            sol.info["rtol"] = rtol
            return sol
        if time.perf_counter() - t0 > 120.0 or richer.info["unknowns"] > 4_000_000:
            sol = richer          # (its error is below the coarser level's estimate)
            sol._estimate = est
            sol.info.update(rtol=rtol, rtol_not_reached=True, under_resolved=True)
            worst = max(est[k] for k in ESTIMATED if k in est)
            warnings.warn(f"fem.stationary: rtol = {rtol:g} not reached within 120 s or "
                          f"4·10⁶ unknowns; returned {sol.info['unknowns']} unknowns with "
                          f"an estimated error below {worst:.2g}; give nx, ny, nz or a "
                          "larger rtol", RuntimeWarning, stacklevel=3)
            return sol
        grid = [_even(RICHER * n) for n in grid]
        sol = richer


def check_grid(nx, ny, nz, degree, y_max, where: str = WHERE) -> tuple:
    """(nx, ny, nz, degree, y_max) checked, defaults filled (:data:`DEFAULT_GRID`); one
    line naming the first bad one."""
    d_nx, d_ny, d_nz, d_deg = DEFAULT_GRID
    degree = d_deg if degree is None else check_int("degree", degree, lo=1, hi=3, where=where)
    grid = [d_nx if nx is None else check_int("nx", nx, lo=2, hi=4096, where=where),
            d_ny if ny is None else check_int("ny", ny, lo=2, hi=4096, where=where),
            d_nz if nz is None else check_int("nz", nz, lo=8, hi=4096, where=where)]
    for name, n in zip(("ny", "nz"), grid[1:]):
        if n % 2:
            raise InputError(f"{where}: {name} must be even (y = 0 and ζ = 0 are mesh "
                             f"planes); got {n}", where=where, name=name)
    if y_max is not None:
        y_max = check_float("y_max", y_max, lo=0.0, where=where)
    return (*grid, degree, y_max)


def solve_level(system: VibroImpactSystem, nx: int, ny: int, nz: int, *, degree: int,
                y_max: float | None, coupled: int, tol: float,
                progress: bool | None) -> ColouredFEMSolution:
    """One solve on the nx × ny × nz mesh (no estimate)."""
    t0 = time.perf_counter()
    dom = domain(system.replace(external=None), y_max)
    xs = wall_nodes(dom, nx, 1.0)         # uniform: module docstring
    ys = axis_nodes(-dom.y_max, dom.y_max, ny, centre=0.0)
    zs = zeta_nodes(system, nz)
    op = assemble_coloured(system, xs, ys, zs, degree, dom=dom)
    t_asm = time.perf_counter() - t0
    solver = ModeSolver(op, coupled=coupled, progress=progress)
    p, sinfo = solver.solve(tol=tol, progress=progress)
    return _solution(system, op, p, xs, ys, zs, degree, {
        "unknowns": op.size, "nx": nx, "ny": ny, "nz": nz, "degree": degree,
        "assembly_seconds": t_asm, **solver.info, **sinfo,
        "seconds": time.perf_counter() - t0, "discretisation": "galerkin-3d",
        "y_max": dom.y_max, "z_max": float(zs[-1])})


def _solution(system, op, p, xs, ys, zs, degree, info) -> ColouredFEMSolution:
    nxd, nyd, nzd = op.shape
    P = p.reshape(nxd, nyd, nzd)
    bz = op.zbasis

    def w1(b, *coef):
        return skfem.asm(forms.weighted_mass_1d, b, coef=coef) @ np.ones(b.N)

    iz, z1, z2 = w1(bz, 1.0), w1(bz, 0.0, 1.0), w1(bz, 0.0, 0.0, 1.0)
    ix, iy, y1 = w1(op.xbasis, 1.0), w1(op.ybasis, 1.0), w1(op.ybasis, 0.0, 1.0)
    P2 = P @ iz                                              # the ζ-marginal's coefficients
    zeta = {"E_zeta2": float(np.einsum("ijk,i,j,k", P, ix, iy, z2)),
            "E_zeta_y": float(np.einsum("ijk,i,j,k", P, ix, y1, z1))}
    Mz = op.parts["Mz"]
    pz_coef = np.einsum("ijk,i,j->k", P, ix, iy)        # p(ζ) on the ζ-basis: its nodal values
    mesh = skfem.MeshQuad.init_tensor(xs, ys)
    if degree > 2:
        dofs = P2.ravel()
    else:
        from .generator import element_for
        k = tensor_index(op.xbasis, op.ybasis,
                         skfem.CellBasis(mesh, element_for(mesh, degree), intorder=1))
        dofs = P2.ravel()[k]
    info = dict(info, min_density=float(p.min() / max(p.max(), 1e-300)),
                zeta_mass=float(iz @ pz_coef), zeta_mass_matrix_nnz=int(Mz.nnz))
    return ColouredFEMSolution(system, mesh, degree, dofs, residual=info["residual"],
                               info=info, tensor=(xs, ys), mass=float(ix @ P2 @ iy),
                               zeta=zeta, zeta_nodes=np.asarray(zs, float),
                               zeta_density=np.maximum(pz_coef, 0.0))


#: The figures ``rtol`` bounds (relative).  The L1 of p(x, y) is estimated too but
#: not bounded: without diffusion in y (D2 = 0) the density's pointwise error near the
#: walls converges slowly (paper case, 16 × 24 × 12 against 24 × 36 × 12: L1 5.8e-3,
#: 9 % at one point near a wall) while the moments, P_impact and E[ζ y] are within
#: 3e-4 (docs/measurements.md, §Coloured noise).
ESTIMATED = ("E_H", "E_x2", "E_y2", "P_impact", "E_zeta_y")


def compare(coarse: ColouredFEMSolution, fine: ColouredFEMSolution,
            order: float = 3.0) -> dict[str, Any]:
    """The estimate of the module docstring: |coarse − fine| per figure, divided by
    1 − 1.5^−order.  E[ζ y] relative to the larger of |E[ζ y]| and 1e-3 sqrt(E[ζ²]
    E[y²]) (a transient starts from E[ζ y] = 0)."""
    grow = 1.0 / (1.0 - RICHER ** -order)
    mc, mf = coarse.moments(), fine.moments()
    out: dict[str, Any] = {k: grow * abs(mc[k] - mf[k]) / max(abs(mf[k]), 1e-300)
                           for k in ("E_H", "E_x2", "E_y2", "P_impact") if k in mf}
    zc, zf = coarse.coloured_moments(), fine.coloured_moments()
    floor = 1e-3 * math.sqrt(zf["E_zeta2"] * mf["E_y2"])
    out["E_zeta_y"] = grow * abs(zc["E_zeta_y"] - zf["E_zeta_y"]) / max(abs(zf["E_zeta_y"]),
                                                                        floor)
    xs, ys = fine._tensor
    t, w = np.polynomial.legendre.leggauss(4)
    gx = (0.5 * (xs[1:] + xs[:-1])[:, None] + 0.5 * np.diff(xs)[:, None] * t).ravel()
    wx = (0.5 * np.diff(xs)[:, None] * w).ravel()
    gy = (0.5 * (ys[1:] + ys[:-1])[:, None] + 0.5 * np.diff(ys)[:, None] * t).ravel()
    wy = (0.5 * np.diff(ys)[:, None] * w).ravel()
    X, Y = np.meshgrid(gx, gy, indexing="ij")
    diff = np.abs(coarse.pdf_joint(X, Y) - fine.pdf_joint(X, Y))
    out["L1"] = grow * float(wx @ diff @ wy)
    out.update(assumes="the richer level (nx, ny, nz × 1.5) is much closer to the exact "
               "density than this one",
               richer=f"Q{fine.degree} on {fine.info['nx']} × {fine.info['ny']} × "
                      f"{fine.info['nz']} cells")
    return out


def estimate(sol: ColouredFEMSolution) -> dict[str, Any]:
    """The estimate of ``sol`` by one richer solve (module docstring)."""
    i = sol.info
    if not all(k in i for k in ("nx", "ny", "nz")):
        raise ValueError("error_estimate: this coloured-noise density does not record its "
                         "mesh (nx, ny, nz)")
    richer = solve_level(sol.system, *[_even(RICHER * i[k]) for k in ("nx", "ny", "nz")],
                         degree=sol.degree, y_max=i.get("y_max"), coupled=2, tol=1e-10,
                         progress=None)
    return compare(sol, richer)


ColouredFEMSolution.estimator = staticmethod(estimate)
