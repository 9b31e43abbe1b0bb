"""``fpk-vibro bench averaging``: wall time of the stationary averaged solution.

For five systems (the paper's at r = 0.98, 0.92, a low restitution with more
damping, wide walls, one wall) one row: the median and least milliseconds of
``averaging.stationary`` over ``--repeat`` runs after a warm-up, Φ's panels and E[H].
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from .. import averaging
from ..model import VibroImpactSystem

__all__ = ["CASES", "main"]

#: (name, system) of each row.
CASES = [("paper r=0.98", VibroImpactSystem.paper(r=0.98)),
         ("paper r=0.92", VibroImpactSystem.paper(r=0.92)),
         ("paper r=0.3, c=0.1", VibroImpactSystem.paper(r=0.3, c=0.1)),
         ("paper delta=1.0", VibroImpactSystem.paper(delta=1.0)),
         ("unilateral r=0.92", VibroImpactSystem.paper(r=0.92, barriers="right"))]


def main(argv: list[str] | None = None) -> int:
    """Print the table (module docstring); returns 0."""
    p = argparse.ArgumentParser(prog="fpk-vibro bench averaging",
                                description=__doc__.split("\n")[0])
    p.add_argument("--repeat", type=int, default=20, help="timed repetitions (default 20)")
    p.add_argument("--quick", action="store_true", help="2 repetitions (a smoke test)")
    args = p.parse_args(argv)
    if args.repeat < 1:
        p.error(f"--repeat must be >= 1; got {args.repeat}")
    repeat = 2 if args.quick else args.repeat
    print(f"{'case':<34s} {'median ms':>10s} {'min ms':>8s} {'panels':>7s} {'E_H':>12s}")
    averaging.stationary(CASES[0][1])  # warm-up (imports, caches)
    for name, system in CASES:
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            sol = averaging.stationary(system)
            times.append(time.perf_counter() - t0)
        print(f"{name:<34s} {1e3*np.median(times):10.1f} {1e3*min(times):8.1f} "
              f"{sol.info['panels']:7d} {sol.moments()['E_H']:12.8f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
