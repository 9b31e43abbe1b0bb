"""Benchmark of the FE transient on the paper packet (not a unit test).

``fpk-vibro bench fem-transient [--quick] [--variants ...]`` prints,
for ``x = 0, y ~ N(1, 0.05²)`` on ``VibroImpactSystem.paper(r=0.92)``, the seconds of
each variant and the relative errors of E[H], E[x²], E[y²] at t = 1, 5, 20, 80
against :data:`REFERENCE`.
"""
from __future__ import annotations

import argparse
import time
from typing import Callable

import numpy as np

from ..model import VibroImpactSystem

__all__ = ["main", "REFERENCE", "PACKET", "TIMES", "relative_errors"]

PACKET = {"mean": (0.0, 1.0), "std": (0.0, 0.05)}
TIMES = (1.0, 5.0, 20.0, 80.0)
KEYS = ("E_H", "E_x2", "E_y2")

#: E[H], E[x²], E[y²] at TIMES: Q2, nx = 96 (82 025 DOFs), adaptive BDF2, tol = 3e-5:
#: ``fem.transient(VibroImpactSystem.paper(r=0.92), initial=PACKET, times=TIMES,
#: degree=2, nx=96, tol=3e-5)`` (2561 steps).  Cross-check, Q2 nx = 64, tol = 1e-5:
#: within 1.0e-4 relative everywhere (E[x²] at t = 1: 0.11402704).
REFERENCE = np.array([
    [0.44562442501603855, 0.11401612683315643, 0.7754543234713297],
    [0.33088773132691846, 0.13408778871933236, 0.5246739116336622],
    [0.19512584865224553, 0.11146030325988067, 0.27647575919660367],
    [0.16613058371279638, 0.10258975313486438, 0.22760966990320086],
])


def relative_errors(sols, times=TIMES) -> np.ndarray:
    """|m − m_ref| / m_ref for each solution's (E[H], E[x²], E[y²]), rows per time."""
    rows = [TIMES.index(float(t)) for t in times]
    got = np.array([[s.moments()[k] for k in KEYS] for s in sols])
    return np.abs(got - REFERENCE[rows]) / REFERENCE[rows]


def _variants(quick: bool) -> dict[str, Callable]:
    from ..fem.exponential import exponential
    from ..fem.transient import transient
    system = VibroImpactSystem.paper(r=0.92)
    nx = 24 if quick else None

    def run(**kw):
        return lambda: transient(system, initial=PACKET, times=TIMES, nx=nx, **kw)

    return {
        "default": run(),
        "tol=1e-3": run(tol=1e-3),
        "tol=1e-5": run(tol=1e-5),
        "q1-nx128": lambda: transient(system, initial=PACKET, times=TIMES, degree=1,
                                         nx=48 if quick else 128),
        "positive-euler": run(positivity="first-order"),
        "exp-first-order": lambda: exponential(system, initial=PACKET, times=TIMES,
                                                  positivity="first-order", nx=nx or 128),
        "exp-quick": lambda: exponential(system, initial=PACKET, times=TIMES,
                                            positivity="quick", nx=nx or 128, dt=0.05),
    }


def main(argv: list[str] | None = None) -> int:
    """Run the variants and print seconds and relative errors (see module docstring)."""
    variants = _variants(False)
    parser = argparse.ArgumentParser(prog="fpk-vibro bench fem-transient",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="coarse meshes (Q2 nx = 24, Q1 nx = 48): seconds, not accuracy")
    parser.add_argument("--variants", nargs="+", default=["default"],
                        choices=sorted(variants) + ["all"], help="what to run")
    args = parser.parse_args(argv)
    variants = _variants(args.quick)
    names = list(variants) if "all" in args.variants else args.variants
    print(f"{'variant':>16} {'seconds':>8} {'steps':>6}  max rel. error of "
          f"(E_H, E_x2, E_y2) at t = {', '.join(f'{t:g}' for t in TIMES)}")
    for name in names:
        t0 = time.perf_counter()
        sols = variants[name]()
        seconds = time.perf_counter() - t0
        err = relative_errors(sols)
        info = sols[-1].info
        steps = info.get("steps", info.get("matvecs", ""))
        cells = "  ".join(f"{e:.1e}" for e in err.max(axis=1))
        print(f"{name:>16} {seconds:8.2f} {steps!s:>6}  {cells}   (worst {err.max():.2e}; "
              f"ndofs {sols[0].dofs.size})", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
