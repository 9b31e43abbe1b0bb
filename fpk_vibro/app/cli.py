"""Command line: ``fpk-vibro COMMAND`` (also ``python -m fpk_vibro``).

Commands
--------
run SCENE   run a scene (TOML): results.json, densities.npz, figures
check SCENE every check of run, and the cost per point and method, without running
keys        the table of scene keys (Markdown), generated from the declarations
methods     what each registered method handles (Markdown; docs/guide/methods.md)
show DIR    print the summary table of a results directory
study KIND  ``convergence`` (error vs wall time) or ``averaging`` (where it holds)
paper       the paper's case end to end (Fig. 3 analogue): p(H) for r = 0.98, 0.92
bench NAME  a benchmark of :mod:`fpk_vibro.benchmarks` (``--quick``: a few seconds)
"""
from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

from .._version import __version__


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
    from .. import averaging
    from . import plotting
    from ..model import VibroImpactSystem

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


def _load(args: argparse.Namespace):
    from .scenes import load_scene
    scene = load_scene(args.scene)
    return scene.reduced() if getattr(args, "reduced", False) else scene


def cmd_run(args: argparse.Namespace) -> int:
    from .runner import run_scene

    scene = _load(args)
    log = (lambda s: None) if args.quiet else print
    log(f"fpk-vibro: scene {scene.name!r}: methods {list(scene.methods)}, "
        f"{scene.n_points} point(s), effects {scene.system.effects}")
    doc = run_scene(scene, out=args.out, workers=args.workers, scheduler=args.scheduler,
                    log=log, progress=None if not args.quiet else False, resume=args.resume,
                    warn=lambda s: print(s.strip(), file=sys.stderr))
    out = Path(args.out) if args.out else scene.output_dir
    if not args.quiet:
        _print_summary(doc)
        print(f"  wrote {out}/results.json")
    if doc["status"] == "interrupted":
        _say(f"interrupted ({doc['signal']}): the run is partial: {_kept(doc['points'])}, "
             f"in {out}/results.json; continue with --resume")
        return 128 + int(getattr(signal, doc["signal"]))
    return 1 if any(p.get("status") == "failed" for p in doc["points"]) else 0


def _kept(points: list[dict]) -> str:
    """What an interrupted run kept, counted: "2 of 3 point(s) kept (1 finished, 1 with
    every answer but no error estimate)"; a point a signal stopped keeps its answers
    (with ``partial`` where a method was cut short) or, stopped in its estimates, every
    answer without them."""
    done = sum(p.get("status") == "done" for p in points)
    stopped = [p for p in points if p.get("status") == "interrupted" and p.get("methods")]
    partial = sum(any(e.get("partial") for e in p["methods"].values()) for p in stopped)
    parts = [f"{done} finished"]
    if len(stopped) > partial:
        parts.append(f"{len(stopped) - partial} with every answer but no error estimate")
    if partial:
        parts.append(f"{partial} with partial answers")
    return f"{done + len(stopped)} of {len(points)} point(s) kept ({', '.join(parts)})"


def cmd_check(args: argparse.Namespace) -> int:
    """Every check of ``run``, per point and method, with the cost estimates."""
    from ..budget import human_bytes, human_seconds
    from .scenes import check_scene

    scene = _load(args)
    points = check_scene(scene)
    print(f"{args.scene}: valid — methods {list(scene.methods)}, quantities "
          f"{list(scene.quantities)}, {_mode_words(scene)}, "
          f"{len(points)} point(s){' (reduced)' if args.reduced else ''}")
    total_s, peak = 0.0, 0.0
    for i, pt in enumerate(points):
        label = ", ".join(f"{k}={v:g}" for k, v in pt["parameters"].items()) or "single point"
        print(f"  point {i + 1}: {label}")
        for method, cost in pt["costs"].items():
            print(f"    {method:<11s} {cost.describe()}")
            total_s += cost.seconds
            peak = max(peak, cost.memory)
    print(f"  estimated total: ~{human_seconds(total_s)} of compute, at most "
          f"~{human_bytes(peak)} of memory per point")
    return 0


def _mode_words(scene) -> str:
    """What the scene computes: its times, its phases (forced) or stationary."""
    if scene.transient:
        return "times " + str(list(scene.times))
    if scene.periodic:
        return f"periodic response at {len(scene.phases)} phases"
    return "stationary"


def cmd_show(args: argparse.Namespace) -> int:
    import json

    path = Path(args.dir) / "results.json"
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ValueError(f"{path}: cannot read results ({reason})") from None
    import contextlib
    import io
    text = io.StringIO()
    try:
        with contextlib.redirect_stdout(text):
            _print_summary(doc)
    except (KeyError, TypeError, AttributeError, ValueError, IndexError):
        raise ValueError(f"{path}: not a results file of fpk-vibro (malformed)") from None
    print(text.getvalue(), end="")
    return 0


def _print_summary(doc: dict) -> None:
    keys = ("E_H", "E_x2", "E_y2", "P_impact")
    print(f"  {'point':<24s} {'method':<11s} {'time s':>7s} " + " ".join(f"{k:>18s}" for k in keys)
          + f" {'error (est.)':>12s}")
    for p in doc["points"]:
        label = ", ".join(f"{k}={v:g}" for k, v in p["parameters"].items()) or "-"
        if "error" in p:
            print(f"  {label:<24s} FAILED: {p['error']}")
            continue
        if p.get("status") == "interrupted" and not p.get("methods"):
            print(f"  {label:<24s} INTERRUPTED (not computed)")
            continue
        for method, e in p["methods"].items():
            rec = e["at"][-1] if "at" in e else e
            m, se = rec["moments"], rec.get("moments_se", {})
            cells = [(f"{m[k]:.6g}" + (f"±{se[k]:.1g}" if k in se else "")) if k in m else "-"
                     for k in keys]
            # a method a signal cut short: its numbers are from the part it finished
            flag = "  PARTIAL (interrupted)" if e.get("partial") or rec.get("partial") else ""
            print(f"  {label:<24s} {method:<11s} {e['wall_time_s']:7.2f} " +
                  " ".join(f"{c:>18s}" for c in cells) + f" {_error_cell(rec):>12s}" + flag)


def _error_cell(entry: dict) -> str:
    """The largest relative figure of a method's error estimate (of a transient: at the
    last time; "-" where none; "unbounded" where the estimate says no bound follows)."""
    est = entry.get("error_estimate")
    if not est:
        return "-"
    from ..keys import JUDGED
    vals = [est[k] for k in JUDGED if k in est]
    if any(v is None for v in vals):
        return "unbounded"
    return f"{max(vals):.2g}" if vals else "-"


def cmd_study(args: argparse.Namespace) -> int:
    from . import studies
    from .scenes import load_scene

    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else scene.output_dir / f"study_{args.kind}"
    print(f"fpk-vibro: {args.kind} study of {scene.name!r}{' (quick)' if args.quick else ''}")
    if args.kind == "convergence":
        doc = studies.convergence_study(scene, quick=args.quick)
    else:
        doc = studies.averaging_study(scene, quick=args.quick)
    files = studies.write_study(args.kind, doc, out)
    if args.kind == "convergence":
        print(studies.markdown_table(doc))
    else:
        print("Averaging's E[H] against FE:\n" + studies.averaging_table(doc))
        print("\nAveraging's mean first-passage time (rest → 3 E[H]) against FE:\n"
              + studies.averaging_table(doc, "rel_tau"))
    print("  wrote " + ", ".join(str(f) for f in files))
    return 0


def cmd_keys(args: argparse.Namespace) -> int:
    """The table of scene keys (generated from the declarations; docs/guide/keys.md's)."""
    from .scenes import schema_table
    print(schema_table())
    return 0


def cmd_methods(args: argparse.Namespace) -> int:
    """The capability table of the registered methods (docs/guide/methods.md's)."""
    from ..registry import capability_table
    print(capability_table(), end="")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from .. import benchmarks
    return int(benchmarks.load(args.name)(args.rest) or 0)


def _line(text: str) -> str:
    """``text`` as one line of the terminal: its whitespace runs made one space, and a
    newline at the end (the next output starts on a line of its own)."""
    return " ".join(str(text).split()) + "\n"


def _say(text: str) -> None:
    """Print ``fpk-vibro: text`` as one line on stderr (an error, an interruption),
    after what stdout holds, so that the two come out in order."""
    sys.stdout.flush()
    sys.stderr.write(_line(f"fpk-vibro: {text}"))
    sys.stderr.flush()


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit status 2), no usage dump."""

    def error(self, message: str):  # noqa: D102
        sys.stdout.flush()
        self.exit(2, _line(f"{self.prog}: error: {message}"))


def _positive_int(flag: str):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < 1 or value > 4096:
            raise argparse.ArgumentTypeError(f"must be an integer in [1, 4096]; got {text!r}")
        return value
    parse.__name__ = flag
    return parse


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="fpk-vibro", description=__doc__.split("\n")[0])
    p.add_argument("--version", action="version", version=f"fpk-vibro {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    pr = sub.add_parser("run", help="run a scene (TOML)")
    pr.add_argument("scene")
    pr.add_argument("--out", default=None, help="output directory (default: the scene's)")
    pr.add_argument("--quiet", action="store_true", help="print nothing but errors")
    pr.add_argument("--reduced", action="store_true",
                    help="a reduced size (few paths, coarse meshes) for a first look and tests")
    pr.add_argument("--workers", type=_positive_int("--workers"), default=None,
                    help="local worker processes for a sweep (>= 1)")
    pr.add_argument("--force", action="store_true",
                    help="run even beyond the estimated memory, time or sweep limits")
    pr.add_argument("--resume", action="store_true",
                    help="keep the points an earlier run of this scene finished in the "
                         "output directory (same scene, parameters and settings, files "
                         "present); compute the missing, interrupted and failed ones")
    pr.add_argument("--scheduler", default=None,
                    help="Dask scheduler ADDRESS for sweeps (extra fpk-vibro[distributed])")
    pr.set_defaults(func=cmd_run)
    pc = sub.add_parser("check", help="validate a scene and estimate its cost, without running it")
    pc.add_argument("scene")
    pc.add_argument("--reduced", action="store_true", help="check the reduced size")
    pc.add_argument("--force", action="store_true",
                    help="accept work beyond the estimated memory, time or sweep limits")
    pc.set_defaults(func=cmd_check)
    ps = sub.add_parser("show", help="summary table of a results directory")
    ps.add_argument("dir")
    ps.set_defaults(func=cmd_show)
    pt = sub.add_parser("study", help="convergence (work-precision) or averaging-validity study")
    pt.add_argument("kind", choices=["convergence", "averaging"])
    pt.add_argument("scene")
    pt.add_argument("--out", default=None, help="output directory")
    pt.add_argument("--quick", action="store_true", help="reduced size (about a minute)")
    pt.set_defaults(func=cmd_study)
    pk = sub.add_parser("keys", help="the table of scene keys (Markdown)")
    pk.set_defaults(func=cmd_keys)
    pm = sub.add_parser("methods", help="what each registered method handles (Markdown)")
    pm.set_defaults(func=cmd_methods)
    pp = sub.add_parser("paper", help="the paper's case end to end (Fig. 3 analogue)")
    pp.add_argument("--out", default="results", help="output directory (default: results)")
    pp.set_defaults(func=cmd_paper)
    from ..benchmarks import BENCHMARKS
    listed = "\n".join(f"  {name:<18s} {b.summary}" for name, b in BENCHMARKS.items())
    pb = sub.add_parser("bench", help="benchmarks", epilog="benchmarks:\n" + listed,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    pb.add_argument("name", choices=list(BENCHMARKS), metavar="NAME",
                    help="the benchmark (listed below)")
    pb.add_argument("rest", nargs=argparse.REMAINDER, metavar="OPTIONS",
                    help="options passed to the benchmark: --quick (a few seconds, a smoke "
                         "test), --help (its own)")
    pb.set_defaults(func=cmd_bench)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if getattr(args, "force", False):
            from ..budget import unlimited
            with unlimited():
                return int(args.func(args) or 0)
        return int(args.func(args) or 0)
    except KeyboardInterrupt as exc:
        _say("interrupted")
        return 128 + int(getattr(exc, "signum", signal.SIGINT))
    except OSError as exc:
        where = f" {exc.filename!r}:" if getattr(exc, "filename", None) else ""
        _say(f"error:{where} {exc.strerror or exc}")
        return 2
    except ValueError as exc:
        _say(f"error: {exc}")
        return 2
