"""The rules and the cost of :func:`fpk_vibro.fem.periodic`'s options.

The options themselves (rtol, nx, ny, degree, harmonics, y_max, wall_grading) are
declared once, in :class:`fpk_vibro.fem.Options` for the mode "periodic"; this
module holds what joins them (:func:`validate_periodic`) and the cost model
(:func:`periodic_cost`), which take the options object (no import of it: the
declaration imports this module).
"""
from __future__ import annotations

import math
from typing import Any

from .._checks import InputError
from ..budget import Cost

__all__ = ["DEFAULT_RTOL", "REDUCED", "MAX_HARMONICS", "START_HARMONICS", "START_NX", "MAX_SECONDS",
           "validate_periodic", "periodic_cost"]

#: The accuracy goal when none of nx, ny, degree, harmonics is given (best effort).
DEFAULT_RTOL = 1e-3
#: The most harmonics K the solve takes (the coefficients decay exponentially in k).
MAX_HARMONICS = 64
#: The first K tried when K is chosen (then raised by 4 until ‖p_K‖ is small).
START_HARMONICS = 4
#: The first mesh of the rtol loop: cells across x (degree 3).
START_NX = 12
#: The caps of a reduced (``--reduced``) periodic scene run: Q2, 8 × 16 cells, K = 4
#: (about a second on the paper system).
REDUCED = {"nx": 8, "ny": 16, "degree": 2, "harmonics": 4}
#: Longest the rtol loop may take before it returns its last level, flagged (s).
MAX_SECONDS = 60.0


def validate_periodic(opts: Any, system: Any, where: str = "fem.periodic") -> None:
    """rtol chooses nx, ny, degree and harmonics (none of them with it); y_max is
    needed without damping."""
    if opts.rtol is not None:
        given = [k for k in ("nx", "ny", "harmonics") if getattr(opts, k) is not None]
        if getattr(opts, "_degree_given", False):
            given.insert(1, "degree")
        if given:
            raise InputError(f"{where}: {given[0]} must not be given with rtol (rtol "
                             f"chooses nx, ny, degree and harmonics)", where=where,
                             name=given[0])
    if system.c == 0 and opts.y_max is None:
        raise InputError(f"{where}: y_max must be given when c = 0 (no damping bound on "
                         "the energy tail)", where=where, name="y_max")


def periodic_cost(opts: Any, system: Any) -> Cost:
    """Memory and seconds of one answer level and its richer level (degree + 1 and
    K + 2), each K + 1 sparse LUs (complex for k ≥ 1) and ~10 GMRES iterations of
    K solves; with rtol (or no mesh option) the first level of the loop, twice for a
    possible refinement.  Constants: the stationary model's LU (docs/costs.md)."""
    adaptive = opts.rtol is not None or not (
        opts.nx or opts.ny or opts.harmonics or getattr(opts, "_degree_given", False))
    deg = opts.degree if getattr(opts, "_degree_given", False) else 3
    nx = opts.nx or START_NX
    ny = opts.ny or 3 * nx            # (measured defaults: 2-3.7 nx)
    K = opts.harmonics or 8
    seconds, memory = 0.5, 130e6
    for d, kk in ((deg, K), (min(deg + 1, 4), K + 2)):
        n = float((d * nx + 1) * (d * ny + 1)) * (4.0 if d == 4 and deg == 4 else 1.0)
        lu = 2.0 * n * 3000.0 * max(1.0, math.log2(max(n, 2.0)) / 17.0)
        factor_s = 2.0 * 6.5e-7 * n ** 1.3
        seconds += (kk + 1) * factor_s + 10.0 * kk * 3e-7 * n * 10.0
        memory += (kk + 1) * lu + 60.0 * (2 * kk + 1) * n * 8.0
    if adaptive:
        seconds *= 3.0
    return Cost(memory, float((2 * K + 1) * (deg * nx + 1) * (deg * ny + 1)), "unknowns",
                min(seconds, MAX_SECONDS if adaptive else math.inf), "nx")
