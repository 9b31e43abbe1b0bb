"""``fpk-vibro bench averaging``: wall time of the stationary averaged solution."""
from __future__ import annotations

import argparse
import time

import numpy as np

from .. import averaging
from ..model import VibroImpactSystem


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="fpk-vibro bench averaging")
    p.add_argument("--repeat", type=int, default=20, help="timed repetitions (default 20)")
    args = p.parse_args(argv)
    if args.repeat < 1:
        p.error(f"--repeat must be >= 1; got {args.repeat}")
    print(f"{'case':<34s} {'median ms':>10s} {'min ms':>8s} {'panels':>7s} {'E_H':>12s}")
    cases = [("paper r=0.98", VibroImpactSystem.paper(r=0.98)),
             ("paper r=0.92", VibroImpactSystem.paper(r=0.92)),
             ("paper r=0.3, c=0.1", VibroImpactSystem.paper(r=0.3, c=0.1)),
             ("paper delta=1.0", VibroImpactSystem.paper(delta=1.0)),
             ("unilateral r=0.92", VibroImpactSystem.paper(r=0.92, barriers="right"))]
    averaging.stationary(cases[0][1])  # warm-up (imports, caches)
    for name, system in cases:
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            sol = averaging.stationary(system)
            times.append(time.perf_counter() - t0)
        panels = sol._low.coef.shape[1] + sol._high.coef.shape[1]
        print(f"{name:<34s} {1e3*np.median(times):10.1f} {1e3*min(times):8.1f} {panels:7d} "
              f"{sol.moments()['E_H']:12.8f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
