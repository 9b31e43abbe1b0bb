"""Command line: ``fpk-vibro COMMAND`` (also ``python -m fpk_vibro``).

Commands
--------
paper       the paper's case end to end (Fig. 3 analogue): p(H) for r = 0.98, 0.92
bench NAME  benchmarks: ``averaging``, ``montecarlo``, ``fem``
"""
from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

from . import __version__

_BENCHMARKS = {
    "averaging": "fpk_vibro.benchmarks",
    "montecarlo": "fpk_vibro.montecarlo.benchmark",
    "fem": "fpk_vibro.fem.benchmark",
}


def _print_moments(label: str, moments: dict[str, float], se: dict[str, float] | None = None) -> None:
    cells = []
    for k, v in moments.items():
        cell = f"{k}={v:.6g}"
        if se and k in se:
            cell += f"±{se[k]:.2g}"
        cells.append(cell)
    print(f"  {label:<22s} " + "  ".join(cells))


def cmd_paper(args: argparse.Namespace) -> int:
    """Yang et al. (2016) Fig. 3: averaged p(H) for r = 0.98 and 0.92, moments printed."""
    from . import averaging, plotting
    from .model import VibroImpactSystem

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    curves = []
    print("fpk-vibro: paper case a=1, b=0.2, c=0.025, D1=D2=0.01, Δ=0.6 (Yang et al. 2016, Fig. 3)")
    for r in (0.98, 0.92):
        system = VibroImpactSystem.paper(r=r)
        t0 = time.perf_counter()
        sol = averaging.stationary(system)
        dt = time.perf_counter() - t0
        _print_moments(f"averaging r={r} ({dt*1e3:.0f} ms)", sol.moments())
        sol.save(out / f"averaging_r{r}.npz")
        curves.append((f"averaging, r = {r}", sol))
    fig = plotting.plot_energy_pdfs(curves, out / "fig3_pdf_energy.png",
                                    title="Stationary p(H), Δ = 0.6 (cf. paper Fig. 3)")
    print(f"  wrote {fig} and the solutions (*.npz) in {out}/")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    module = importlib.import_module(_BENCHMARKS[args.name])
    return int(module.main(args.rest) or 0)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fpk-vibro", description=__doc__.split("\n")[0])
    p.add_argument("--version", action="version", version=f"fpk-vibro {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    pp = sub.add_parser("paper", help="the paper's case end to end (Fig. 3 analogue)")
    pp.add_argument("--out", default="results", help="output directory (default: results)")
    pp.set_defaults(func=cmd_paper)
    pb = sub.add_parser("bench", help="benchmarks")
    pb.add_argument("name", choices=sorted(_BENCHMARKS))
    pb.add_argument("rest", nargs=argparse.REMAINDER, help="options passed to the benchmark")
    pb.set_defaults(func=cmd_bench)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("fpk-vibro: interrupted", file=sys.stderr)
        return 130
    except ValueError as exc:
        print(f"fpk-vibro: error: {exc}", file=sys.stderr)
        return 2
