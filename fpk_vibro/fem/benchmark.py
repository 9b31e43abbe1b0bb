"""Benchmark of the FEM solver on the exact case (DESIGN §3, §5).

Run ``python -m fpk_vibro.fem.benchmark`` (``--help`` for options).  For each
degree, level and solver it prints DOFs, assembly and solve seconds, the L1 and
max errors against the exact Gibbs density p ∝ exp(−(c/D1) H) (r = 1, D2 = 0,
paper a, b, c, D1, Δ), and the ratio of the straightforward baseline (general
skfem 2-D assembly + SciPy SuperLU with COLAMD, mesh and basis included) to the
fast path (Kronecker assembly + SuperLU with nested-dissection ordering for Q1,
MMD for Q2; the "total" column) measured in the same run.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np
from skfem import Functional, asm

from ..model import VibroImpactSystem
from . import stationary

__all__ = ["main", "exact_errors", "EXACT_SYSTEM"]

EXACT_SYSTEM = VibroImpactSystem.paper(r=1.0, D2=0.0)


def exact_errors(sol) -> tuple[float, float]:
    """(L1 error, max nodal error) of a FEMSolution of an r = 1, D2 = 0 system."""
    s = sol.system
    beta = s.c / s.D1

    def gibbs(x, y):
        return np.exp(-beta * s.energy(x, y))

    Z = asm(Functional(lambda w: gibbs(w.x[0], w.x[1])), sol.basis)
    L1 = asm(Functional(lambda w: abs(w.p - gibbs(w.x[0], w.x[1]) / Z)), sol.basis,
             p=sol.basis.interpolate(sol.dofs))
    X = sol.basis.doflocs
    return float(L1), float(np.max(np.abs(sol.dofs - gibbs(X[0], X[1]) / Z)))


def _run(n: int, degree: int, **kw):
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sol = stationary(EXACT_SYSTEM, nx=n, ny=4 * n, degree=degree, **kw)
    wall = time.perf_counter() - t0
    L1, emax = exact_errors(sol)
    return sol, wall, L1, emax


def baseline(n: int, degree: int) -> tuple[float, np.ndarray]:
    """Straightforward path: general skfem 2-D assembly + SciPy SuperLU (COLAMD,
    default pivoting) on the pinned system.  Returns (seconds, normalised p)."""
    import scipy.sparse.linalg as spla
    import skfem

    from .generator import assemble, element_for, quadrature_order
    from .mesh import domain, structured_mesh
    from .solve import pinned_system

    t0 = time.perf_counter()
    m, _, _ = structured_mesh(domain(EXACT_SYSTEM), n, 4 * n)
    basis = skfem.CellBasis(m, element_for(m, degree), intorder=quadrature_order(degree))
    L, M = assemble(EXACT_SYSTEM, basis)
    unit = np.asarray(M.sum(axis=0)).ravel()
    A, b, _ = pinned_system(L, unit)
    p = spla.splu(A.tocsc(), permc_spec="COLAMD").solve(b)
    p /= unit @ p
    return time.perf_counter() - t0, p


def main(argv: list[str] | None = None) -> int:
    """Print the benchmark table; returns 0."""
    ap = argparse.ArgumentParser(prog="python -m fpk_vibro.fem.benchmark",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--q1", type=int, nargs="*", default=[32, 64, 128, 256, 500],
                    help="Q1 levels: cells across x (ny = 4 nx); default %(default)s")
    ap.add_argument("--q2", type=int, nargs="*", default=[16, 32, 48, 64, 128],
                    help="Q2 levels; default %(default)s")
    ap.add_argument("--baseline-max", type=int, default=70_000,
                    help="run the baseline up to this many DOFs (default %(default)s)")
    ap.add_argument("--amg", action="store_true",
                    help="also try pyamg AIR / smoothed aggregation on the smallest level")
    ap.add_argument("--quick", action="store_true", help="small levels only")
    args = ap.parse_args(argv)
    if args.quick:
        args.q1, args.q2, args.baseline_max = [16, 32, 64], [8, 16, 32], 20_000
    head = (f"{'deg':>3} {'nx':>4} {'DOFs':>9} {'solver':>10} {'asm s':>7} {'solve s':>8} "
            f"{'total s':>8} {'L1 err':>9} {'max err':>9} {'mass-1':>9} {'base s':>8} {'ratio':>6}")
    print(f"exact case: {EXACT_SYSTEM}")
    print(head)
    print("-" * len(head))
    for degree, levels in ((1, args.q1), (2, args.q2)):
        for n in levels:
            sol, _, L1, emax = _run(n, degree)
            i = sol.info
            tot = i["assembly_seconds"] + i["solve_seconds"]
            base, ratio = "", ""
            if sol.dofs.size <= args.baseline_max:
                bt, bp = baseline(n, degree)
                if np.max(np.abs(bp - sol.dofs)) > 1e-8 * sol.dofs.max():
                    raise RuntimeError("baseline and fast path disagree")
                base, ratio = f"{bt:8.2f}", f"{bt / tot:6.1f}"
            print(f"{degree:>3} {n:>4} {sol.dofs.size:>9} {i['ordering'][:10]:>10} "
                  f"{i['assembly_seconds']:7.2f} {i['solve_seconds']:8.2f} {tot:8.2f} "
                  f"{L1:9.2e} {emax:9.2e} {sol.mass - 1:9.1e} {base:>8} {ratio:>6}", flush=True)
        if args.amg and levels:
            n = levels[0]
            for solver in ("amg", "amg-sa"):
                try:
                    sol, _, L1, emax = _run(n, degree, solver=solver)
                    i = sol.info
                    print(f"{degree:>3} {n:>4} {sol.dofs.size:>9} {solver:>10} "
                          f"{i['assembly_seconds']:7.2f} {i['solve_seconds']:8.2f} "
                          f"{i['assembly_seconds'] + i['solve_seconds']:8.2f} {L1:9.2e} "
                          f"{emax:9.2e}  residual {sol.residual:.1e} after "
                          f"{i['iterations']} its", flush=True)
                except (ValueError, ArithmeticError, RuntimeError) as exc:
                    print(f"{degree:>3} {n:>4} {'':>9} {solver:>10} failed: {exc}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
