"""The histograms of a Monte Carlo run: their edges, per-block counts and bins in
the kernel's records."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..model import VibroImpactSystem
from ..scales import potential_min, reach
from ._params import StepParams

__all__ = ["Histograms", "x_range", "bin_count"]


def bin_count(spec: Any) -> int:
    return spec if isinstance(spec, int) else int(np.asarray(spec).size - 1)



def x_range(system: VibroImpactSystem, H_max: float) -> tuple[float, float]:
    """The default x range of the histograms: the strip (x_L, x_R) with two walls;
    with a side open, the strip cut at ∓X, X = :func:`fpk_vibro.scales.reach` at
    ``H_max`` (the largest |x| a state of energy ≤ H_max reaches)."""
    lo, hi = system.x_bounds
    if system.left is not None and system.right is not None:
        return lo, hi
    X = max(float(reach(system, H_max)), 1e-12)
    xlo, xhi = max(lo, -X), min(hi, X)
    if xhi <= xlo:
        xhi = xlo + 1e-12
    return xlo, xhi


class Histograms:
    """Edges of the requested histograms and the per-block count arrays.

    Impact speeds ("impacts"): per wall w, bins from 0 to sqrt(2 (H_max − G(x_w))),
    the speed at the wall of a path of energy H_max (or the given edges); ``hu`` is
    ``[n_blocks, 2, bins + 1]`` (side 0 left, 1 right; last column: beyond the last
    bin), or ``[n_blocks, 2, 0]`` when not requested.  Impact energies
    ("impact_energy"): per wall from 0 to the largest loss ½ (1 − r(u)²) u² over those
    speeds (``he``, the same layout).  Inter-impact times ("inter_impact"): from 0 to
    ``g_max`` (``hg``, ``[n_blocks, 1, bins + 1]``).
    """

    def __init__(self, system: VibroImpactSystem, quantities: tuple[str, ...],
                 bins: dict[str, Any], n_blocks: int, H_max: float,
                 g_max: float = 1.0) -> None:
        gmin = potential_min(system)
        H_max = max(H_max, gmin + 1e-12)
        xlo, xhi = x_range(system, H_max)
        Y = math.sqrt(2.0 * (H_max - gmin))

        def make(spec, v0, v1):
            return spec if isinstance(spec, np.ndarray) else np.linspace(v0, v1, spec + 1)

        self.edges = {}
        if "energy" in quantities:
            self.edges["edges_H"] = make(bins["energy"], gmin, H_max)
        if "x" in quantities:
            self.edges["edges_x"] = make(bins["x"], xlo, xhi)
        if "y" in quantities:
            self.edges["edges_y"] = make(bins["y"], -Y, Y)
        if "joint" in quantities:
            self.edges["edges_jx"] = make(bins["joint"][0], xlo, xhi)
            self.edges["edges_jy"] = make(bins["joint"][1], -Y, Y)

        def arr(key, *tail):
            return np.zeros((n_blocks, self.edges[key].size - 1) + tail) \
                if key in self.edges else np.zeros((n_blocks, 0) + tail)

        self.hH = arr("edges_H")
        self.hx = arr("edges_x")
        self.hy = arr("edges_y")
        nj = (self.edges["edges_jx"].size - 1, self.edges["edges_jy"].size - 1) \
            if "edges_jx" in self.edges else (0, 1)
        self.hj = np.zeros((n_blocks,) + nj)
        def speed_max(wall):
            du = H_max - float(system.potential(wall.position))
            return math.sqrt(2.0 * du) if du > 1e-12 else math.sqrt(2.0 * (H_max - gmin))

        def per_wall(q, key, top):
            if q not in quantities:
                return 0
            for side, wall in system.walls:
                spec = bins[q]
                self.edges[f"{key}_{side}"] = spec if isinstance(spec, np.ndarray) else \
                    np.linspace(0.0, top(wall), spec + 1)
            return bin_count(bins[q]) + 1 if system.walls else 0

        def loss_max(wall):
            if wall.elastic:            # every loss is 0: one bin holds them
                return 1.0
            u = np.linspace(0.0, speed_max(wall), 4097)
            return max(float(np.max(wall.loss(u))), 1e-300)

        self.hu = np.zeros((n_blocks, 2, per_wall("impacts", "edges_u", speed_max)))
        self.he = np.zeros((n_blocks, 2, per_wall("impact_energy", "edges_e", loss_max)))
        ng = 0
        if "inter_impact" in quantities and system.walls:
            spec = bins["inter_impact"]
            self.edges["edges_g"] = spec if isinstance(spec, np.ndarray) else \
                np.linspace(0.0, g_max, spec + 1)
            ng = bin_count(spec) + 1
        self.hg = np.zeros((n_blocks, 1, ng))

    def with_bins(self, p: StepParams) -> StepParams:
        """``p`` with the (uniform) bin origins and inverse widths of these histograms."""
        bins = {}
        for key, v0, iw in (("edges_H", "h0", "h_iw"), ("edges_x", "x0", "x_iw"),
                            ("edges_y", "y0", "y_iw"), ("edges_jx", "jx0", "jx_iw"),
                            ("edges_jy", "jy0", "jy_iw")):
            if key in self.edges:
                e = self.edges[key]
                bins[v0] = float(e[0])
                bins[iw] = float((e.size - 1) / (e[-1] - e[0]))
        for key, iw in (("edges_u_left", "u_iw_left"), ("edges_u_right", "u_iw_right"),
                        ("edges_e_left", "e_iw_left"), ("edges_e_right", "e_iw_right"),
                        ("edges_g", "g_iw")):
            if key in self.edges:
                e = self.edges[key]
                bins[iw] = float((e.size - 1) / (e[-1] - e[0]))
        return p._replace(**bins)
