"""The 3-D coloured-noise FE solve: unknowns, GMRES iterations, factor memory and
seconds, against one sparse LU of the same system where that is affordable.

Run ``fpk-vibro bench fem-coloured`` (``--help`` for options).  The system is the
paper's with walls at ±0.6, r = 0.92, D2 = 0 and τ = 0.5.
"""
from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from ..fem.coloured_operator import assemble_coloured, zeta_nodes
from ..fem.coloured_solve import ModeSolver, solve_lu
from ..fem.mesh import axis_nodes, domain, wall_nodes
from ..model import VibroImpactSystem
from ..noise import OrnsteinUhlenbeck

SYSTEM = VibroImpactSystem.paper(r=0.92, D2=0.0, external=OrnsteinUhlenbeck(tau=0.5))
#: (nx, ny, nz) at degree 2; LU up to LU_MAX unknowns.
GRIDS = [(8, 16, 8), (16, 24, 12), (32, 24, 16), (24, 36, 12)]
LU_MAX = 50_000


def run(nx: int, ny: int, nz: int, degree: int, lu: bool) -> dict:
    dom = domain(SYSTEM.replace(external=None))
    t0 = time.perf_counter()
    op = assemble_coloured(SYSTEM, wall_nodes(dom, nx), axis_nodes(-dom.y_max, dom.y_max, ny,
                                                                    centre=0.0),
                           zeta_nodes(SYSTEM, nz), degree, dom=dom)
    t_asm = time.perf_counter() - t0
    t0 = time.perf_counter()
    ms = ModeSolver(op)
    p, info = ms.solve()
    out = {"unknowns": op.size, "nnz": op.L.nnz, "assembly_s": t_asm,
           "iterations": info["iterations"], "factor_GB": ms.info["factor_bytes"] / 1e9,
           "modes_s": time.perf_counter() - t0,
           "peak_GB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6}
    if lu and op.size <= LU_MAX:
        q, linfo = solve_lu(op)
        out.update(lu_s=linfo["solve_seconds"], lu_GB=linfo["factor_bytes"] / 1e9,
                   lu_diff=float(np.max(np.abs(p - q)) / np.max(q)))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fpk-vibro bench fem-coloured",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--grid", action="append", default=None, metavar="NX:NY:NZ",
                    help="a grid (repeatable); default: a table up to 9·10⁴ unknowns")
    ap.add_argument("--degree", type=int, default=2)
    ap.add_argument("--no-lu", action="store_true", help="skip the LU comparison")
    ap.add_argument("--quick", action="store_true", help="the smallest grid only (a smoke test)")
    args = ap.parse_args(argv)
    grids = GRIDS if not args.grid else [tuple(int(v) for v in g.split(":")) for g in args.grid]
    if args.quick:
        grids = GRIDS[:1]
    print(f"{'grid':>12} {'unknowns':>9} {'iters':>5} {'factors GB':>10} {'peak GB':>7} "
          f"{'modes s':>7} {'LU s':>7} {'LU GB':>6} {'max diff':>8}")
    for nx, ny, nz in grids:
        r = run(nx, ny, nz, args.degree, not args.no_lu)
        lu = (f"{r['lu_s']:>7.2f} {r['lu_GB']:>6.2f} {r['lu_diff']:>8.1e}" if "lu_s" in r
              else f"{'-':>7} {'-':>6} {'-':>8}")
        print(f"{f'{nx}x{ny}x{nz}':>12} {r['unknowns']:>9} {r['iterations']:>5} "
              f"{r['factor_GB']:>10.3f} {r['peak_GB']:>7.2f} {r['modes_s']:>7.2f} {lu}",
              flush=True)
    return 0


if __name__ == "__main__":          # pragma: no cover
    raise SystemExit(main())
