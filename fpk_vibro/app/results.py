"""The results document of a run: ``results.json`` (every point, finished, failed or
interrupted), the merged ``densities.npz``, the sweep figures and ``results.nc``; and
what is kept when the disk fills up.
"""
from __future__ import annotations

import signal
from pathlib import Path
from typing import Any

import numpy as np

from ..io import atomic_json, atomic_savez
from .resume import clear_temporaries, storage_fault
from .scenes import Scene

__all__ = ["write_results", "storage_failed"]


def write_results(scene: Scene, points: list, records: dict[int, dict[str, Any]],
                   out_dir: Path, wall: float, signum: int | None,
                   fault: OSError | None = None) -> dict[str, Any]:
    """results.json (every point: finished, failed or interrupted) and densities.npz;
    after a storage ``fault``, results.json alone (``"status": "failed"``)."""
    from .._version import __version__
    listed = []
    for i, (params, _) in enumerate(points):
        listed.append(records.get(i) or {"index": i, "parameters": params,
                                         "status": "interrupted"})
    doc = {"scene": scene.source, "name": scene.name, "stationary": not scene.transient,
           "fpk_vibro_version": __version__, "wall_time_s": wall,
           "status": "complete" if signum is None else "interrupted", "points": listed}
    if scene.spectra is not None:  # the resolved settings (the points share them)
        doc["spectra"] = dict(scene.spectra)
    if scene.crossings is not None:
        doc["crossings"] = dict(scene.crossings)
    if scene.periodic:            # the periodic response of a forced scene
        doc["periodic"], doc["phases"] = True, list(scene.phases)
    if signum is not None:
        doc["signal"] = signal.Signals(signum).name
    if fault is not None:        # the rest is made again by --resume
        doc["status"], doc["error"] = "failed", f"{fault.filename}: {fault.strerror or fault}"
        atomic_json(out_dir / "results.json", doc)
        return doc
    atomic_json(out_dir / "results.json", doc)
    if "npz" in scene.formats:
        merged: dict[str, np.ndarray] = {}
        for r in listed:
            f = out_dir / "points" / f"p{r['index']}.npz"
            if r.get("status") == "done" and f.exists():
                with np.load(f) as data:
                    merged.update({k: data[k] for k in data.files})
        if merged:
            atomic_savez(out_dir / "densities.npz", merged)
            if scene.sweep and "png" in scene.formats and signum is None:
                from . import run_plots
                doc["figures"] = [run_plots.sweep_overlay(
                    merged, listed, q, out_dir / f"sweep_{q}.png", title=scene.name).name
                    for q in ("energy", "x", "y") if q in scene.quantities]
                atomic_json(out_dir / "results.json", doc)
    # the moments against the swept parameter (forcing.frequency, external.tau, ...)
    # need no densities: drawn with or without "npz"
    if scene.sweep and "png" in scene.formats and signum is None and \
            "moments" in scene.quantities and not scene.transient and any(
                r.get("status") == "done" for r in listed):
        from . import run_plots
        doc.setdefault("figures", []).append(run_plots.sweep_moments(
            listed, out_dir / "sweep_moments.png", title=scene.name).name)
        atomic_json(out_dir / "results.json", doc)
    if scene.periodic and scene.sweep and "png" in scene.formats and signum is None and any(
            r.get("status") == "done" for r in listed):
        from .periodic_plots import response_curve
        doc.setdefault("figures", []).append(response_curve(
            listed, out_dir / "sweep_response.png", title=scene.name).name)
        atomic_json(out_dir / "results.json", doc)
    if scene.sweep and "spectra" in scene.quantities and "png" in scene.formats and \
            signum is None and any(r.get("status") == "done" for r in listed):
        from .spectral_plots import sweep_peak_frequency
        doc.setdefault("figures", []).append(sweep_peak_frequency(
            listed, out_dir / "sweep_peak_frequency.png", title=scene.name,
            units=scene.spectra["units"]).name)
        atomic_json(out_dir / "results.json", doc)
    if "nc" in scene.formats and any(r.get("status") == "done" for r in listed):
        from ..io import atomic_files
        from ..labelled import NETCDF_ENGINE, run_dataset
        atomic_files(out_dir / "results.nc", lambda p: run_dataset(out_dir).to_netcdf(
            p, engine=NETCDF_ENGINE))
    return doc


def storage_failed(fault: OSError, scene: Scene, points: list, records: dict[int, dict],
                    out_dir: Path, wall: float, signum: int | None) -> OSError:
    """After a write failed for lack of space: ``results.json`` with every finished point
    (``"status": "failed"``, ``"error"`` names the file) if it can still be written; the
    one-line error that names the file and says what was kept."""
    clear_temporaries(out_dir)
    n = sum(r.get("status") == "done" for r in records.values())
    try:
        write_results(scene, points, records, out_dir, wall, signum, fault)
        kept = f"results.json lists the {n} finished point(s)"
    except OSError as exc:
        if not storage_fault(exc):
            raise
        clear_temporaries(out_dir)
        kept = (f"the {n} finished point(s) are kept in {str(out_dir / 'points')!r} "
                "(results.json could not be written)")
    return OSError(fault.errno, f"{fault.strerror or fault}; {kept}; free space and continue "
                   "with --resume", fault.filename)
