"""The options of the Monte Carlo method, declared once (see :mod:`fpk_vibro.options`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._checks import InputError, invalid
from ..budget import MAX_SECONDS, Cost, human_seconds
from ..model import VibroImpactSystem
from ..options import Options as _Options
from ..options import PerMode, option
from . import _setup as S
from .solution import ALL_QUANTITIES, IMPACT_QUANTITIES, QUANTITIES

TWO_PI = 2.0 * math.pi

__all__ = ["Options"]

ST, TR, FP, PE = ("stationary",), ("transient",), ("first_passage",), ("periodic",)
#: Every mode (densities, first passage and the periodic response).
ALL = ("stationary", "transient", "first_passage", "periodic")
#: The density modes and the periodic response.
DENS = ("stationary", "transient", "periodic")
#: Defaults of the periodic response where a PerMode has none (PerMode knows the
#: modes stationary, transient and first passage only).
PERIODIC_DEFAULTS = {"n_paths": 2048, "bins": 60}
#: First horizon of an adaptive first passage, in relaxation times (its cost model).
FP_FIRST = 10.0
#: Default burn-in of the periodic response, in relaxation times 1/λ: the forced mean's
#: transient decays like e^{−λt/2} (the amplitude, where the energy decays like e^{−λt};
#: e^{−ct/2} for the linear oscillator), so 12/λ gives it 6 e-folds (e⁻⁶ ≈ 0.25 % of
#: the mean amplitude left), as 6/λ gives the noise's.  6/λ left e⁻³ ≈ 5 % of the
#: amplitude: a = 1, c = 0.05, F = 0.05, Ω = 1 (A = 1) measured 0.955 (the windowed
#: transient predicts 0.956), now 0.998 ± 0.006 (tests/test_montecarlo_periodic.py).
FORCED_BURN = 12.0

#: Path-steps per second of one thread (benchmark medians, docs/costs.md), kept low.
PATH_STEPS_PER_S = 1.0e8
#: A given dt is refused beyond COARSE × the default step a time scale other than the
#: period allows (:func:`._setup.step_bounds`; there the bias is several per cent:
#: E[y²] −5.7 % at 8 × the default with r = 0.92, D1 = 10⁶).
COARSE = 8.0


@dataclass(frozen=True)
class Options(_Options):
    """Numerical options of :func:`~fpk_vibro.montecarlo.stationary`,
    :func:`~fpk_vibro.montecarlo.transient` and
    :func:`~fpk_vibro.montecarlo.first_passage` (and ``periodic``); coloured external
    noise is handled by ``stationary`` and ``transient`` (``COLOURED_MODES``)."""

    WHERE = "montecarlo"
    FORCED_MODES = ("transient", "periodic")
    COLOURED_MODES = ("stationary", "transient")

    n_paths: int = option(PerMode(2048, 4096, 4096), "independent paths", "int", lo=2,
                          hi=10 ** 9, reduced=512, modes=ALL)
    dt: float | None = option(None, "time step (the largest, in a transient)", "float",
                              lo=0.0, lo_open=True, unit="s", modes=ALL,
                              auto="the smallest of T0/120, 1/(10 c), noise time/4 and crossing "
                              "time/k(r) (montecarlo._setup.step_bounds), smaller for "
                              "target_rse < 1e-3")
    t_burn: float | None = option(None, "burn-in time per path", "float", lo=0.0, unit="s",
                                  modes=ST, auto="6 relaxation times")
    t_sample: float | None = option(None, "sampled time per path", "float", lo=0.0,
                                    lo_open=True, unit="s", modes=ST, reduced=200.0,
                                    auto="until the relative SE of E[H] is target_rse")
    seed: Any = option(None, "random seed: the same seed gives the same numbers", "custom",
                       check=S.check_seed, allowed="integer in [0, 2⁶³ − 1]", modes=ALL,
                       auto="fresh entropy, recorded in the result")
    quantities: tuple = option(QUANTITIES, "histograms to accumulate", "custom",
                               check=S.check_quantities, allowed=f"names from {ALL_QUANTITIES}",
                               scene="study.quantities", modes=DENS)
    bins: Any = option(PerMode(100, 60), "histogram bins: n for H, x, y (n/2 per axis of the "
                       "joint), or a table {quantity: count or edges}", "custom",
                       check=S.check_bins, allowed="integer in [2, 100000] or a table",
                       modes=DENS)
    n_batches: int = option(32, "independent batches (standard errors from their spread)",
                            "int", lo=2, hi=10 ** 6, modes=DENS)
    target_rse: float = option(0.005, "relative SE of E[H] at which an adaptive run stops",
                               "float", lo=0.0, hi=1.0, lo_open=True, hi_open=True, modes=ST)
    max_t_sample: float | None = option(None, "longest sampled time of an adaptive run",
                                        "float", lo=0.0, lo_open=True, unit="s", modes=ST,
                                        auto="10⁴ relaxation times")
    sample_every: int | None = option(None, "steps between samples of a path", "int", lo=1,
                                      hi=10 ** 9, modes=ST, auto="about T0/4")
    max_impacts: int = option(64, "impacts handled in one free-flight sub-step", "int",
                              lo=1, hi=10 ** 6, modes=DENS)
    progress: bool | None = option(None, "a progress line on stderr", "bool", modes=ALL,
                                   scene="cli --quiet", auto="when stderr is a terminal")
    threads: int | None = option(None, "worker threads (the result does not depend on it)",
                                 "int", lo=1, hi=1024, modes=ALL, auto="numba's thread count")
    t_max: float | None = option(None, "horizon of the paths: those still inside then are "
                                 "censored (the mean is a lower bound)", "float", lo=0.0,
                                 lo_open=True, unit="s", modes=FP,
                                 auto="continued until every path has exited (at most 500 "
                                      "relaxation times)")
    device: str = option("cpu", "where the paths run: the CPU threads, an NVIDIA GPU "
                         "(numba-cuda, pip install 'fpk-vibro[gpu]'), or auto (the GPU when "
                         "one is usable); the same estimators, random streams of its own",
                         "choice", choices=("cpu", "cuda", "auto"), modes=ALL)
    phase_bin: float = option(TWO_PI / 64, "width of the phase bin each phase's statistics "
                              "average over (0: the point value, interpolated linearly "
                              "between the sampled instants)", "float", lo=0.0,
                              hi=math.pi / 4, unit="rad", modes=PE)
    n_periods: int | None = option(None, "sampled periods per path", "int", lo=1,
                                   hi=10 ** 7, modes=PE, reduced=20,
                                   auto="the larger of 64 periods and 40 relaxation times")
    burn_periods: int | None = option(None, "burn-in in forcing periods", "int", lo=0,
                                      hi=10 ** 7, modes=PE,
                                      auto="12 relaxation times (6 e-folds of the forced "
                                      "mean's transient e^(-λt/2)), rounded up to whole "
                                      "periods")
    bridge: bool = option(True, "detect crossings between step ends by the Brownian-bridge "
                          "probability (false: step ends only, biased late)", "bool",
                          modes=FP)

    @classmethod
    def from_call(cls, mode: str, values: dict[str, Any]):
        """:meth:`fpk_vibro.options.Options.from_call`; for "periodic" the defaults a
        :class:`~fpk_vibro.options.PerMode` does not know come from
        :data:`PERIODIC_DEFAULTS` (else the stationary one)."""
        if mode != "periodic":
            return super().from_call(mode, values)
        where = f"{cls.WHERE}.{mode}"
        clean = {}
        for name, opt in cls.declared().items():
            if name in values and mode in opt.modes:
                clean[name] = opt.validate(name, values[name], where)
            elif name in PERIODIC_DEFAULTS:
                clean[name] = PERIODIC_DEFAULTS[name]
            else:
                clean[name] = opt.default_for("stationary")
        return cls(**clean)

    # -- rules joining options ----------------------------------------------------
    def resolved(self, system: VibroImpactSystem, mode: str) -> dict[str, Any]:
        """The defaults filled in for ``system``: dt, t_burn, max_t_sample, sample_every."""
        adaptive = mode == "stationary" and self.t_sample is None
        dt = self.dt if self.dt is not None else \
            S.default_dt(system, self.target_rse if adaptive else None)
        lam = S.relaxation_rate(system)
        return {"dt": dt, "lam": lam, "adaptive": adaptive,
                "t_burn": S.default_t_burn(system) if self.t_burn is None else self.t_burn,
                "max_t_sample": 1e4 / lam if self.max_t_sample is None else self.max_t_sample,
                "sample_every": S.default_sample_every(system, dt)
                if self.sample_every is None else self.sample_every}

    def periodic_plan(self, system: VibroImpactSystem, phases: Any = ()) -> dict[str, Any]:
        """The grid and lengths of :func:`~fpk_vibro.montecarlo.periodic`: ``M`` steps
        per period (:func:`._periodic_grid.steps_per_period`), ``h`` = T/M,
        ``burn_periods`` (default :data:`FORCED_BURN`/λ rounded up to periods) and
        ``n_periods`` (default the larger of 64 and 40/λ)."""
        from ._periodic_grid import steps_per_period
        fo = system.forcing
        T = fo.period
        r = self.resolved(system, "periodic")
        M = steps_per_period(T, r["dt"], np.asarray(phases, dtype=float), fo.phase)
        lam = r["lam"]
        burn = self.burn_periods if self.burn_periods is not None else \
            math.ceil(FORCED_BURN / (lam * T) - 1e-9)
        n_per = self.n_periods or max(64, math.ceil(40.0 / (lam * T)))
        return {"M": M, "h": T / M, "burn_periods": int(burn), "n_periods": int(n_per),
                "period": T, "lam": lam}

    def validate_for(self, system: VibroImpactSystem, mode: str, *, probe: bool = False) -> None:
        """Every rule joining the options to each other and to ``system``."""
        where = f"montecarlo.{mode}"

        def bad(name: str, allowed: str, value: Any, why: str = "") -> InputError:
            return invalid(where, name, allowed, value, why)

        if mode == "first_passage":
            self._validate_passage(system, bad)
            return

        asked = [q for q in IMPACT_QUANTITIES if q in self.quantities]
        if asked and (mode != "stationary" or not system.walls):
            raise bad("quantities", "names from " + str(QUANTITIES) + (
                "" if mode != "stationary" else f" ({', '.join(map(repr, asked))} needs a "
                "wall)"), list(self.quantities), f"{asked[0]!r} is recorded by "
                "montecarlo.stationary only" if mode != "stationary" else "no wall")
        if self.n_batches > self.n_paths:
            raise bad("n_batches", f"an integer in [2, n_paths = {self.n_paths}]",
                      self.n_batches)
        r = self.resolved(system, mode)
        limit = S.dt_limit(system)
        if r["dt"] > limit:
            raise bad("dt", f"in (0, {limit:.4g}]", r["dt"], "1/ω_max, ω_max² = |a| + 3|b| X² "
                      "at 30 energy scales: beyond it the explicit splitting loses stability")
        if self.dt is not None:
            for name, (t, allowed) in S.step_bounds(system).items():
                if name != "period" and self.dt > COARSE * allowed:
                    raise bad("dt", f"in (0, {COARSE * allowed:.3g}]", self.dt,
                              f"{COARSE:g} × the default {allowed:.3g} that the {name} = "
                              f"{t:.3g} s allows: a coarser step gives wrong moments with "
                              "tight standard errors")
        if mode == "stationary":
            t_min = r["sample_every"] * r["dt"]
            for name in ("t_sample", "max_t_sample"):
                val = getattr(self, name)
                if val is not None and val < t_min * (1 - 1e-9):
                    raise bad(name, f">= one sampling interval sample_every*dt = {t_min:.6g}",
                              val)

    def _validate_passage(self, system: VibroImpactSystem, bad: Any) -> None:
        """First passage: dt within the stability limit, t_max at least one step."""
        dt = self.resolved(system, "first_passage")["dt"]
        limit = S.dt_limit(system)
        if dt > limit:
            raise bad("dt", f"in (0, {limit:.6g}]", dt, "1/ω_max: beyond it the explicit "
                      "splitting loses stability")
        if self.t_max is not None and self.t_max < dt:
            raise bad("t_max", f"at least one step dt = {dt:.6g}", self.t_max)

    @classmethod
    def prepare(cls, system: VibroImpactSystem, mode: str, values: dict[str, Any], **kw: Any):
        """:meth:`fpk_vibro.options.Options.prepare`; a default step whose run is beyond
        the budget is refused naming the time scale that sets it and the cost."""
        try:
            return super().prepare(system, mode, values, **kw)
        except InputError as exc:
            if exc.name != "dt" or values.get("dt") is not None:
                raise
            opts = cls.from_call(mode, values)
            r = opts.resolved(system, mode)
            name, t, _ = S.binding_scale(system)
            cost = opts.estimate(system, mode, kw.get("times"))
            where = f"{cls.WHERE}.{mode}"
            raise InputError(
                f"{where}: dt: the {name} = {t:.3g} s sets the default step {r['dt']:.3g} s, "
                f"and at that step the run (t_burn {r['t_burn']:.3g} s + sampling) needs "
                f"{cost.work:.3g} path-steps, ~{human_seconds(cost.seconds)}, beyond the "
                f"limit of {human_seconds(MAX_SECONDS)}; a coarser step is wrong here: "
                "use fem or averaging, or force it (--force)", where=where, name="dt") from None

    # -- cost ---------------------------------------------------------------------
    def _estimate_periodic(self, system: VibroImpactSystem) -> Cost:
        if getattr(system, "forcing", None) is None:      # refused by the solver
            return Cost(150e6, 0.0, "path-steps", 1.0, "n_periods")
        return _periodic_cost(self, system)

    def estimate(self, system: VibroImpactSystem, mode: str, times: Any = None) -> Cost:
        """Memory, path-steps and seconds (constants: docs/costs.md)."""
        r = self.resolved(system, mode)
        if mode == "first_passage":
            # paths run to t_max, or (adaptive) 10 relaxation times and then only the
            # survivors: counted as the first round
            t = self.t_max if self.t_max is not None else FP_FIRST / r["lam"]
            path_steps = self.n_paths * math.ceil(t / r["dt"])
            seconds = 1.0 + path_steps * _step_weight(system, r["dt"], 0) / \
                (PATH_STEPS_PER_S * min(self.threads or 2, 2))
            return Cost(150e6 + 64.0 * self.n_paths, float(path_steps), "path-steps",
                        seconds, "n_paths" if self.t_max is None else "t_max")
        if mode == "periodic":
            return self._estimate_periodic(system)
        bins = S.check_bins("bins", self.bins, None)
        n_hist = sum(S.bin_count(bins[q]) for q in ("energy", "x", "y") if q in self.quantities)
        if "joint" in self.quantities:
            n_hist += S.bin_count(bins["joint"][0]) * S.bin_count(bins["joint"][1])
        for q, per in (("impacts", 2), ("impact_energy", 2), ("inter_impact", 1)):
            if q in self.quantities:
                n_hist += per * (S.bin_count(bins[q]) + 1)
        memory = 150e6 + (64.0 if "inter_impact" in self.quantities else 48.0) * self.n_paths + 3 * 8.0 * self.n_batches * n_hist
        if mode == "stationary":
            if r["adaptive"]:     # var(H) ≈ E[H]², correlation time ≈ 0.3/λ (measured)
                t = min(r["max_t_sample"],
                        max(1.0 / r["lam"], 0.3 / (r["lam"] * self.n_paths * self.target_rse ** 2)))
                key = "target_rse"
            else:
                t, key = self.t_sample, "t_sample"
            t += r["t_burn"]
        else:
            t = float(max(times)) if times is not None and len(times) else 0.0
            key = "times"
        if 3 * 8.0 * self.n_batches * n_hist > 0.5 * memory:
            key = "bins"
        elif 48.0 * self.n_paths > 0.5 * memory:
            key = "n_paths"
        path_steps = self.n_paths * math.ceil(t / r["dt"])
        threads = self.threads or 2
        seconds = 1.0 + path_steps * _step_weight(system, r["dt"], r["sample_every"]
                                                  if mode == "stationary" else 0) / \
            (PATH_STEPS_PER_S * min(threads, 2))
        if key not in ("bins", "n_paths") and self.dt is None and \
                S.binding_scale(system)[0] != "period" and \
                seconds * r["dt"] / S.step_bounds(system)["period"][1] <= MAX_SECONDS:
            key = "dt"      # a fast time scale makes it costly (refused by prepare)
        return Cost(memory, float(path_steps), "path-steps", seconds, key)


def _periodic_cost(opts: Options, system: VibroImpactSystem) -> Cost:
    """:meth:`Options.estimate` of the periodic response: the burn-in and the sampled
    periods of every path, plus the bias run of ``error_estimate()`` (the same periods
    at 2 dt: half the steps), at the stationary engine's rate with a sample every
    M/16 steps (the period average's 16 phases; a requested phase adds a few)."""
    pl = opts.periodic_plan(system)
    M = pl["M"]
    periods = pl["burn_periods"] + pl["n_periods"]
    main = opts.n_paths * periods * M
    bias = opts.n_paths * periods * max(8, round(M / 2))
    path_steps = main + bias
    seconds = 1.0 + path_steps * _step_weight(system, pl["h"], max(1, M // 16)) / \
        (PATH_STEPS_PER_S * min(opts.threads or 2, 2))
    bins = S.check_bins("bins", opts.bins, None)
    n_hist = sum(S.bin_count(bins[q]) for q in ("energy", "x", "y") if q in opts.quantities)
    if "joint" in opts.quantities:
        n_hist += S.bin_count(bins["joint"][0]) * S.bin_count(bins["joint"][1])
    rows = 3 * 8 + 1          # ~3 grid points per phase, 8 phases, and the average
    memory = 150e6 + 48.0 * opts.n_paths + 8.0 * opts.n_batches * (rows * n_hist + M * 10)
    key = "n_periods" if pl["n_periods"] >= pl["burn_periods"] else "burn_periods"
    return Cost(memory, float(path_steps), "path-steps", seconds, key)


def _step_weight(system: VibroImpactSystem, dt: float, sample_every: int) -> float:
    """A path-step's cost relative to the benchmark's (paper case: ~3 % of path-steps
    cross a wall, a sample every 30 steps).

    f = dt / (crossing time) impacts per step: a path-step with an impact runs the
    scalar step, ~10 smooth ones, and each further impact in it ~2; a sample costs
    about one path-step.  Measured (one thread): D1 = 10⁶, r = 0.92 (f = 0.4,
    sampling every 2 steps) 1.3·10⁷ path-steps/s, Δ = 10⁻⁶, r = 1 (f = 8, every
    step) 6·10⁶/s, against 1.5·10⁸/s on the paper case.
    """
    tc = S.time_scales(system).get("crossing time L/v", math.inf)
    f = dt / tc
    w = 1.0 + 10.0 * max(0.0, min(f, 1.0) - 0.03) + 2.0 * max(0.0, f - 1.0)
    if sample_every > 0:
        w += max(0.0, 1.0 / sample_every - 1.0 / 30.0)
    if getattr(system, "external", None) is not None:
        # coloured noise: the OU step of ζ, and with D2 > 0 a second normal a step
        w += 0.6 if system.D2 > 0 else 0.1
    return w
