"""First passage out of a safe set: one result type for every method.

A path starts inside the safe set and is stopped when it first leaves it: its energy
reaches the critical level H_c, its displacement a bound, or an impact is faster than a
threshold (:mod:`fpk_vibro.safe_sets`).  The time it takes is the first-passage time T; engineers ask
for its mean τ (the mean first-passage time) and for the reliability
R(t) = P(T > t).  Starts: a point ``(x0, y0)``, a Gaussian ``{"mean": (x0, y0),
"std": (sx, sy)}``, or ``"stationary"`` (the stationary density conditioned on the
safe set).

Requested ``times`` (:func:`check_times`, shared by the three engines) are finite
numbers >= 0 in any order: they are sorted for you and duplicates kept once.  Each
engine computes R on its own time grid, set by its own scales (the mean time, the
horizon of its paths), and reads R at the requested times from it
(:func:`merge_requested`): one huge requested time never coarsens the grid.

The three engines compute it each their way (:func:`fpk_vibro.fem.first_passage`,
:func:`fpk_vibro.averaging.first_passage`,
:func:`fpk_vibro.montecarlo.first_passage`) and return a :class:`FirstPassage`.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ._checks import check_float, invalid
from .model import VibroImpactSystem
from .safe_sets import SafeSet, parse_safe_set

__all__ = ["FirstPassage", "ESTIMATORS", "parse_start", "check_energy", "check_times", "survival_at",
           "merge_requested", "MAX_TIMES", "SafeSet", "parse_safe_set"]

#: Most requested times accepted.
MAX_TIMES = 10 ** 6

_TIMES_RULE = "a non-empty sequence of finite numbers >= 0 (any order)"


def check_times(where: str, times: Any) -> np.ndarray | None:
    """The requested times of R(t): None, or a sorted array of distinct floats.

    A list, tuple, range or 1-D numeric array of finite numbers >= 0 (at most
    :data:`MAX_TIMES`), in any order: they are sorted and duplicates dropped.  Anything
    else (a string, a bool, NaN, a negative time, an empty sequence) raises a one-line
    :class:`~fpk_vibro._checks.InputError` naming ``times``.
    """
    if times is None:
        return None
    if isinstance(times, np.ndarray):
        if times.ndim != 1 or times.dtype.kind not in "iuf":
            raise invalid(where, "times", _TIMES_RULE, times,
                          f"an array of dtype {times.dtype} and shape {times.shape}")
        values = list(times.tolist())
    elif isinstance(times, (list, tuple, range)):
        values = list(times)
    else:
        raise invalid(where, "times", _TIMES_RULE, times)
    if not values:
        raise invalid(where, "times", _TIMES_RULE, times, "empty")
    if len(values) > MAX_TIMES:
        raise invalid(where, "times", _TIMES_RULE + f", at most {MAX_TIMES}",
                      f"<{len(values)} times>")
    out = np.empty(len(values))
    for i, t in enumerate(values):
        ok = isinstance(t, numbers.Real) and not isinstance(t, bool)
        try:
            v = float(t) if ok else math.nan
        except (OverflowError, ValueError):
            v = math.nan
        if not (math.isfinite(v) and v >= 0):
            raise invalid(where, "times", _TIMES_RULE, times, f"entry {i} is {t!r}")
        out[i] = v
    return np.unique(out)


def survival_at(T: np.ndarray, S: np.ndarray, t: np.ndarray) -> np.ndarray:
    """R(t) read on the grid (T, S): linear between grid times, and beyond the last
    time continued with the decay rate of the last tenth of the grid."""
    t = np.asarray(t, dtype=float)
    R = np.interp(t, T, S)
    if np.any(t > T[-1]) and S[-1] > 0 and T.size > 1:
        k = max(1, len(T) // 10)
        rate = (math.log(max(S[-1 - k], 1e-300)) - math.log(S[-1])) / (T[-1] - T[-1 - k])
        with np.errstate(over="ignore", under="ignore"):
            R = np.where(t > T[-1], S[-1] * np.exp(-max(rate, 0.0) * (t - T[-1])), R)
    return R


def merge_requested(T: np.ndarray, S: np.ndarray, requested: np.ndarray | None,
                    exact: Callable[[np.ndarray], np.ndarray] | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The solver's grid (T, S) with the requested times added: R at them from
    ``exact(t)`` where given (up to T[-1]), else read on the grid
    (:func:`survival_at`)."""
    if requested is None or requested.size == 0:
        return T, S
    R = survival_at(T, S, requested)
    if exact is not None:
        inside = requested <= T[-1]
        if np.any(inside):
            R[inside] = exact(requested[inside])
    times = np.concatenate([T, requested])
    order = np.argsort(times, kind="stable")
    times, values = times[order], np.concatenate([S, R])[order]
    keep = np.concatenate([[True], np.diff(times) > 0])
    return times[keep], np.clip(values[keep], 0.0, 1.0)


def _coordinate(where: str, name: str, value: Any) -> np.ndarray:
    """x0 or y0 of :meth:`FirstPassage.mean_time`: finite numbers (arrays broadcast)."""
    rule = "a finite number or an array of finite numbers"
    if value is None or isinstance(value, (bool, str, bytes)):
        raise invalid(where, name, rule, value)
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise invalid(where, name, rule, value) from None
    if v.dtype.kind != "f" or not np.all(np.isfinite(v)):
        raise invalid(where, name, rule, value)
    return v


def check_energy(where: str, system: VibroImpactSystem, energy: Any) -> float:
    """H_c as a float above the bottom of the potential on the strip."""
    from .scales import potential_min
    g0 = potential_min(system)
    return check_float("energy", energy, lo=g0, lo_open=True, where=where)


def parse_start(where: str, system: VibroImpactSystem, start: Any,
                energy: "float | SafeSet") -> tuple[str, Any]:
    """("point", (x0, y0)), ("gaussian", {"mean", "std"}) or ("stationary", None).

    A point must lie in the safe set (``energy``: H_c, or any :class:`SafeSet`) and on
    the strip.
    """
    safe = energy if isinstance(energy, SafeSet) else SafeSet("energy", energy=energy)
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
        if not bool(safe.contains(system, x0, y0)):
            got = (f"H(x0, y0) = {float(system.energy(x0, y0)):.4g}"
                   if safe.kind == "energy" else None)
            raise invalid(where, "start", f"a point inside the safe set {safe.describe()}",
                          start, got)
        return "point", (x0, y0)
    raise invalid(where, "start", "(x0, y0), {'mean': ..., 'std': ...} or 'stationary'",
                  start)


#: Each method's first-passage estimator, ``estimator(fp, reference)`` (finite
#: elements set ``_estimate`` when they solve).  The registry, above every method,
#: provides them when the package loads: this module lies below the methods.
ESTIMATORS: dict[str, Callable[[Any, Any], dict[str, Any]]] = {}


@dataclass
class FirstPassage:
    """Mean first-passage time and reliability of one method for one start.

    Attributes
    ----------
    method : str
        "fem", "averaging" or "montecarlo".
    system : VibroImpactSystem
    energy : float or None
        The critical energy H_c of an energy safe set (None for another kind).
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
    safe_set : SafeSet or None
        The set left (:mod:`fpk_vibro.safe_sets`); None means {H < energy}.
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
    _estimate: dict | None = None
    safe_set: SafeSet | None = None

    def __post_init__(self) -> None:
        if self.safe_set is None:
            self.safe_set = SafeSet("energy", energy=self.energy)

    def error_estimate(self, reference: "FirstPassage | None" = None) -> dict[str, Any]:
        """The method's own error estimate of τ and R(t), made on the first call and kept.

        Parameters
        ----------
        reference : FirstPassage, optional
            Averaging only: the finite-element first passage of the same system,
            energy and start to measure the model error against (e.g. a scene's own);
            default: ``fem.first_passage`` with its default accuracy, solved on the
            first call.

        Returns
        -------
        dict
            ``"mean_time"`` (relative error of τ), ``"reliability"`` (largest absolute
            error of R(t) on the time grid) and ``"assumes"`` (what the estimate takes
            for granted).  Finite elements: the three-level estimate, with ``"order"``
            and ``"levels"`` ((nx, ny, n_steps) of the solves, the answer's last).  Monte
            Carlo: 2 SE + |bias| + 2 SE(bias) from one second run at 2 dt
            (:func:`fpk_vibro.montecarlo._first_passage.error_estimate`), with ``"bias"``
            (relative, signed) and ``"seconds"``.  Averaging: the difference to the
            FE first passage plus FE's own estimate
            (:func:`fpk_vibro.averaging.first_passage.model_error`), infinite with
            FE's reason (``"reference"``) where FE refuses.

        Raises
        ------
        ValueError
            A ``reference`` given to a method other than averaging, or one of another
            method, energy or start.
        """
        if reference is not None and self.method != "averaging":
            raise ValueError(f"{self.method}.first_passage: error_estimate takes a "
                             "reference for averaging only")
        if reference is None and self._estimate is not None:
            return dict(self._estimate)
        estimator = ESTIMATORS.get(self.method)
        if estimator is None:
            raise ValueError(f"{self.method}.first_passage: no error estimate (this "
                             "result was not made by fem.first_passage)")
        est = estimator(self, reference)
        if self._estimate is None:
            self._estimate = est
        return dict(est)

    def mean_time(self, x0: Any = None, y0: Any = None) -> Any:
        """τ from the point (x0, y0) (arrays broadcast); no arguments: τ for the start.

        Monte Carlo knows τ only for its own start.  A missing (None), NaN, infinite
        or non-numeric coordinate raises a one-line InputError naming it.
        """
        if x0 is None and y0 is None:
            return self.mean
        where = f"{self.method}.first_passage"
        x, y = _coordinate(where, "x0", x0), _coordinate(where, "y0", y0)
        if self._mean_at is None:
            raise ValueError(f"{where}: mean_time(x0, y0) is known only "
                             f"for the start {self.start[1]!r}; call mean_time()")
        return self._mean_at(x, y)

    def reliability(self, t: Any) -> Any:
        """R(t) = P(T > t) for the start: interpolated on :attr:`times`, and beyond
        the last time continued with the decay rate of the last stretch."""
        t = np.asarray(t, dtype=float)
        if np.any(~np.isfinite(t)) or np.any(t < 0):
            raise invalid(f"{self.method}.first_passage", "t", "finite times >= 0", t)
        return survival_at(self.times, self.survival, t)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able summary (for results.json)."""
        out = {"method": self.method, "energy": self.energy,
               "safe_set": self.safe_set.to_dict(), "start": self.start[0],
               "start_value": self.start[1], "mean": self.mean, "mean_se": self.mean_se,
               "times": self.times.tolist(), "survival": self.survival.tolist(),
               "info": {k: v for k, v in self.info.items()
                        if isinstance(v, (int, float, str, bool, type(None)))}}
        if self.survival_band is not None:
            out["survival_band"] = [b.tolist() for b in self.survival_band]
        return out
