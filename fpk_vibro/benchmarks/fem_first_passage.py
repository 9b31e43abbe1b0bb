"""Accuracy and speed of ``fem.first_passage`` by default (issues 23 and 31).

Run ``fpk-vibro bench fem-first-passage`` (``--nx``, ``--repeat``, ``--quick``,
``--random``, ``--references``).

For five measured systems (:data:`CASES`), and with ``--random`` for the random draw
of issue 31 (:func:`draw`: asymmetric walls with r from 0.05 to 1, one-sided walls,
hardening, softening, linear and double-well springs, parametric noise, starts off
rest), it prints the default τ, the converged reference, the relative error, the
error estimate ``error_estimate()["mean_time"]``, true/estimate,
``["reliability"]`` and the seconds of the whole call (least of ``--repeat`` runs
after a warm-up).  Target: within 0.2 %, true/estimate in [1/30, 2], at most 2 s.

References (:func:`converged`, cached in :data:`CONVERGED`): isoparametric Q2 with the
default wall grading at nx = 256, and, a second way, the Richardson extrapolation
(order 2) of nx = 64 and 128 on a mesh graded as x_w − x ∝ s⁴ toward walls with
r < 1; the two agree within 6e-5 (docs/fem_first_passage.md).  ``--references``
recomputes them (minutes per system).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from contextlib import contextmanager

import numpy as np

from ..model import VibroImpactSystem, Wall
from ..fem import safe_set
from ..fem.first_passage import _level, first_passage
from ..fem.safe_set import safe_set_components
from ..first_passage import parse_start

__all__ = ["CASES", "CONVERGED", "TARGET_REL", "TARGET_SECONDS", "draw", "converged",
           "run", "main"]

_P = VibroImpactSystem.paper
#: name: (system, H_c, start)
CASES = {
    "paper c=0.2 H_c=0.15": (_P(r=0.92).replace(c=0.2), 0.15, (0.0, 0.0)),
    "softening b=-0.2 r=0.5": (_P(r=0.5, b=-0.2, c=0.2), 0.3, (0.0, 0.0)),
    "one wall at 0.6": (_P(r=0.92, c=0.2, barriers="right"), 0.25, (0.0, 0.0)),
    "r=0.2 H_c=0.3": (_P(r=0.2, c=0.2), 0.3, (0.0, 0.0)),
    "double well, one well": (VibroImpactSystem(a=-1.0, b=1.0, c=0.2, D1=0.01, D2=0.01,
                                                barriers="none"), -0.1, (1.0, 0.0)),
    "walls -0.1 (r=0.05), 0.4 (r=0.36)": (VibroImpactSystem(
        a=1.0, b=0.2, c=0.1, D1=0.03, left=Wall(-0.1, r=0.05), right=Wall(0.4, r=0.36)),
        0.35, (0.0, 0.0)),
}
#: name: (τ at nx = 256, τ of the s⁴-graded Richardson) from :func:`converged`; the
#: random draws as "seed S #i".  The tests take their references from here.
CONVERGED = {
    "paper c=0.2 H_c=0.15": (38.076978, 38.076976),
    "softening b=-0.2 r=0.5": (418.530948, 418.530302),
    "one wall at 0.6": (153.294176, 153.295129),
    "r=0.2 H_c=0.3": (409.375567, 409.374709),
    "double well, one well": (11.937952, 11.937901),
    "walls -0.1 (r=0.05), 0.4 (r=0.36)": (170.305571, 170.304336),
    "seed 31 #0": (1938.101769, 1938.215534), "seed 31 #1": (281.82536, 281.823972),
    "seed 31 #2": (66.982701, 66.982157), "seed 31 #3": (108.358743, 108.358093),
    "seed 31 #4": (76.380894, 76.381324), "seed 31 #5": (38.283813, 38.283158),
    "seed 31 #6": (268.742009, 268.740169), "seed 31 #7": (82.417278, 82.417219),
    "seed 31 #8": (27.412452, 27.41213), "seed 31 #9": (41.879342, 41.878911),
    "seed 31 #10": (38.67978, 38.680829), "seed 31 #11": (5.836186, 5.836172),
    "seed 32 #0": (65.046052, 65.04561), "seed 32 #1": (130.871183, 130.866962),
    "seed 32 #2": (118.584144, 118.585521), "seed 32 #3": (30.344935, 30.344904),
    "seed 32 #4": (17.000205, 16.999871), "seed 32 #5": (16.449667, 16.449623),
    "seed 32 #6": (197.162633, 197.163944), "seed 32 #7": (145.71872, 145.727372),
}
TARGET_REL, TARGET_SECONDS = 2e-3, 2.0
_KINDS = ("hardening", "softening", "double well", "linear")


def draw(seed: int = 31, n: int = 12) -> dict[str, tuple]:
    """``n`` random systems, name "seed S #i": (system, H_c, start, kind).

    Springs hardening, softening (walls inside the humps), double well or linear;
    c log-uniform in [0.03, 0.3]; walls drawn independently on each side (r uniform
    in [0.05, 1]), one of them dropped with probability 0.2 where the spring
    confines; H_c 1.15–2.5 times the lower wall's energy above the start's
    potential (below the hump of a softening spring), D1 setting c ΔH/D1 in
    [1.5, 4]; D2 up to D1/scale² with probability 0.6; the start at the bottom of
    a well with a velocity up to 0.4 of the safe set's there.
    """
    rng = np.random.default_rng(seed)
    out: dict[str, tuple] = {}
    while len(out) < n:
        kind = str(rng.choice(_KINDS, p=[0.35, 0.25, 0.3, 0.1]))
        c = float(10 ** rng.uniform(math.log10(0.03), math.log10(0.3)))
        if kind == "double well":
            a, b = -float(rng.uniform(0.5, 1.5)), float(rng.uniform(0.5, 2.0))
            scale = math.sqrt(-a / b)
        elif kind == "softening":
            a = float(rng.uniform(0.5, 2.0))
            b = -float(rng.uniform(0.1, 0.5)) * a
            scale = 0.9 * math.sqrt(a / -b)
        else:
            a = float(rng.uniform(0.5, 2.0))
            b = float(rng.uniform(0.05, 1.0)) if kind == "hardening" else 0.0
            scale = 1.0
        lo = (0.7, 1.6) if kind == "double well" else (0.2, 1.0)
        xl, xr = -scale * float(rng.uniform(*lo)), scale * float(rng.uniform(*lo))
        rl, rr = (float(v) for v in rng.uniform(0.05, 1.0, 2))
        left, right = Wall(round(xl, 3), r=round(rl, 2)), Wall(round(xr, 3), r=round(rr, 2))
        if kind != "softening" and rng.uniform() < 0.2:
            if rng.uniform() < 0.5:
                left = None
            else:
                right = None

        def G(x):
            return 0.5 * a * x * x + 0.25 * b * x ** 4
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        x0 = side * math.sqrt(-a / b) if kind == "double well" else 0.0
        if (left is not None and x0 <= left.position) or \
                (right is not None and x0 >= right.position):
            continue
        g_lo = min(G(w.position) for w in (left, right) if w is not None)
        H_c = G(x0) + (g_lo - G(x0)) * float(rng.uniform(1.15, 2.5))
        if kind == "softening":
            H_c = min(H_c, 0.95 * a * a / (4 * -b))
            if H_c <= g_lo:
                continue
        dH = H_c - G(x0)
        D1 = c * dH / float(rng.uniform(1.5, 4.0))
        D2 = float(rng.uniform(0.0, 1.0)) * D1 / scale ** 2 if rng.uniform() < 0.6 else 0.0
        y0 = float(rng.uniform(-0.4, 0.4)) * math.sqrt(2 * dH)
        system = VibroImpactSystem(a=round(a, 3), b=round(b, 3), c=round(c, 3),
                                   D1=float(f"{D1:.3g}"), D2=float(f"{D2:.3g}"),
                                   left=left, right=right)
        out[f"seed {seed} #{len(out)}"] = (system, float(f"{H_c:.4g}"),
                                           (round(x0, 4), round(y0, 3)), kind)
    return out


@contextmanager
def _wall_power(power: float):
    """The safe-set mesh graded as x_w − x ∝ s^power toward walls with r < 1."""
    old, safe_set.WALL_POWER = safe_set.WALL_POWER, power
    try:
        yield
    finally:
        safe_set.WALL_POWER = old


def _tau(system, H_c, start, nx: int) -> float:
    """τ alone (no reliability march) on the default mesh kind at ``nx``."""
    kind, value = parse_start("bench", system, start, H_c)
    parts = safe_set_components(system, H_c)
    if kind == "point":
        parts = [p for p in parts if p[0] <= value[0] <= p[1]][:1]
    return _level("bench", system, parts, H_c, nx, 2 * nx, 2, kind, value)["mean"]


def converged(system, H_c: float, start) -> tuple[float, float]:
    """(τ at nx = 256 on the default mesh, the Richardson extrapolation (order 2) of
    nx = 64 and 128 graded as s⁴ toward walls with r < 1): two converged values, for
    :data:`CONVERGED`.  Minutes."""
    fine = _tau(system, H_c, start, 256)
    with _wall_power(4.0):
        t64, t128 = _tau(system, H_c, start, 64), _tau(system, H_c, start, 128)
    return fine, t128 + (t128 - t64) / 3.0


def run(nx: int | None = None, repeat: int = 3, random: bool = False,
        references: bool = False, seed: int = 31, n: int = 12, out=sys.stdout
        ) -> list[dict]:
    """Print the table (module docstring) and return its rows; ``random``: the
    ``n`` systems of :func:`draw` with ``seed`` (cached references: seed 31, 12
    systems, and seed 32, 8)."""
    cases = {k: v[:3] for k, v in draw(seed, n).items()} if random else CASES
    rows = []
    print(f"{'system':34s} {'tau':>11s} {'converged':>11s} {'rel.err':>8s} {'est.tau':>8s} "
          f"{'true/est':>8s} {'est.R':>8s} {'s':>6s}", file=out)
    for name, (system, H_c, start) in cases.items():
        if references or name not in CONVERGED:
            ref = converged(system, H_c, start)
            print(f"  {name}: converged {ref[0]:.6f}, {ref[1]:.6f} "
                  f"(apart {abs(ref[0] / ref[1] - 1.0):.1e})", file=out, flush=True)
        else:
            ref = CONVERGED[name]
        first_passage(system, energy=H_c, start=start, nx=nx)
        best = float("inf")
        for _ in range(max(1, repeat)):
            t0 = time.perf_counter()
            fp = first_passage(system, energy=H_c, start=start, nx=nx)
            best = min(best, time.perf_counter() - t0)
        est = fp.error_estimate()
        err = abs(fp.mean / ref[0] - 1.0)
        row = {"system": name, "tau": fp.mean, "converged": ref[0], "error": err,
               "estimate": est["mean_time"], "effectivity": err / est["mean_time"],
               "estimate_R": est["reliability"], "seconds": best}
        rows.append(row)
        print(f"{name:34s} {fp.mean:11.5f} {ref[0]:11.5f} {err:8.1e} {row['estimate']:8.1e} "
              f"{row['effectivity']:8.3f} {row['estimate_R']:8.1e} {best:6.2f}", file=out,
              flush=True)
    ok = all(r["error"] <= TARGET_REL and r["seconds"] <= TARGET_SECONDS for r in rows)
    print(f"target (rel. error <= {TARGET_REL:g}, <= {TARGET_SECONDS:g} s): "
          f"{'met' if ok else 'NOT met'}; true/estimate "
          f"{min(r['effectivity'] for r in rows):.3g} to "
          f"{max(r['effectivity'] for r in rows):.3g}", file=out)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fpk-vibro bench fem-first-passage",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=None, help="cells across x (default: "
                    "fem.first_passage's)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per system (default 3)")
    ap.add_argument("--random", action="store_true",
                    help="the random draw of issue 31 instead of the measured systems")
    ap.add_argument("--seed", type=int, default=31, help="seed of --random (default 31)")
    ap.add_argument("--n", type=int, default=12, help="systems of --random (default 12)")
    ap.add_argument("--references", action="store_true",
                    help="recompute the converged references (minutes per system)")
    ap.add_argument("--quick", action="store_true",
                    help="nx = 16, one timed run: a few seconds (a smoke test)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1; got {args.repeat}")
    if args.quick:
        args.nx, args.repeat = 16, 1
    run(args.nx, args.repeat, args.random, args.references, args.seed, args.n)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
