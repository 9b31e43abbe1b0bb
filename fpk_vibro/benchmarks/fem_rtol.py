"""``fpk-vibro bench fem``: what accuracy costs with ``fem.stationary(system, rtol=...)``.

For each case and each rtol (default 1e-2 … 1e-6) one row: the achieved error
against a fine reference, the error estimate the solution reports, the seconds of
the solve (the estimate comes with it), the level chosen and min p.  "error" and
"estimate" are the largest relative error of E[H], E[x²], E[y²], P_impact (the
quantities rtol judges) and, in the L1 columns, ∫|p − p_ref|.

Cases: the paper's (r = 0.92), a hard case (paper with r = 0.05, D2 = 0) and the
smooth double well without walls of the path-integration peer's exact test
(a = −1, b = 0.25, c = 1, D1 = 0.5: p ∝ exp(−2H)).  References: the exact density
for the double well; Galerkin Q4 with wall grading 2 at nx = 96 otherwise (within
1e-5 of nx = 48 on these cases; docs/measurements.md).  A refused rtol (the next
level beyond the budget) prints its one-line reason.  Measured tables:
docs/measurements.md, §What accuracy costs.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from .._checks import InputError
from ..model import VibroImpactSystem
from ..fem import stationary
from ..fem.estimate import JUDGED, difference

__all__ = ["CASES", "main"]

CASES = {
    "paper (r = 0.92)": VibroImpactSystem.paper(),
    "hard (r = 0.05, D2 = 0)": VibroImpactSystem.paper(r=0.05, D2=0.0),
    "double well, no walls": VibroImpactSystem(a=-1.0, b=0.25, c=1.0, D1=0.5,
                                               barriers="none"),
}


def _reference(system: VibroImpactSystem, nx: int):
    from .. import exact
    if not system.has_barrier and system.D2 == 0:
        return exact.gibbs(system)
    return stationary(system, degree=4, nx=nx, wall_grading=2.0, positivity=False)


def _exact_l1(sol, ref) -> float:
    from ..fem.highorder import l1_error
    return l1_error(sol, ref.pdf_joint)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="fpk-vibro bench fem", description=__doc__.split("\n")[0])
    p.add_argument("--rtol", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6],
                   help="accuracy goals (default 1e-2 … 1e-6)")
    p.add_argument("--ref-nx", type=int, default=96,
                   help="cells across x of the Q4 references (default 96)")
    p.add_argument("--case", choices=list(CASES), action="append",
                   help="only this case (repeatable)")
    p.add_argument("--quick", action="store_true",
                   help="rtol 1e-2 only, references at nx = 16: a few seconds (a smoke test)")
    args = p.parse_args(argv)
    if args.quick:
        args.rtol, args.ref_nx = [1e-2], 16
    if any(not 0 < r < 1 for r in args.rtol):
        p.error(f"--rtol must lie in (0, 1); got {args.rtol}")
    if args.ref_nx < 8:
        p.error(f"--ref-nx must be >= 8; got {args.ref_nx}")
    stationary(VibroImpactSystem.paper(r=1.0), degree=2, nx=8)      # warm-up: imports
    head = (f"{'case':<24s} {'rtol':>7s} {'error':>8s} {'estimate':>8s} {'L1 err':>8s} "
            f"{'L1 est':>8s} {'seconds':>8s} {'min p':>8s}  level")
    print(head)
    for name in args.case or CASES:
        system = CASES[name]
        ref = _reference(system, args.ref_nx)
        for rtol in args.rtol:
            t0 = time.perf_counter()
            try:
                sol = stationary(system, rtol=rtol)
            except InputError as exc:
                print(f"{name:<24s} {rtol:7.0e}  refused: {str(exc).split(': ', 1)[-1]}")
                continue
            seconds = time.perf_counter() - t0
            est = sol.error_estimate()
            if hasattr(ref, "dofs"):
                d = difference(sol, ref)
                l1 = d["L1"]
            else:
                m, mr = sol.moments(), ref.moments()
                d = {k: abs(m[k] - mr[k]) / abs(mr[k]) for k in JUDGED if k in mr}
                l1 = _exact_l1(sol, ref)
            err = max(v for k, v in d.items() if k in JUDGED)
            e = max(est[k] for k in JUDGED if k in est)
            level = f"Q{sol.degree}, nx {len(sol._tensor[0]) - 1}"
            print(f"{name:<24s} {rtol:7.0e} {err:8.1e} {e:8.1e} {l1:8.1e} {est['L1']:8.1e} "
                  f"{seconds:8.2f} {float(np.min(sol.dofs)):8.1e}  {level}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
