"""Benchmark of the FEM solver on the exact case (docs/theory.md, §Exact solution).

Run ``fpk-vibro bench fem-scale`` (``--help`` for options).  For each
degree, level and solver it prints DOFs, assembly and solve seconds, the L1 and
max errors against the exact Gibbs density p ∝ exp(−(c/D1) H) (r = 1, D2 = 0,
paper a, b, c, D1, Δ), and the ratio of the straightforward baseline (general
skfem 2-D assembly + SciPy SuperLU with COLAMD, mesh and basis included) to the
fast path (Kronecker assembly + SuperLU with nested-dissection ordering for Q1,
MMD for Q2; the "total" column) measured in the same run.  ``wall s`` is the whole
``stationary`` call (assembly, solve and the power balance it records, which takes
the moments and the wall traces); ``mom s`` one more ``moments()`` and ``pb s`` one
more ``power_balance()`` on the solution; ``peak GB`` the process's peak RSS so far.
The default Q1 levels end at nx = 500, 10⁶ DOFs (issue 23, §5: ≤ 60 s with the
moments; measured numbers in docs/measurements.md, §Scale).

``--amg-sizes N …`` instead prints AMG (pyamg AIR-preconditioned GMRES, the
:func:`fpk_vibro.fem.solve.factorised` / ``solve_stationary`` AMG path) against
SuperLU (grid nested dissection) at about N Q1 DOFs each (ny = 4 nx), on the
matrices where AMG applies: ``step`` = M − dt·A (positive generator A, lumped
M, dt = T0/20 ≈ 0.3; one implicit-Euler step of the positive transient) and
``stationary`` = the pinned −A (the ``positivity="first-order"`` stationary
solve); ``galerkin-step`` = M − dt·L with the Galerkin L (AMG does not converge
there).  Each solve runs in its own subprocess (address space capped by
``--amg-mem-gb``, wall time by ``--amg-timeout``) and reports its peak RSS.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np
from skfem import Functional, asm

from ..model import VibroImpactSystem
from ..fem import stationary

__all__ = ["EXACT_SYSTEM", "exact_errors", "main"]

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


def _derived_seconds(sol) -> tuple[float, float]:
    """(seconds of ``sol.moments()``, of ``sol.power_balance()``)."""
    t0 = time.perf_counter()
    sol.moments()
    t1 = time.perf_counter()
    sol.power_balance()
    return t1 - t0, time.perf_counter() - t1


def _peak_gb() -> float:
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def baseline(n: int, degree: int) -> tuple[float, np.ndarray]:
    """Straightforward path: general skfem 2-D assembly + SciPy SuperLU (COLAMD,
    default pivoting) on the pinned system.  Returns (seconds, normalised p)."""
    import scipy.sparse.linalg as spla
    import skfem

    from ..fem.generator import assemble, element_for, quadrature_order
    from ..fem.mesh import domain, structured_mesh
    from ..fem.solve import pinned_system

    t0 = time.perf_counter()
    m, _, _ = structured_mesh(domain(EXACT_SYSTEM), n, 4 * n)
    basis = skfem.CellBasis(m, element_for(m, degree), intorder=quadrature_order(degree))
    L, M = assemble(EXACT_SYSTEM, basis)
    unit = np.asarray(M.sum(axis=0)).ravel()
    A, b, _ = pinned_system(L, unit)
    p = spla.splu(A.tocsc(), permc_spec="COLAMD").solve(b)
    p /= unit @ p
    return time.perf_counter() - t0, p


def _amg_worker(nx: int, kind: str, method: str) -> None:
    """One AMG-vs-LU measurement (run in a subprocess by :func:`amg_table`)."""
    import resource

    import scipy.sparse as sp

    from .. import budget, scales
    from ..fem.solve import SolverNotConverged, factorised, solve_stationary
    from ..fem.transient import discretise

    warnings.simplefilter("ignore", RuntimeWarning)
    with budget.unlimited():
        d = discretise(EXACT_SYSTEM, nx=nx, ny=4 * nx,
                       positivity=False if kind == "galerkin-step" else "first-order")
    L, M, unit = d.L.tocsr(), d.M.tocsr(), d.unit
    n = L.shape[0]
    grid = d.ranks if kind == "galerkin-step" else (np.arange(nx + 1), np.arange(4 * nx + 1))
    solver = "direct" if method == "superlu" else "amg"
    dt = scales.period(EXACT_SYSTEM) / 20.0
    t0 = time.perf_counter()
    setup, its, res, status = 0.0, 0, float("nan"), "ok"
    try:
        if kind == "stationary":
            _p, info = solve_stationary(L, unit, solver=solver, grid=grid)
            its, res = info.iterations, info.residual
            setup = float("nan")
        else:
            K = sp.csr_matrix(M - dt * L)
            b = M @ np.full(n, 1.0 / unit.sum())
            f = factorised(K, solver=solver, grid=grid)
            setup = f.info["setup_seconds"]
            x = f(b)
            its = f.info.get("iterations", 0)
            res = float(np.linalg.norm(K @ x - b) / np.linalg.norm(b))
    except SolverNotConverged as exc:
        status, its, res = "not converged", exc.iterations, exc.residual
    total = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(f"RESULT {n} {setup:.2f} {total:.2f} {its} {res:.2e} {rss:.2f} {status}", flush=True)


def amg_table(sizes, kinds=("step", "stationary"), *, mem_gb: float = 15.0,
              timeout: float = 600.0) -> None:
    """Print AMG against SuperLU at about ``sizes`` DOFs (module docstring)."""
    import resource
    import subprocess

    head = (f"{'matrix':>13} {'DOFs':>9} {'solver':>8} {'setup s':>8} {'total s':>8} "
            f"{'its':>4} {'rel.res':>8} {'peak GB':>8}  status")
    print(f"AMG (AIR + GMRES, tol 1e-10) vs SuperLU (grid ND); exact case, ny = 4 nx; "
          f"limits {mem_gb:g} GB address space, {timeout:g} s")
    print(head)
    print("-" * len(head))
    for kind in kinds:
        for N in sizes:
            nx = max(4, round((np.sqrt(1 + 16 * (N - 1)) - 5) / 8))  # (nx+1)(4nx+1) ≈ N
            for method in ("superlu", "amg"):
                cmd = [sys.executable, "-m", "fpk_vibro.benchmarks.fem_scale", "--amg-worker",
                       str(nx), kind, method]
                lim = int(mem_gb * 2**30)

                def cap(lim=lim):
                    resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
                t0 = time.perf_counter()
                try:
                    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                       check=False, preexec_fn=cap)
                    line = [x for x in r.stdout.splitlines() if x.startswith("RESULT")]
                    if line:
                        _, n, setup, tot, its, res, rss, *st = line[0].split()
                        setup = "-" if kind == "stationary" else f"{float(setup):.1f}"
                        print(f"{kind:>13} {int(n):>9} {method:>8} {setup:>8} "
                              f"{float(tot):8.1f} {int(its):>4} {float(res):8.1e} "
                              f"{float(rss):8.2f}  {' '.join(st)}", flush=True)
                    else:
                        err = (r.stderr.strip().splitlines() or ["?"])[-1][:60]
                        why = "out of memory" if "MemoryError" in r.stderr or r.returncode < 0 \
                            else err
                        print(f"{kind:>13} {(nx + 1) * (4 * nx + 1):>9} {method:>8} "
                              f"{'':>8} {time.perf_counter() - t0:8.1f} {'':>4} {'':>8} "
                              f"{'>' + format(mem_gb, 'g'):>8}  failed: {why}", flush=True)
                except subprocess.TimeoutExpired:
                    print(f"{kind:>13} {(nx + 1) * (4 * nx + 1):>9} {method:>8} {'':>8} "
                          f"{'>' + format(timeout, 'g'):>8} {'':>4} {'':>8} {'':>8}  "
                          "timed out (killed)", flush=True)


def main(argv: list[str] | None = None) -> int:
    """Print the benchmark table; returns 0."""
    ap = argparse.ArgumentParser(prog="fpk-vibro bench fem-scale",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--q1", type=int, nargs="*", default=[32, 64, 128, 256, 500],
                    help="Q1 levels: cells across x (ny = 4 nx); default %(default)s")
    ap.add_argument("--q2", type=int, nargs="*", default=[16, 32, 48, 64, 128],
                    help="Q2 levels; default %(default)s")
    ap.add_argument("--baseline-max", type=int, default=70_000,
                    help="run the baseline up to this many DOFs (default %(default)s)")
    ap.add_argument("--amg", action="store_true",
                    help="also try pyamg AIR / smoothed aggregation on the smallest level")
    ap.add_argument("--quick", action="store_true",
                    help="small levels only: a few seconds (a smoke test)")
    ap.add_argument("--amg-sizes", type=float, nargs="+", metavar="N",
                    help="instead: AMG vs SuperLU at about these DOF counts, e.g. "
                         "1e4 6.6e4 2.6e5 1e6 4e6 (module docstring)")
    ap.add_argument("--amg-kinds", nargs="+", default=["step", "stationary"],
                    choices=["step", "stationary", "galerkin-step"],
                    help="matrices for --amg-sizes; default %(default)s")
    ap.add_argument("--amg-mem-gb", type=float, default=15.0,
                    help="address-space cap per solve (GB); default %(default)s")
    ap.add_argument("--amg-timeout", type=float, default=600.0,
                    help="seconds per solve; default %(default)s")
    ap.add_argument("--amg-worker", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.amg_worker:
        nx, kind, method = args.amg_worker
        _amg_worker(int(nx), kind, method)
        return 0
    if args.amg_sizes:
        amg_table([int(n) for n in args.amg_sizes], args.amg_kinds,
                  mem_gb=args.amg_mem_gb, timeout=args.amg_timeout)
        return 0
    if args.quick:
        args.q1, args.q2, args.baseline_max = [16, 32, 64], [8, 16, 32], 20_000
    head = (f"{'deg':>3} {'nx':>4} {'DOFs':>9} {'solver':>10} {'asm s':>7} {'solve s':>8} "
            f"{'total s':>8} {'wall s':>7} {'mom s':>6} {'pb s':>6} {'L1 err':>9} "
            f"{'max err':>9} {'mass-1':>9} {'base s':>8} {'ratio':>6} {'peak GB':>7}")
    print(f"exact case: {EXACT_SYSTEM}")
    print(head)
    print("-" * len(head))
    for degree, levels in ((1, args.q1), (2, args.q2)):
        for n in levels:
            sol, wall, L1, emax = _run(n, degree)
            mom, pb = _derived_seconds(sol)
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
                  f"{wall:7.2f} {mom:6.2f} {pb:6.2f} {L1:9.2e} {emax:9.2e} "
                  f"{sol.mass - 1:9.1e} {base:>8} {ratio:>6} {_peak_gb():7.2f}", flush=True)
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
