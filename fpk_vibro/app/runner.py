"""Run a scene: only the requested methods, quantities and times; results written atomically.

Layout of an output directory::

    results.json            the scene echoed, per point and method: moments (with
                            standard errors where they exist), wall time, effects;
                            with [external] also "coloured": E[ζ²], E[ζ y] (+ "_se")
    densities.npz           grids and densities, keys "p{i}.{method}.{quantity}.{grid|pdf|se}"
    p{i}_{quantity}.png     figures: p(H), p(x), p(y) with every method overlaid
    p{i}_joint.png          joint densities side by side
    p{i}_fem.vtu            the FE field (format "vtu")
    points/p{i}.json        each sweep point as soon as it finishes

A forced scene's periodic response adds its records and figures per phase
(:mod:`fpk_vibro.app.periodic_records`, :mod:`fpk_vibro.app.periodic_point`), "spectra"
and "crossings" theirs (:mod:`fpk_vibro.app.spectral_point`).
"""
from __future__ import annotations

import contextlib
import os
import signal
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .._checks import InputError
from ..io import atomic_json, atomic_savez
from ..model import VibroImpactSystem
from ..progress import Progress, as_lines, interactive
from ..registry import methods
from ..scales import density_grids
from .estimates import add_estimates
from .execution import SchedulerLost, dask_client, execute
from .interrupt import Interrupted, received, signals_handled
from .outdir import OutputDir, holds, point_records
from .plan import first_passage_kwargs, resolved_options, solver_kwargs
from .results import storage_failed, write_results
from .resume import (clear_outputs, clear_temporaries, fingerprint, seal, select,
                     storage_fault)
from .impact_records import impact_arrays, impact_energy_record, inter_impact_record
from .periodic_records import periodic_record
from .scene_impacts import safe_set_keyword
from .scenes import Scene, check_scene
from .spectral_point import spectral_entry, spectral_outputs

__all__ = ["run_scene", "run_point", "grids_for"]

grids_for = density_grids


def _solve(method: str, system: VibroImpactSystem, scene: Scene,
           progress: bool | None = False) -> Any:
    """One method on one system with the scene's keywords; a Solution or a list."""
    kw = solver_kwargs(scene, method, progress=progress)
    solve = methods()[method].solver(scene.mode)
    # each point's warnings are its own: Python shows a warning once per text and
    # line, and two points can word theirs alike (the same level and estimate)
    globals().get("__warningregistry__", {}).clear()
    if scene.transient:
        return solve(system, initial=scene.initial, times=scene.times, **kw)
    if scene.periodic:
        return solve(system, scene.phases, **kw)
    return solve(system, **kw)


def _partial(sol: Any) -> bool:
    """True for a solution (or a transient's list of them) that a signal cut short:
    ``partial`` on either (fpk_vibro.solution.Solution.partial, TransientResult)."""
    if isinstance(sol, list):
        return bool(getattr(sol, "partial", False)) or any(_partial(s) for s in sol)
    return bool(sol.partial)


def _moments_record(sol: Any) -> dict[str, Any]:
    rec: dict[str, Any] = {"moments": sol.moments()}
    if hasattr(sol, "moments_se"):
        rec["moments_se"] = sol.moments_se()
    if sol.system.external is not None:     # E[ζ²], E[ζ y] (+ "_se" where sampled)
        rec["coloured"] = {k: float(v) for k, v in sol.coloured_moments().items()}
    for attr in ("mass", "min_density", "residual", "impact_rate", "n_paths", "dt", "partial",
                 "seed_entropy"):
        val = getattr(sol, attr, None)
        if isinstance(val, (int, float, bool, np.floating, np.integer)):
            rec[attr] = val.item() if hasattr(val, "item") else val
    return rec


def _density_arrays(snapshots: dict, grids: dict, quantities: list, index: int,
                    tag: str = "") -> dict[str, np.ndarray]:
    """The densities of one point (and time ``tag``) on their grids, npz-keyed."""
    arrays: dict[str, np.ndarray] = {}
    for m, sol in snapshots.items():
        for q in quantities:
            key = f"p{index}.{m}.{q}{tag}"
            if q == "joint":
                gx, gy = grids["joint"]
                arrays[f"{key}.x"], arrays[f"{key}.y"] = gx, gy
                arrays[f"{key}.pdf"] = sol.pdf_joint(gx[None, :], gy[:, None])
                continue
            g = grids[q]
            arrays[f"{key}.grid"] = g
            arrays[f"{key}.pdf"] = getattr(sol, "pdf_" + q)(g)
            if methods()[m].sampled:
                edges, dens, se = sol.histogram(q)
                arrays[f"{key}.edges"], arrays[f"{key}.hist"], arrays[f"{key}.se"] = edges, dens, se
    return arrays


def _engineering(scene: Scene, method: str, system: VibroImpactSystem, sol: Any,
                 passages: dict[str, Any]) -> dict[str, Any]:
    """Impact statistics and first passage of one method, if the scene asks for them."""
    out: dict[str, Any] = {}
    if "impacts" in scene.quantities and system.has_barrier:
        try:
            out["impacts"] = sol.impacts()
        except NotImplementedError:
            pass
    try:                       # a check on every stationary solution (docs/impacts.md)
        out["power_balance"] = sol.power_balance()
    except NotImplementedError:
        pass
    if "inter_impact" in scene.quantities:
        out["inter_impact"] = inter_impact_record(sol)
    if "impact_energy" in scene.quantities:
        out["impact_energy"] = impact_energy_record(sol)
    m = methods()[method]
    if scene.first_passage is not None and "first_passage" in m.modes:
        fp = scene.first_passage
        kw = first_passage_kwargs(scene, method)   # the table's first-passage keys
        start = fp["start"] if fp["start"] == "stationary" else tuple(fp["start"])
        kind, value = safe_set_keyword(fp)
        passages[method] = m.solver("first_passage")(system, **{kind: value}, start=start,
                                                     times=fp["times"], **kw)
        out["first_passage"] = passages[method].to_dict()
    return out


def run_point(scene: Scene, index: int, params: dict[str, float], system: VibroImpactSystem,
              out_dir: Path, progress: bool | None = False, token: str | None = None
              ) -> dict[str, Any]:
    """All requested methods at one sweep point; writes ``points/p{index}.json`` and the data."""
    from . import impact_plots, plotting, run_plots

    record: dict[str, Any] = {"index": index, "parameters": params, "status": "done",
                              "fingerprint": fingerprint(scene, index, params, system),
                              "system": system.to_dict(), "effects": system.effects,
                              "methods": {}}
    solutions: dict[str, Any] = {}
    passages: dict[str, Any] = {}
    spectral: dict[str, Any] = {}      # "spectra", "crossings": for the arrays and figures
    for method in scene.methods:
        methods()[method].solver(scene.mode)      # imports are not the method's time
        t0 = time.perf_counter()
        sol = _solve(method, system, scene, progress)
        wall = time.perf_counter() - t0
        solutions[method] = sol
        entry: dict[str, Any] = {"wall_time_s": wall, "options": resolved_options(scene, method)}
        if _partial(sol):
            entry["partial"] = True
            record["status"] = "interrupted"
        if scene.transient:
            entry["times"] = list(scene.times)
            entry["at"] = [_moments_record(s) for s in sol]
        elif scene.periodic:       # the period average as the moments, the phases beside
            entry.update(_moments_record(sol.average()))
            entry["periodic"] = periodic_record(sol, methods()[method].sampled)
        else:
            entry.update(_moments_record(sol))
            entry.update(_engineering(scene, method, system, sol, passages))
            if not entry.get("partial"):
                entry.update(spectral_entry(scene, method, system, sol, spectral))
        record["methods"][method] = entry
        if record["status"] == "interrupted":
            break
    if record["status"] == "done":
        try:
            add_estimates(scene, record, solutions, passages)
        except KeyboardInterrupt:     # (Interrupted too) the answers are kept: the point
            record["status"] = "interrupted"    # is written as interrupted, then stops
            for entry in record["methods"].values():
                for rec in (entry.get("at") or [entry]) + [entry.get("first_passage", {})]:
                    rec.setdefault("error_estimate", {"not_computed": "interrupted"})
    if token is not None and not holds(out_dir, token):
        raise RuntimeError("the run was stopped; this point's result is discarded")
    arrays: dict[str, np.ndarray] = {}
    want_density = [q for q in scene.quantities if q in ("energy", "x", "y", "joint")]
    if scene.periodic:
        from .periodic_point import point_outputs
        arrays, figs = point_outputs(scene, index, params, system, solutions,
                                     record["methods"], out_dir, _density_arrays)
        if figs:
            record["figures"] = figs
    elif want_density:
        title = f"{scene.name}" + ("" if not params else " — " + ", ".join(
            f"{k} = {v:g}" for k, v in params.items()))
        # a transient: every requested time (arrays "….t{k}", figures "p{i}_t{k}_…"),
        # and the last time also under the stationary keys
        steps = list(enumerate(scene.times)) if scene.transient else [(None, None)]
        record["figures"] = []
        for k, t in steps:
            snapshots = {m: (s[k] if k is not None else s) for m, s in solutions.items()}
            grids = grids_for(system, next(iter(snapshots.values())))
            tags = [f".t{k}"] + ([""] if k == len(steps) - 1 else []) if k is not None else [""]
            for tag in tags:
                arrays.update(_density_arrays(snapshots, grids, want_density, index, tag))
            if "png" in scene.formats:
                record["figures"] += [str(p.name) for p in plotting.scene_figures(
                    snapshots, grids, want_density, out_dir,
                    f"p{index}" if k is None else f"p{index}_t{k}",
                    title if t is None else f"{title}, t = {t:g}")]
    if not scene.transient and not scene.periodic:
        impacts = impact_arrays(scene.quantities, solutions, record["methods"], index,
                                lambda m: methods()[m].sampled)
        arrays.update(impacts)
    if "png" in scene.formats and not scene.periodic and (
            "impacts" in scene.quantities and system.has_barrier
            or passages or not scene.transient and impacts):
        figs = record.setdefault("figures", [])
        if "impacts" in scene.quantities and system.has_barrier:
            figs.append(run_plots.impact_speeds(solutions, out_dir / f"p{index}_impact_speed.png",
                                               title=scene.name).name)
        if passages:
            figs.append(run_plots.reliability(passages, out_dir / f"p{index}_reliability.png",
                                             title=scene.name).name)
        if not scene.transient:
            figs += [p.name for p in impact_plots.point_figures(
                impacts, record["methods"], system, out_dir, index, scene.name)]
    if scene.transient and "png" in scene.formats and "moments" in scene.quantities:
        figs = record.setdefault("figures", [])
        for key in ("E_H", "E_x2", "E_y2"):
            figs.append(run_plots.moment_history(record["methods"], out_dir / f"p{index}_{key}_t.png",
                                                key=key, title=scene.name).name)
    if spectral:
        arrays.update(spectral_outputs(scene, index, system, spectral, record, out_dir))
    if "vtu" in scene.formats and "fem" in solutions:
        fem_sol = solutions["fem"][-1] if scene.transient else \
            solutions["fem"].average() if scene.periodic else solutions["fem"]
        path = out_dir / f"p{index}_fem.vtu"
        fem_sol.save_vtu(path)
        record["vtu"] = path.name
    if "npz" in scene.formats and arrays:
        atomic_savez(out_dir / "points" / f"p{index}.npz", arrays)
        record["densities"] = f"points/p{index}.npz"     # resume checks it is there
    atomic_json(out_dir / "points" / f"p{index}.json", seal(record))   # resume checks it
    if record["status"] == "interrupted":
        raise Interrupted(received() or signal.SIGINT)
    return record


def _label(params: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in params.items()) or "single point"


def _point_job(args: tuple) -> dict[str, Any]:
    """One point in a worker (or in this process): its record, or a failed one.

    ``progress`` "lines" (a worker of a run that shows progress): each long stage is
    one line naming the point (:func:`fpk_vibro.progress.as_lines`), not a bar."""
    scene, index, params, system, out_dir, progress, token = args
    lines: Any = contextlib.nullcontext()
    if progress == "lines":
        lines = as_lines(f"  point {index + 1}/{scene.n_points} ({_label(params)}): ")
        progress = True
    try:
        with lines:
            return run_point(scene, index, params, system, out_dir, progress, token)
    except Interrupted:
        raise
    except OSError as exc:    # a full disk is the run's fault, not the point's: it stops
        if storage_fault(exc):
            raise
        rec = _failed(scene, index, params, system, exc)
    except Exception as exc:  # a failed point is reported, the others go on
        rec = _failed(scene, index, params, system, exc)
    if token is None or holds(out_dir, token):
        atomic_json(out_dir / "points" / f"p{index}.json", rec)
    return rec


def _failed(scene: Scene, index: int, params: dict[str, float], system: VibroImpactSystem,
            exc: BaseException) -> dict[str, Any]:
    """The record of a point that raised ``exc`` (computed again by ``--resume``)."""
    return {"index": index, "parameters": params, "status": "failed",
            "fingerprint": fingerprint(scene, index, params, system),
            "error": " ".join(f"{type(exc).__name__}: {exc}".split())}


def run_scene(scene: Scene, *, out: str | Path | None = None, workers: int | None = None,
              scheduler: str | None = None, log: Callable[[str], None] = print,
              progress: bool | None = False, resume: bool = False,
              warn: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run every point of ``scene``; returns (and writes) the results document.

    Everything is checked before any work (:func:`fpk_vibro.app.scenes.check_scene`,
    the output directory, its lock).  ``progress`` (None: on a terminal) is passed
    to the solvers of a run in this process (one point, or ``workers=1``); workers
    print one line per stage that lasts (:func:`fpk_vibro.progress.as_lines`).
    ``resume``: keep the points an earlier run of the same scene finished in the
    output directory and compute only the others (:func:`fpk_vibro.app.resume.select`:
    a record is kept when its fingerprints match and its files are there; failed
    points are computed again); ``log`` gets one line saying how many and why.
    Without it the run clears the earlier run's outputs first (a run owns its
    directory: :func:`fpk_vibro.app.resume.clear_outputs`).  A full disk stops the run:
    ``results.json`` lists what finished (``"status": "failed"``, ``"error"`` names
    the file) and the :class:`OSError` raised names the file and says what was kept.
    SIGINT or SIGTERM stops the
    run within about a second: workers are terminated, ``results.json`` lists every
    finished point and marks the others ``"status": "interrupted"``, and the
    document's ``"status"`` is ``"interrupted"`` (``"signal"`` names it).
    ``warn`` receives failed points (default: ``log``).
    """
    check_scene(scene)                  # every check of every point, before any work
    if scheduler is not None:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise InputError("--scheduler: needs dask.distributed (pip install "
                             "'fpk-vibro[distributed]')", name="--scheduler") from None
    out_dir = Path(out) if out is not None else scene.output_dir
    points = scene.points()
    warn = warn or log
    with OutputDir(out_dir, "--out" if out is not None else "output.directory") as lock, \
            signals_handled(), dask_client(scheduler) as client:
        if resume:                     # only records of this scene, point and settings
            records, line = select(out_dir, scene, points)
            log(line)
        else:
            records = {}
        clear_outputs(out_dir, records)   # the run owns the outputs: no earlier run's mix in
        serial = scheduler is None and (len(points) - len(records) <= 1 or workers == 1)
        # the output directory as an absolute path: a worker (a Dask one in particular)
        # has its own working directory
        job_dir = Path(os.path.abspath(out_dir))
        shown = interactive() if progress is None else bool(progress)
        jobs = [(scene, i, params, system, job_dir,
                 progress if serial else ("lines" if shown else False), lock.token)
                for i, (params, system) in enumerate(points) if i not in records]
        t0 = time.perf_counter()
        signum = None
        fault: OSError | None = None
        sweep_bar = Progress(progress if len(jobs) > 1 else False, f"{scene.name} points",
                             total=len(points), unit="point")
        sweep_bar.update(len(records))
        try:
            for rec in execute(_point_job, jobs, serial, workers, client):
                records[rec["index"]] = _report(rec, len(points), log, warn)
                sweep_bar.update(len(records))
        except Interrupted as exc:
            signum = exc.signum
        except OSError as exc:        # a full disk: stop, keep what finished
            if not storage_fault(exc):
                raise
            fault = exc
        except SchedulerLost as exc:  # keep what finished; the rest fails (--resume redoes it)
            on_disk = point_records(out_dir)
            lost = [j for j in jobs if j[1] not in records]
            for j in lost:
                r = on_disk.get(j[1])
                records[j[1]] = r if r and r.get("status") in ("done", "failed") else {
                    "index": j[1], "parameters": j[2], "status": "failed",
                    "error": f"not computed: {exc}"}
            n_lost = sum(records[j[1]].get("status") == "failed" for j in lost)
            warn(f"fpk-vibro: {exc}: {n_lost} point(s) not computed, marked failed in "
                 "results.json; run again with --resume to compute them")
        finally:
            sweep_bar.close()
        signum = signum or received()
        if signum is not None or fault is not None:   # what workers wrote, not yet reported
            todo = {j[1] for j in jobs}
            records.update({i: r for i, r in point_records(out_dir).items()
                            if i not in records and i in todo})
        clear_temporaries(out_dir)    # of a worker stopped in the middle of a write
        wall = time.perf_counter() - t0
        if fault is None:
            try:
                return write_results(scene, points, records, out_dir, wall, signum)
            except OSError as exc:
                if not storage_fault(exc):
                    raise
                fault = exc
        raise storage_failed(fault, scene, points, records, out_dir, wall, signum)


def _report(record: dict[str, Any], total: int, log: Callable[[str], None],
            warn: Callable[[str], None]) -> dict[str, Any]:
    i = record["index"]
    params = _label(record["parameters"])
    if record.get("status") == "failed":
        warn(f"  point {i + 1}/{total} ({params}) FAILED: {record['error']}")
    else:
        times = ", ".join(f"{m} {e['wall_time_s']:.2f} s" for m, e in record["methods"].items())
        log(f"  point {i + 1}/{total} ({params}) {record.get('status', 'done')}: {times}")
        for e in record["methods"].values():
            if e.get("warning"):
                log(f"  point {i + 1}/{total} ({params}) warning: {e['warning']}")
    return record
