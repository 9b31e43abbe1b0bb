"""The cost of a restitution law in the FE solve (issue 32): tabulated r(u) against a
constant r on the same mesh.

Run ``fpk-vibro bench fem-restitution`` (``--help`` for options).

On the paper system (walls ±0.6) it times ``fem.stationary`` (the whole call: options,
mesh, assembly with the impact coupling, solve, power balance; the least of
``--repeat`` runs after one warm-up) with r = 0.8 and with a 12-knot table falling from
r = 0.95 to 0.7 over the impact speeds (u·r(u) increasing), at the same degree and
mesh, and prints the ratio law / constant.  The target: at most 1.5.  The law adds
only the pre-images φ⁻¹ of the wall's nodes (a vectorised bisection) and more
breakpoints of the wall quadrature; the sparse pattern of L is the same.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from ..fem import stationary
from ..model import VibroImpactSystem
from ..restitution import Restitution

__all__ = ["TABLE", "TARGET_RATIO", "run", "main"]

#: The tabulated law: r from 0.95 at rest to 0.7 at u = 1.5 and beyond.
TABLE = Restitution.table(np.linspace(0.0, 1.5, 12), np.linspace(0.95, 0.7, 12))
TARGET_RATIO = 1.5


def _time(system: VibroImpactSystem, degree: int, nx: int, repeat: int) -> float:
    stationary(system, degree=degree, nx=nx)                  # warm-up
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        stationary(system, degree=degree, nx=nx)
        best = min(best, time.perf_counter() - t0)
    return best


def run(degree: int = 2, nx: int = 64, repeat: int = 5) -> dict[str, float]:
    """Least seconds of the constant-r and the tabulated-law solve, and their ratio."""
    base = VibroImpactSystem.paper(r=0.8)
    law = base.replace(**{"left.r": TABLE, "right.r": TABLE})
    t_const = _time(base, degree, nx, repeat)
    t_law = _time(law, degree, nx, repeat)
    return {"degree": degree, "nx": nx, "constant_s": t_const, "law_s": t_law,
            "ratio": t_law / t_const}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fpk-vibro bench fem-restitution",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per case")
    ap.add_argument("--quick", action="store_true",
                    help="Q2 nx = 16, one timed run: about a second (a smoke test)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1; got {args.repeat}")
    configs = [(2, 64), (4, 32)]
    if args.quick:
        configs, args.repeat = [(2, 16)], 1
    print(f"{'degree':>6} {'nx':>4} {'constant r s':>12} {'table law s':>11} {'ratio':>6}")
    worst = 0.0
    for degree, nx in configs:
        r = run(degree, nx, args.repeat)
        worst = max(worst, r["ratio"])
        print(f"{degree:>6} {nx:>4} {r['constant_s']:>12.3f} {r['law_s']:>11.3f} "
              f"{r['ratio']:>6.2f}", flush=True)
    verdict = "meets" if worst <= TARGET_RATIO else "misses"
    print(f"largest ratio law / constant: {worst:.2f} ({verdict} the {TARGET_RATIO:g} target)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
