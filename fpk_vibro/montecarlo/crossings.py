"""Level crossings and peaks counted on Monte Carlo paths: :func:`crossings`
(docs/theory.md, §Spectra and crossings).

Stationary paths (started and burned in as :func:`~fpk_vibro.montecarlo.stationary`'s)
are advanced by the engine's step, and at every step the compiled kernel counts, on
the scheme's piecewise-linear path through the step's start, midpoint, end and the
walls it touched (:mod:`._paths_kernel`):

- **up-crossings** of each level b (x passing from below b to b or above): their
  rate per unit time is ν⁺(b) = ∫_{y>0} y p(b, y) dy.  A level on the right wall
  counts the arrivals on it, one on the left wall the departures from it: both that
  wall's impact rate (so ν⁺(wall) = impact rate holds count by count, up to grazes,
  a touch without impact; with r near 0 both counts depend on dt, as the impact
  count does, :mod:`fpk_vibro.montecarlo`);
- **peaks**: with white noise x has infinitely many local maxima, so a peak is the
  engineering one, the largest x of an excursion above the mean m (from an
  up-crossing of m to the next down-crossing), one per excursion; the rate of peaks
  above b is at most ν⁺(b) (an excursion above b crosses b at least once) and close
  to it at high levels (where one crossing per excursion is the rule).  The
  excursion rate is ν⁺(m).  An excursion under way when the counting starts is not
  counted; m is E[x] = 0 for a symmetric system, else the mean of a pilot run of 2/λ
  (λ the relaxation rate) before the counting, recorded in the result.

Bias: the count misses the excursions across b that start and end within one
half-step (the scheme's path is linear between vertices), a relative
O(c h)-small deficit (velocity slower than ~sqrt(2 D h) at the crossing); a run at
2 dt measures it (``bias_run``).  Standard errors come from the batches of paths.
Measured against the Gibbs closed form and at 2 dt: docs/measurements.md, §Counted
crossings.
"""
from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._checks import InputError, check_points, invalid
from ..budget import Cost, enforce
from ..io import atomic_savez, atomic_write_text, strict
from ..model import VibroImpactSystem
from . import _setup as S
from ._paths import Paths, effective_levels, shared_options
from ._summary import _ratio
from .estimate import interruption_note

__all__ = ["crossings", "CrossingRates", "MAX_LEVELS"]

#: Levels one count takes at most.
MAX_LEVELS = 128
#: Default paths per device.
DEFAULT_PATHS = {"cpu": 256, "cuda": 65536}
#: Pilot run for the mean of an asymmetric system, in relaxation times.
PILOT = 2.0
CROSSINGS_FORMAT = "fpk_vibro.crossings"
CROSSINGS_VERSION = 1
#: Levels whose rate is below this fraction of the excursion rate do not steer an
#: adaptive run (they are reported with their standard error).
RARE = 0.01
ARRAYS = ("levels", "upcrossing_rate", "upcrossing_rate_se", "peak_rate", "peak_rate_se")


@dataclass
class CrossingRates:
    """Counted up-crossing and peak rates per level (module docstring).

    Attributes
    ----------
    system : VibroImpactSystem
    levels : ndarray
        The levels b, as given.
    upcrossing_rate, upcrossing_rate_se : ndarray
        ν⁺(b) per unit time and its standard error between batches.
    peak_rate, peak_rate_se : ndarray
        The rate of peaks (excursion maxima) at or above b.
    mean_level : float
        The reference m of the excursions.
    excursion_rate, excursion_rate_se : float
        ν⁺(m), the rate of excursions (and of peaks).
    impact_rate, impact_rate_se : dict
        Per wall ("left", "right"), impacts per unit time on it.
    info : dict
        The run: dt, n_paths, n_batches, t_burn, t_sample, seed_entropy, device,
        partial, seconds, and the rates at 2 dt where ``bias_run`` was asked.
    """

    system: VibroImpactSystem
    levels: np.ndarray
    upcrossing_rate: np.ndarray
    upcrossing_rate_se: np.ndarray
    peak_rate: np.ndarray
    peak_rate_se: np.ndarray
    mean_level: float
    excursion_rate: float
    excursion_rate_se: float
    impact_rate: dict = field(default_factory=dict)
    impact_rate_se: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able record (arrays as lists)."""
        out = {k: getattr(self, k) for k in ARRAYS}
        out.update(mean_level=self.mean_level, excursion_rate=self.excursion_rate,
                   excursion_rate_se=self.excursion_rate_se,
                   impact_rate=dict(self.impact_rate),
                   impact_rate_se=dict(self.impact_rate_se), info=dict(self.info),
                   method="montecarlo", system=self.system.to_dict())
        return strict(out)

    def save(self, path: str | os.PathLike) -> Path:
        """Write ``.npz`` (arrays and a JSON header) or ``.json`` (by the suffix; none:
        ``.npz`` appended)."""
        path = Path(path)
        head = {"format": CROSSINGS_FORMAT, "version": CROSSINGS_VERSION, **self.to_dict()}
        if path.suffix == ".json":
            return atomic_write_text(path, json.dumps(head, allow_nan=False))
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        arrays = {k: np.asarray(getattr(self, k), dtype=float) for k in ARRAYS}
        for k in ARRAYS:
            head.pop(k)
        arrays["header"] = np.array(json.dumps(head, allow_nan=False))
        return atomic_savez(path, arrays)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "CrossingRates":
        """Read a file written by :meth:`save`; any problem is one line naming it."""
        path = Path(path)
        try:
            if path.suffix == ".json":
                h = json.loads(path.read_text())
                if not isinstance(h, dict):
                    raise ValueError("not a crossings file (no header)")
                arrays = {k: _floats(h.pop(k)) for k in ARRAYS}
            else:
                with np.load(path, allow_pickle=False) as z:
                    arrays = {k: np.asarray(z[k], dtype=float) for k in ARRAYS}
                    h = json.loads(str(z["header"]))
            if not isinstance(h, dict) or h.get("format") != CROSSINGS_FORMAT:
                raise ValueError("not a crossings file (header format)")
            if h.get("version") != CROSSINGS_VERSION:
                raise ValueError(f"version {h.get('version')!r}, expected {CROSSINGS_VERSION}")
            n = arrays["levels"].shape
            if any(a.shape != n or a.ndim != 1 for a in arrays.values()):
                raise ValueError("arrays of different lengths")
            return cls(VibroImpactSystem.from_dict(h["system"]), **arrays,
                       mean_level=_float(h["mean_level"]),
                       excursion_rate=_float(h["excursion_rate"]),
                       excursion_rate_se=_float(h["excursion_rate_se"]),
                       impact_rate=dict(h["impact_rate"]),
                       impact_rate_se=dict(h["impact_rate_se"]), info=dict(h["info"]))
        except InputError as exc:
            raise InputError(f"{path}: {exc}", where=str(path), name="path") from None
        except (OSError, ValueError, KeyError, TypeError, AttributeError, EOFError) as exc:
            problem = " ".join(str(exc).split())
            raise InputError(f"{path}: {type(exc).__name__}: {problem}", where=str(path),
                             name="path") from None

    def __repr__(self) -> str:
        return (f"CrossingRates(levels={self.levels.size}, mean_level={self.mean_level:.6g}, "
                f"excursion_rate={self.excursion_rate:.6g})")


def _float(v: Any) -> float:
    return math.nan if v is None else float(v)


def _floats(v: Any) -> np.ndarray:
    """A JSON list of numbers (None: NaN, as :func:`fpk_vibro.io.strict` writes it)."""
    if not isinstance(v, list):
        raise ValueError("an array entry is not a list")
    return np.array([_float(x) for x in v], dtype=float)


def _levels(where: str, system: VibroImpactSystem, levels: Any) -> np.ndarray:
    arr = np.atleast_1d(check_points("levels", levels, where=where))
    lo, hi = system.x_bounds
    if arr.ndim != 1 or arr.size == 0 or arr.size > MAX_LEVELS:
        raise invalid(where, "levels", f"1 to {MAX_LEVELS} finite numbers", levels)
    out = (arr < lo) | (arr > hi)
    if out.any():
        raise invalid(where, "levels", f"levels within the strip [{lo:g}, {hi:g}]",
                      float(arr[out][0]), "beyond a wall no path goes")
    return arr


def crossings(system: VibroImpactSystem, levels: Any, *,
              seed: int | np.random.SeedSequence | None = None, n_paths: int | None = None,
              dt: float | None = None, t_burn: float | None = None,
              t_sample: float | None = None, target_rse: float = 0.01,
              max_t_sample: float | None = None, n_batches: int = 32,
              max_impacts: int = 64, progress: bool | None = None,
              threads: int | None = None, device: str = "cpu",
              bias_run: bool = False) -> CrossingRates:
    """Counted up-crossing rates ν⁺(b), peak rates and impact rates (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
        Any stationary system (walls with constant or speed-dependent restitution,
        parametric noise, coloured external noise); a forced system is refused.
    levels : array_like
        Levels b within the strip (at most :data:`MAX_LEVELS`), any order.
    seed : int, SeedSequence or None
        Same seed → the same counts (on one device).
    n_paths : int, optional
        Default 256 (65536 on a GPU).
    dt, t_burn, n_batches, max_impacts, progress, threads, device
        As in :func:`~fpk_vibro.montecarlo.stationary`.
    t_sample : float, optional
        Counted time per path; default: until the relative SE of the excursion rate
        and of every ν⁺(b) above :data:`RARE` of it is at most ``target_rse``
        (checked every ~8·10⁶ path-steps), at most ``max_t_sample`` (10⁴/λ).
    target_rse : float, default 0.01
    bias_run : bool, default False
        Also count at 2 dt (same paths, times and seed): ``info["at_2dt"]`` holds its
        rates and ``info["time_step_bias"]`` their difference (the count's bias is
        O(dt): the difference estimates it).

    Returns
    -------
    CrossingRates

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> s = VibroImpactSystem.paper(r=1.0, D2=0.0)
    >>> c = crossings(s, [0.0, 0.6], seed=1, n_paths=64, n_batches=8, t_sample=200.0)
    >>> nu, imp = c.upcrossing_rate[1], c.impact_rate["right"]   # the wall's own count
    >>> bool(abs(nu - imp) < 1e-3 * imp)
    True
    """
    where = "montecarlo.crossings"
    t_start = time.perf_counter()
    arr = _levels(where, system, levels)
    opts, r, dev = shared_options(where, system, dict(locals()), DEFAULT_PATHS)
    if not isinstance(bias_run, bool):
        raise invalid(where, "bias_run", "True or False", bias_run)
    res = _count(system, arr, opts, r, dev, r["dt"], where)
    if bias_run and not res.info["partial"]:
        dt2 = 2.0 * r["dt"]
        if dt2 > S.dt_limit(system):
            raise InputError(f"{where}: bias_run: 2 dt = {dt2:.4g} is beyond the stability "
                             f"limit {S.dt_limit(system):.4g}; give a smaller dt",
                             where=where, name="bias_run")
        opts2 = opts.replace(t_sample=res.info["t_sample"], seed=res.info["seed_entropy"])
        other = _count(system, arr, opts2, r, dev, dt2, where)
        res.info["at_2dt"] = {k: other.to_dict()[k] for k in
                              ("upcrossing_rate", "upcrossing_rate_se", "peak_rate",
                               "excursion_rate")}
        res.info["time_step_bias"] = list(res.upcrossing_rate - other.upcrossing_rate)
    res.info["seconds"] = time.perf_counter() - t_start
    return res


def _count(system, arr, opts, r, dev, dt, where) -> CrossingRates:
    order = np.argsort(arr, kind="stable")
    lev = effective_levels(system, arr[order])
    n, nb = opts.n_paths, opts.n_batches
    n_burn = math.ceil(r["t_burn"] / dt - 1e-9)
    fixed = opts.t_sample is not None
    t_max = opts.t_sample if fixed else r["max_t_sample"]
    n_steps = max(2, 2 * math.ceil(t_max / (2.0 * dt) - 1e-9))
    enforce(Cost(150e6 + 48.0 * n + 16.0 * nb * lev.size, float(n * (n_burn + n_steps)),
                 "path-steps", 1.0 + n * (n_burn + n_steps) / 1.5e8,
                 "t_sample" if fixed else "max_t_sample"), where)
    P = Paths(system, n_paths=n, n_batches=nb, dt=dt, seed=opts.seed,
              max_impacts=opts.max_impacts, threads=opts.threads, device=dev)
    prog = S.Progress(opts.progress, "crossings")
    try:
        P.burn_in(n_burn, prog, (0.0, 0.1))
        mean = 0.0 if system.symmetric else _pilot(P, r["lam"], system)
    except KeyboardInterrupt:
        prog.close("(interrupted during burn-in: nothing counted)")
        raise
    P.count_from_here(lev, mean)
    chunk = max(2, S.CHUNK_PATH_STEPS // max(n, 1) // 2 * 2)
    done, partial = 0, False
    n_min = max(2, 2 * math.ceil(1.0 / (r["lam"] * dt) / 2))
    try:
        while done < n_steps:
            m = min(chunk, n_steps - done)
            P.advance(m)
            done += m
            frac = done / n_steps
            if not fixed and done >= n_min:
                rse = _worst_rse(P)
                frac = max(frac, min(1.0, (opts.target_rse / rse) ** 2))
                if rse <= opts.target_rse:
                    break
            prog.update(0.1 + 0.9 * min(frac, 1.0), "counting")
    except KeyboardInterrupt:
        if done == 0:
            prog.close("(interrupted before any step was counted)")
            raise
        partial = True
        interruption_note("\n[montecarlo] interrupted: returning the counts so far "
                          "(info['partial'] = True)")
    prog.close()
    P.check_finite(where)
    return _result(system, arr, order, P, mean, dict(
        dt=dt, n_paths=n, n_batches=nb, t_burn=n_burn * dt, t_sample=done * dt,
        seed_entropy=P.seed_entropy, device=P.device_name, partial=partial))


def _pilot(P: Paths, lam: float, system: VibroImpactSystem) -> float:
    """E[x] from a pilot run of :data:`PILOT`/λ sampled about every T0/4."""
    every = max(2, S.default_sample_every(system, P.dt))
    n = max(1, math.ceil(PILOT / (lam * P.dt * every)))
    out = np.empty((P.n_paths, n))
    P.advance(n * every, every, out)
    return float(out.mean())


def _worst_rse(P: Paths) -> float:
    L = P.levels.size
    t = P.path_time()
    ups = np.column_stack([P.cnt[:, :L], P.cnt[:, 2 * L + 1]])
    est, se = _ratio(ups, t)
    keep = est >= RARE * est[-1]
    if est[-1] <= 0:
        return math.inf
    return float(np.max(se[keep] / est[keep]))


def _result(system, arr, order, P: Paths, mean: float, info: dict) -> CrossingRates:
    L = P.levels.size
    t = P.path_time()
    c = P.cnt
    up, up_se = _ratio(c[:, :L], t)
    peaks = np.cumsum(c[:, L:2 * L + 1][:, ::-1], axis=1)[:, ::-1]     # ≥ k levels below
    pk, pk_se = _ratio(peaks[:, 1:], t)
    ex, ex_se = _ratio(c[:, [2 * L + 1]], t)
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    imp, imp_se = {}, {}
    for side, wall in system.walls:
        k = 0 if side == "left" else 1
        v, s = _ratio(P.wcnt[:, [k]], t)
        imp[side], imp_se[side] = float(v[0]), float(s[0])
    return CrossingRates(system, arr.copy(), up[back], up_se[back], pk[back], pk_se[back],
                         mean, float(ex[0]), float(ex_se[0]), imp, imp_se, info)
