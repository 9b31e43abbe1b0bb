"""Accuracy and speed of ``fem.first_passage`` by default (issue 23).

Run ``fpk-vibro bench fem-first-passage`` (``--nx``, ``--repeat``, ``--quick``).

For five systems it prints the default τ (start and H_c below), the converged
reference (isoparametric Q2 at nx = 64, 128 and 256 for the paper case, the last
difference: docs/fem_first_passage.md), the relative error, the two-level estimate
``error_estimate()["mean_time"]`` and ``["reliability"]`` and the seconds of the
whole call (least of ``--repeat`` runs after a warm-up).  Target: within 0.2 % in
at most 2 s.
"""
from __future__ import annotations

import argparse
import sys
import time

from ..model import VibroImpactSystem
from ..fem.first_passage import first_passage

__all__ = ["CASES", "run", "main"]

_P = VibroImpactSystem.paper
#: name: (system, H_c, start, converged τ)
CASES = {
    "paper c=0.2 H_c=0.15": (_P(r=0.92).replace(c=0.2), 0.15, (0.0, 0.0), 38.0770),
    "softening b=-0.2 r=0.5": (_P(r=0.5, b=-0.2, c=0.2), 0.3, (0.0, 0.0), 418.529),
    "one wall at 0.6": (_P(r=0.92, c=0.2, barriers="right"), 0.25, (0.0, 0.0), 153.297),
    "r=0.2 H_c=0.3": (_P(r=0.2, c=0.2), 0.3, (0.0, 0.0), 409.37),
    "double well, one well": (VibroImpactSystem(a=-1.0, b=1.0, c=0.2, D1=0.01, D2=0.01,
                                                barriers="none"), -0.1, (1.0, 0.0), 11.9381),
}
TARGET_REL, TARGET_SECONDS = 2e-3, 2.0


def run(nx: int | None = None, repeat: int = 3, out=sys.stdout) -> list[dict]:
    rows = []
    print(f"{'system':26s} {'tau':>11s} {'converged':>10s} {'rel.err':>8s} "
          f"{'est.tau':>8s} {'est.R':>8s} {'s':>6s}", file=out)
    for name, (system, H_c, start, ref) in CASES.items():
        first_passage(system, energy=H_c, start=start, nx=nx)
        best = float("inf")
        for _ in range(max(1, repeat)):
            t0 = time.perf_counter()
            fp = first_passage(system, energy=H_c, start=start, nx=nx)
            best = min(best, time.perf_counter() - t0)
        est = fp.error_estimate()
        row = {"system": name, "tau": fp.mean, "converged": ref,
               "error": abs(fp.mean / ref - 1.0), "estimate": est["mean_time"],
               "estimate_R": est["reliability"], "seconds": best}
        rows.append(row)
        print(f"{name:26s} {fp.mean:11.5f} {ref:10.4f} {row['error']:8.1e} "
              f"{row['estimate']:8.1e} {row['estimate_R']:8.1e} {best:6.2f}", file=out,
              flush=True)
    ok = all(r["error"] <= TARGET_REL and r["seconds"] <= TARGET_SECONDS for r in rows)
    print(f"target (rel. error <= {TARGET_REL:g}, <= {TARGET_SECONDS:g} s): "
          f"{'met' if ok else 'NOT met'}", file=out)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fpk-vibro bench fem-first-passage",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=None, help="cells across x (default: "
                    "fem.first_passage's)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per system (default 3)")
    ap.add_argument("--quick", action="store_true",
                    help="nx = 16, one timed run: a few seconds (a smoke test)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1; got {args.repeat}")
    if args.quick:
        args.nx, args.repeat = 16, 1
    run(args.nx, args.repeat)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
