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
    bin), or ``[n_blocks, 2, 0]`` when not requested.
    """

    def __init__(self, system: VibroImpactSystem, quantities: tuple[str, ...],
                 bins: dict[str, Any], n_blocks: int, H_max: float) -> None:
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
        nu = 0
        if "impacts" in quantities:
            for side, wall in system.walls:
                spec = bins["impacts"]
                if isinstance(spec, np.ndarray):
                    self.edges[f"edges_u_{side}"] = spec
                    continue
                du = H_max - float(system.potential(wall.position))
                u_max = math.sqrt(2.0 * du) if du > 1e-12 else math.sqrt(2.0 * (H_max - gmin))
                self.edges[f"edges_u_{side}"] = np.linspace(0.0, u_max, spec + 1)
            nu = bin_count(bins["impacts"]) + 1 if system.walls else 0
        self.hu = np.zeros((n_blocks, 2, nu))

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
        for key, iw in (("edges_u_left", "u_iw_left"), ("edges_u_right", "u_iw_right")):
            if key in self.edges:
                e = self.edges[key]
                bins[iw] = float((e.size - 1) / (e[-1] - e[0]))
        return p._replace(**bins)
