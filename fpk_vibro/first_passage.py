"""First passage out of the safe set {H < H_c}: one result type for every method.

A path starts inside the safe set and is stopped when its energy first reaches the
critical level H_c.  The time it takes is the first-passage time T; engineers ask
for its mean τ (the mean first-passage time) and for the reliability
R(t) = P(T > t).  Starts: a point ``(x0, y0)``, a Gaussian ``{"mean": (x0, y0),
"std": (sx, sy)}``, or ``"stationary"`` (the stationary density conditioned on the
safe set).

The three engines compute it each their way (:func:`fpk_vibro.fem.first_passage`,
:func:`fpk_vibro.averaging.first_passage`,
:func:`fpk_vibro.montecarlo.first_passage`) and return a :class:`FirstPassage`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ._checks import check_float, invalid
from .model import VibroImpactSystem

__all__ = ["FirstPassage", "parse_start", "check_energy"]


def check_energy(where: str, system: VibroImpactSystem, energy: Any) -> float:
    """H_c as a float above the bottom of the potential on the strip."""
    from .scales import potential_min
    g0 = potential_min(system)
    return check_float("energy", energy, lo=g0, lo_open=True, where=where)


def parse_start(where: str, system: VibroImpactSystem, start: Any, energy: float
                ) -> tuple[str, Any]:
    """("point", (x0, y0)), ("gaussian", {"mean", "std"}) or ("stationary", None).

    A point must lie in the safe set (H < H_c) and on the strip.
    """
    if start is None or (isinstance(start, str) and start == "stationary"):
        return "stationary", None
    if isinstance(start, dict):
        from .initial import parse_initial
        init = parse_initial(start, system)
        return "gaussian", {"mean": tuple(init.mean), "std": tuple(init.std)}
    if isinstance(start, (tuple, list, np.ndarray)) and len(start) == 2:
        x0 = check_float("start[0]", start[0], where=where)
        y0 = check_float("start[1]", start[1], where=where)
        lo, hi = system.x_bounds
        if not lo <= x0 <= hi:
            raise invalid(where, "start", f"a point on the strip {lo} <= x <= {hi}", start)
        if not float(system.energy(x0, y0)) < energy:
            raise invalid(where, "start", f"a point inside the safe set H < {energy:g}",
                          start, f"H(x0, y0) = {float(system.energy(x0, y0)):.4g}")
        return "point", (x0, y0)
    raise invalid(where, "start", "(x0, y0), {'mean': ..., 'std': ...} or 'stationary'",
                  start)


@dataclass
class FirstPassage:
    """Mean first-passage time and reliability of one method for one start.

    Attributes
    ----------
    method : str
        "fem", "averaging" or "montecarlo".
    system : VibroImpactSystem
    energy : float
        The critical energy H_c.
    start : tuple
        ("point", (x0, y0)), ("gaussian", {...}) or ("stationary", None).
    mean : float
        τ for the start.
    mean_se : float
        Its standard error (Monte Carlo; 0 for the deterministic methods).
    times, survival : ndarray
        R(t) = P(T > t) on a grid of times (``survival[0] = 1``).
    survival_band : (ndarray, ndarray) or None
        A 95 % confidence band of R (Monte Carlo).
    info : dict
        Method-specific details (mesh, paths, seconds, quantiles, ...).
    """

    method: str
    system: VibroImpactSystem
    energy: float
    start: tuple
    mean: float
    mean_se: float
    times: np.ndarray
    survival: np.ndarray
    survival_band: tuple[np.ndarray, np.ndarray] | None = None
    info: dict = field(default_factory=dict)
    _mean_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None

    def mean_time(self, x0: Any = None, y0: Any = None) -> Any:
        """τ from the point (x0, y0) (arrays broadcast); no arguments: τ for the start.

        Monte Carlo knows τ only for its own start.
        """
        if x0 is None and y0 is None:
            return self.mean
        if self._mean_at is None:
            raise ValueError(f"{self.method}.first_passage: mean_time(x0, y0) is known only "
                             f"for the start {self.start[1]!r}; call mean_time()")
        return self._mean_at(np.asarray(x0, float), np.asarray(y0, float))

    def reliability(self, t: Any) -> Any:
        """R(t) = P(T > t) for the start: interpolated on :attr:`times`, and beyond
        the last time continued with the decay rate of the last stretch."""
        t = np.asarray(t, dtype=float)
        if np.any(~np.isfinite(t)) or np.any(t < 0):
            raise invalid(f"{self.method}.first_passage", "t", "finite times >= 0", t)
        R = np.interp(t, self.times, self.survival)
        T, S = self.times, self.survival
        if np.any(t > T[-1]) and S[-1] > 0:
            k = max(1, len(T) // 10)
            rate = (math.log(max(S[-1 - k], 1e-300)) - math.log(S[-1])) / (T[-1] - T[-1 - k])
            R = np.where(t > T[-1], S[-1] * np.exp(-rate * (t - T[-1])), R)
        return R

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able summary (for results.json)."""
        out = {"method": self.method, "energy": self.energy, "start": self.start[0],
               "start_value": self.start[1], "mean": self.mean, "mean_se": self.mean_se,
               "times": self.times.tolist(), "survival": self.survival.tolist(),
               "info": {k: v for k, v in self.info.items()
                        if isinstance(v, (int, float, str, bool, type(None)))}}
        if self.survival_band is not None:
            out["survival_band"] = [b.tolist() for b in self.survival_band]
        return out
