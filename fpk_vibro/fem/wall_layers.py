"""Walls the force presses the density against: the layers there, and the FE
solve's refusal of a density it cannot represent."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..model import VibroImpactSystem
from .integrals import potential_range

__all__ = ["MAX_CONTRAST", "wall_layers", "check_wall_layers"]

#: Largest c (max G − min G)/D on the strip (the density spans e^this) that the FE
#: solve is accepted for (measurements: check_wall_layers).
MAX_CONTRAST = 60.0


def wall_layers(system: VibroImpactSystem) -> list[tuple[str, float, float, float]]:
    """(side, x_w, push, ℓ) for each wall the force −G'(x_w) presses the density
    against (push > 0 towards it), ℓ = D(x_w)/(c·push) the width of the layer there
    (c > 0; none with c = 0)."""
    out = []
    if system.c <= 0:
        return out
    for side, sign in (("left", -1), ("right", 1)):
        w = getattr(system, side)
        if w is None:
            continue
        xw = w.position
        push = -sign * float(system.restoring_force(xw))
        if push > 0:
            out.append((side, xw, push,
                        float(system.noise_intensity(xw)) / (system.c * push)))
    return out


def check_wall_layers(opts: Any, system: VibroImpactSystem, dom: Any, nx: int, bad: Any,
                      layers: bool = True) -> None:
    """Refuse a density pressed against a wall that the FE solve cannot
    represent: spanning more than e^MAX_CONTRAST over the strip, or in a layer
    thinner than a node spacing.

    Where the force −G'(x_w) presses into a wall (softening b < 0 beyond the
    hump, a preloaded wall) the density sits in a layer of width ℓ = D/(c |G'|)
    against it.  Measured on the exact (r = 1) density, a = 1, c = 0.025,
    D1 = 0.01, walls ±0.6: E[H] within 0.2 % for h/(degree·ℓ) ≤ 1 (Q2, b = −300),
    15 % off at 1.7 (b = −500), 99 % at 2.4 (b = −700); with the contrast
    c (max G − min G)/D = 56 (b = −700) Q1 at h = 0.9 ℓ was within 0.01 %, at
    80 (b = −1000) every mesh up to nx = 3000 was off by 10–100 % (or singular).
    """
    found = wall_layers(system)
    if not found:      # (a low-noise peak inside the strip is a question of nx, ny)
        return
    x = np.linspace(dom.x0, dom.x1, 4001)
    g_lo, g_hi = potential_range(system, np.array([dom.x0]), np.array([dom.x1]))
    D = float(system.noise_intensity(max(abs(dom.x0), abs(dom.x1))))
    contrast = system.c * float(g_hi[0] - g_lo[0]) / D
    if contrast > MAX_CONTRAST:
        G = system.potential(x)
        raise bad("system", f"must give a density spanning at most e^{MAX_CONTRAST:g} "
                  f"on the strip for fem, c (max G - min G)/D <= {MAX_CONTRAST:g}; got "
                  f"{contrast:.3g} (a={system.a}, b={system.b}, c={system.c}: G falls "
                  f"from {G.max():.3g} to {G.min():.3g} at x = {x[np.argmin(G)]:.3g}; "
                  "at 80 no mesh up to nx = 3000 came within 10 %)")
    if not layers:
        return
    h = (dom.x1 - dom.x0) / (nx * opts.degree)
    for side, xw, push, ell in found:
        if h > ell:
            need = math.ceil((dom.x1 - dom.x0) / (opts.degree * ell))
            raise bad("nx", f"must be at least {need} here (a node spacing below the "
                      f"width {ell:.3g} = D/(c |G'|) of the layer the force {push:.3g} "
                      f"presses against the {side} wall x = {xw:g}; ny need not grow); "
                      f"got {nx}{'' if opts.nx is not None else ' (the default)'}")
