"""Validation of the Monte Carlo keywords, seeds, blocks of paths and the set-up the
engine shares.

The step sizes (:mod:`._step_size`), the kernels' records (:mod:`._params`) and the
histograms (:mod:`._histograms`) have modules of their own; their names stay
importable from here.
"""
from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from .. import _checks
from ..model import VibroImpactSystem
from ..progress import Progress as _Progress
from ..scales import energy_scale, potential_min  # noqa: F401
from ._histograms import Histograms, bin_count, x_range  # noqa: F401
from ._params import StepFlags, StepParams, step_params, wall_laws  # noqa: F401
from .estimate import second_run_label
from ._step_size import (DT_RSE, STICK_DIV, STICK_R, binding_scale,  # noqa: F401
                         crossing_divisor, default_dt, default_sample_every, default_t_burn,
                         dt_limit, relaxation_rate, step_bounds, time_scales,
                         typical_energy)
from .solution import ALL_QUANTITIES

#: The histograms whose edges start at 0, and what they bin.
FROM_ZERO = {"impacts": "speeds", "impact_energy": "energies", "inter_impact": "times"}

CHUNK_PATH_STEPS = 1 << 23      # path-steps per kernel call (progress / Ctrl-C granularity)


def check_quantities(name: str, quantities: Any, where: str | None) -> tuple[str, ...]:
    """Distinct names from :data:`ALL_QUANTITIES` (the default histograms and the
    opt-in impact speeds), in that order."""
    if isinstance(quantities, str):
        quantities = (quantities,)
    try:
        qs = tuple(quantities)
    except TypeError:
        raise _checks.invalid(where, name, f"a sequence of names from {ALL_QUANTITIES}",
                              quantities) from None
    bad = [q for q in qs if not isinstance(q, str) or q not in ALL_QUANTITIES]
    if bad or len(set(qs)) != len(qs):
        raise _checks.invalid(where, name, f"distinct names from {ALL_QUANTITIES}",
                              quantities)
    return tuple(q for q in ALL_QUANTITIES if q in qs)


def check_seed(name: str, seed: Any, where: str | None) -> int | np.random.SeedSequence:
    """An int in [0, 2⁶³) or a SeedSequence (None is drawn by :func:`seed_sequence`)."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    return _checks.check_int(name, seed, 0, 2 ** 63 - 1, where=where)


def seed_sequence(seed: int | np.random.SeedSequence | None) -> np.random.SeedSequence:
    """The SeedSequence of a checked seed; None draws a fresh 63-bit seed, so the
    entropy recorded in the result can be given back as ``seed`` (a scene's integer)."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        seed = int(np.random.SeedSequence().entropy) % 2 ** 63
    return np.random.SeedSequence(seed)


def _edges_or_count(where: str | None, name: str, v: Any) -> int | np.ndarray:
    if isinstance(v, numbers.Integral) and not isinstance(v, bool):
        return _checks.check_int(name, v, 1, 100_000, where=where)
    allowed = "a bin count in [1, 100000] or increasing, equally spaced finite edges"
    if isinstance(v, (str, bytes, dict)):
        raise _checks.invalid(where, name, allowed, v)
    try:
        arr = np.asarray(v, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise _checks.invalid(where, name, allowed, v) from None
    if arr.ndim != 1 or not 2 <= arr.size <= 100_001 or not np.all(np.isfinite(arr)) or \
            not np.all(np.diff(arr) > 0):
        raise _checks.invalid(where, name, allowed, v)
    w = np.diff(arr)
    if not np.allclose(w, w[0], rtol=1e-9, atol=0):
        raise _checks.invalid(where, name, allowed, v, "the kernel bins uniformly")
    return arr


def check_bins(name: str, bins: Any, where: str | None) -> dict[str, Any]:
    """bins: int n (n bins for energy, x, y, each wall's impact speeds and impact
    energies and the inter-impact times; n//2 per axis for joint) or a dict (edges of
    impact speeds, energies and inter-impact times must start at 0)."""
    if isinstance(bins, numbers.Integral) and not isinstance(bins, bool):
        n = _checks.check_int(name, bins, 2, 100_000, where=where)
        return {"energy": n, "x": n, "y": n, "joint": (max(n // 2, 1),) * 2, "impacts": n,
                "impact_energy": n, "inter_impact": n}
    if not isinstance(bins, dict):
        raise _checks.invalid(where, name, "an integer in [2, 100000] or a table "
                              "{quantity: count or edges}", bins)
    unknown = [k for k in bins if k not in ALL_QUANTITIES]
    if unknown:
        raise _checks.invalid(where, f"{name} keys", f"names from {ALL_QUANTITIES}", unknown)
    out = check_bins(name, 100, where)
    for k, v in bins.items():
        if k == "joint":
            if isinstance(v, numbers.Integral) and not isinstance(v, bool):
                v = (v, v)
            if not (isinstance(v, (tuple, list)) and len(v) == 2):
                raise _checks.invalid(where, f"{name}['joint']", "a count, or a pair (x "
                                      "bins, y bins) of counts or edges", v)
            out[k] = (_edges_or_count(where, f"{name}['joint'][0]", v[0]),
                      _edges_or_count(where, f"{name}['joint'][1]", v[1]))
        else:
            out[k] = _edges_or_count(where, f"{name}[{k!r}]", v)
            if k in FROM_ZERO and isinstance(out[k], np.ndarray) and out[k][0] != 0.0:
                raise _checks.invalid(where, f"{name}[{k!r}]", "a bin count or equally "
                                      f"spaced edges starting at 0 ({FROM_ZERO[k]})", v)
    return out


# -- kernel set-up ------------------------------------------------------------------
def block_starts(n_paths: int, n_blocks: int) -> np.ndarray:
    return (np.arange(n_blocks + 1, dtype=np.int64) * n_paths) // n_blocks


def rng_states(children: list[np.random.SeedSequence]) -> np.ndarray:
    st = np.array([c.generate_state(4, np.uint64) for c in children], dtype=np.uint64)
    st[np.all(st == 0, axis=1), 0] = 1           # xoshiro's forbidden all-zero state
    return st


def initial_x(system: VibroImpactSystem) -> float:
    """Where the stationary run starts its paths: x = 0, or the nearest point of the
    strip when 0 is not on it (a preloaded wall)."""
    lo, hi = system.x_bounds
    return min(max(0.0, lo), hi)


class Progress(_Progress):
    """The package's progress bar (:class:`fpk_vibro.progress.Progress`), labelled
    for Monte Carlo (and, in an error estimate's second run, as its bias run)."""

    def __init__(self, enabled: bool | None, label: str) -> None:
        super().__init__(enabled, f"montecarlo {label}{second_run_label()}")
