"""The default stationary FE solve on random scenes: what rtol = 1e-4 costs and where
it is not reached.

Run ``fpk-vibro bench fem-scenes [--seeds 0 40] [--named]``.  Each seed draws a
system as the issue tracker's random scenes were drawn: stiffness single-well, pure
cubic, softening or double-well; c in [0.01, 0.5] and D1 in [0.002, 0.2]
(log-uniform), D2 = 0 or up to 0.8 c; walls symmetric, asymmetric or one-sided with r
in [0.3, 1].  ``--named`` adds the slow systems of issue 31 (:data:`NAMED`: a double
well with c = 0.01, a pure cubic spring, the hard corners r = 0 and 0.05 at
D1 = 0.002).  One line per scene: seconds, the largest relative moment estimate,
the L1 estimate (rtol bounds both since issue 31), the quantity that decided,
whether it is flagged, min p and the level chosen.  Measured tables:
docs/measurements.md, §The default: rtol = 1e-4, best effort.
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from ..model import VibroImpactSystem, Wall
from ..fem import stationary

__all__ = ["NAMED", "draw", "main"]

_P = VibroImpactSystem.paper
#: The systems issue 31 found slow by default (7.4 s, 3.8 s, 4.3–5.6 s).
NAMED = {
    "double well c=0.01": VibroImpactSystem(a=-1.0, b=1.0, c=0.01, D1=0.05, D2=0.01,
                                            delta=2.0, r=0.92),
    "pure cubic": VibroImpactSystem(a=0.0, b=1.0, c=0.025, D1=0.01, delta=0.6, r=0.9),
    "corner r=0": _P(r=0.0, D1=0.002, D2=0.0),
    "corner r=0.05": _P(r=0.05, D1=0.002, D2=0.0),
}


def draw(seed: int) -> tuple[str, VibroImpactSystem]:
    """(label, system) of random scene ``seed`` (module docstring)."""
    rng = np.random.default_rng(seed)
    kind = str(rng.choice(["single", "cubic", "softening", "double"]))
    c = float(np.exp(rng.uniform(np.log(0.01), np.log(0.5))))
    D1 = float(np.exp(rng.uniform(np.log(0.002), np.log(0.2))))
    D2 = float(rng.choice([0.0, rng.uniform(0, 0.8 * c)]))
    r = float(rng.uniform(0.3, 1.0))
    walls = str(rng.choice(["sym", "asym", "one"]))
    a, b = {"single": (1.0, float(rng.uniform(0, 1))), "cubic": (0.0, 1.0),
            "softening": (1.0, -0.5), "double": (-1.0, 1.0)}[kind]
    reach = {"single": 0.5, "cubic": 0.6, "softening": 0.8, "double": 1.8}[kind]
    d = reach * float(rng.uniform(0.4, 1.1))
    if kind == "softening":
        d = min(d, 1.2)
        if walls == "one":           # a softening spring needs a wall on each side
            walls = "sym"
    if walls == "sym":
        s = VibroImpactSystem(a=a, b=b, c=c, D1=D1, D2=D2, delta=d, r=r)
    elif walls == "one":
        s = VibroImpactSystem(a=a, b=b, c=c, D1=D1, D2=D2, delta=d, r=r, barriers="right")
    else:
        s = VibroImpactSystem(a=a, b=b, c=c, D1=D1, D2=D2, left=Wall(-d, r),
                              right=Wall(0.6 * d, float(min(1.0, r + rng.uniform(0, 0.4)))))
    return f"{kind}/{walls}", s


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="fpk-vibro bench fem-scenes",
                                description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, nargs=2, default=[0, 40], metavar=("FROM", "TO"),
                   help="seeds FROM .. TO-1 (default 0 40)")
    p.add_argument("--named", action="store_true",
                   help="also the slow systems of issue 31 (NAMED)")
    p.add_argument("--quick", action="store_true",
                   help="seeds 0 and 1 at rtol = 1e-2: a few seconds (a smoke test)")
    args = p.parse_args(argv)
    rtol = 1e-2 if args.quick else None
    if args.quick:
        args.seeds = [0, 2]
    if args.seeds[1] <= args.seeds[0] or args.seeds[0] < 0:
        p.error(f"--seeds must be 0 <= FROM < TO; got {args.seeds}")
    stationary(VibroImpactSystem.paper(r=1.0), degree=2, nx=8)      # warm-up: imports
    stationary(VibroImpactSystem.paper(r=1.0), degree=4, nx=4)
    scenes = [(str(seed), *draw(seed)) for seed in range(*args.seeds)]
    if args.named:
        scenes += [("-", name, s) for name, s in NAMED.items()]
    times, flagged = [], 0
    print(f"{'seed':>4s} {'scene':<19s} {'seconds':>8s} {'moments':>9s} {'L1 est':>8s} "
          f"{'decided':>8s} {'flagged':>8s} {'min p':>8s}  level")
    for seed, label, s in scenes:
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as seen:     # (the flag says it)
            warnings.simplefilter("always")
            sol = stationary(s) if rtol is None else stationary(s, rtol=rtol)
        seconds = time.perf_counter() - t0
        est = sol.error_estimate()
        worst = max(est[k] for k in ("E_H", "E_x2", "E_y2", "P_impact") if k in est)
        times.append(seconds)
        flagged += bool(sol.info["under_resolved"])
        warned = "" if not seen else " (warned)"
        xs, ys = sol._tensor
        print(f"{seed:>4s} {label:<19s} {seconds:8.2f} {worst:9.1e} {est['L1']:8.1e} "
              f"{sol.info.get('rtol_decided_by', '-'):>8s} "
              f"{str(sol.info['under_resolved']):>8s} {sol.dofs.min():8.1e}  "
              f"Q{sol.degree}, nx {xs.size - 1}, ny {ys.size - 1}{warned}", flush=True)
    print(f"median {np.median(times):.2f} s, worst {max(times):.2f} s, flagged {flagged} "
          f"of {len(times)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
