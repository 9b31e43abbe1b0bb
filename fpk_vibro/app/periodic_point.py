"""One point of a forced scene's run beyond its records: the densities at each phase
and their average into densities.npz, and the figures the scene asks for.

- densities (``study.quantities`` energy, x, y, joint): the period average under the
  plain keys and phase ``k`` under the tag ``.ph{k}``, on one set of grids (the
  average's); figures ``p{i}_{q}.png`` of the period-averaged densities, and with
  "joint" the joint density at four phases per method (``p{i}_{method}_joint_phases.png``);
- "moments": the moments against phase, every method (``p{i}_phase_moments.png``);
- "impacts" (with a wall): the impact rate of each wall against phase
  (``p{i}_impact_rates.png``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..scales import density_grids
from .periodic_records import snapshots_at

__all__ = ["point_outputs", "DENSITIES"]

#: The quantities that are densities.
DENSITIES = ("energy", "x", "y", "joint")


def point_outputs(scene: Any, index: int, params: dict[str, float], system: Any,
                  solutions: dict[str, Any], entries: dict[str, Any], out_dir: Path,
                  density_arrays: Callable[..., dict[str, np.ndarray]]
                  ) -> tuple[dict[str, np.ndarray], list[str]]:
    """(arrays for densities.npz, names of the figures written) of one point;
    ``density_arrays(snapshots, grids, quantities, index, tag)`` is the runner's."""
    from . import periodic_plots, plotting
    arrays: dict[str, np.ndarray] = {}
    figures: list[str] = []
    want = [q for q in scene.quantities if q in DENSITIES]
    png = "png" in scene.formats
    title = scene.name + ("" if not params else " — " + ", ".join(
        f"{k} = {v:g}" for k, v in params.items()))
    if want:
        averages = snapshots_at(solutions, None)
        grids = density_grids(system, next(iter(averages.values())))
        arrays.update(density_arrays(averages, grids, want, index, ""))
        for k in range(len(scene.phases)):
            arrays.update(density_arrays(snapshots_at(solutions, k), grids, want, index,
                                         f".ph{k}"))
        if png:
            figures += [p.name for p in plotting.scene_figures(
                averages, grids, want, out_dir, f"p{index}", f"{title}, period average")]
            if "joint" in want:
                figures += [periodic_plots.joint_phases(
                    response, *grids["joint"], out_dir / f"p{index}_{m}_joint_phases.png",
                    method=m, title=title).name for m, response in solutions.items()]
    if png and "moments" in scene.quantities:
        figures.append(periodic_plots.phase_moments(
            entries, system, out_dir / f"p{index}_phase_moments.png", title=title).name)
    if png and "impacts" in scene.quantities and system.has_barrier:
        figures.append(periodic_plots.impact_rates(
            entries, system, out_dir / f"p{index}_impact_rates.png", title=title).name)
    return arrays, figures
