"""The quantities "spectra" and "crossings" at one point of a run: each method's
records (:mod:`fpk_vibro.app.spectral_records`), then the point's arrays and figures.

Arrays (``points/p{i}.npz``, merged into ``densities.npz``), per method and signal:
``p{i}.{method}.spectrum_{of}.omega`` (rad/s), ``.density`` (two-sided S), ``.se``
(sampled), ``.lags`` and ``.correlation`` (R(τ) of the centred signal).  Figures:
``p{i}_spectra.png``, ``p{i}_crossings.png`` and, with ``crossings.rice_times``,
``p{i}_rice.png`` (:mod:`fpk_vibro.app.spectral_plots`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .spectral_records import crossings_record, spectra_record

__all__ = ["spectral_entry", "spectral_outputs"]


def spectral_entry(scene: Any, method: str, system: Any, sol: Any, keep: dict
                   ) -> dict[str, Any]:
    """``{"spectra": ..., "crossings": ...}`` of one method, as the scene asks (empty
    when it asks neither); what the figures need goes into ``keep``."""
    out: dict[str, Any] = {}
    if scene.spectra is not None:
        out["spectra"] = spectra_record(scene, method, system, keep.setdefault("spectra", {}))
    if scene.crossings is not None:
        out["crossings"] = crossings_record(scene, method, system, sol, keep)
    return out


def spectral_outputs(scene: Any, index: int, system: Any, keep: dict,
                     record: dict[str, Any], out_dir: Path) -> dict[str, np.ndarray]:
    """The arrays of one point (module docstring); its figures are drawn and named in
    ``record["figures"]``."""
    figs = _figures(scene, index, system, keep, record["methods"], out_dir)
    if figs:
        record.setdefault("figures", []).extend(figs)
    arrays: dict[str, np.ndarray] = {}
    for method, by_signal in (keep.get("spectra") or {}).items():
        for of, sp in by_signal.items():
            key = f"p{index}.{method}.spectrum_{of}"
            arrays[f"{key}.omega"], arrays[f"{key}.density"] = sp.omega, sp.density
            arrays[f"{key}.lags"], arrays[f"{key}.correlation"] = sp.lags, sp.correlation(
                sp.lags)
            if sp.se is not None:
                arrays[f"{key}.se"] = sp.se
    return arrays


def _figures(scene: Any, index: int, system: Any, keep: dict,
             entries: dict[str, dict[str, Any]], out_dir: Path) -> list[str]:
    from . import spectral_plots
    figs: list[str] = []
    if "png" not in scene.formats:
        return figs
    if keep.get("spectra"):
        figs.append(spectral_plots.spectra(entries, scene.spectra,
                                           out_dir / f"p{index}_spectra.png",
                                           title=scene.name).name)
    if scene.crossings is not None and any(
            "levels" in (e.get("crossings") or {}) for e in entries.values()):
        figs.append(spectral_plots.crossings(entries, system,
                                             out_dir / f"p{index}_crossings.png",
                                             title=scene.name).name)
        if any("estimate" in ((e.get("crossings") or {}).get("rice") or {})
               for e in entries.values()):
            figs.append(spectral_plots.rice(entries, keep.get("passages") or {},
                                            out_dir / f"p{index}_rice.png",
                                            title=scene.name).name)
    return figs
