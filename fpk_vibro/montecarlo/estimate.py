"""The error estimate of a Monte Carlo answer: statistics and time-step bias together.

``MonteCarloSolution.error_estimate()`` gives, for E[H], E[x²], E[y²] and P_impact
(relative; P_impact absolute below 1e-3), for the mean time between impacts
(``mean_inter_impact_time``, where the run kept "inter_impact"), the mean energy
one impact removes at each inelastic wall (``mean_impact_energy_left``/``_right``)
and, with coloured external noise, the power E[ζ y] it puts in (``E_zeta_y``,
relative to the larger of |E[ζ y]| and 1e-3 sqrt(E[ζ²] E[y²]): a transient starts
from E[ζ y] = 0), relative::

    estimate = 2 SE + |bias| + 2 SE(bias)

The standard error SE comes from the spread between independent batches of paths.
The time-step bias of the scheme is O(h²) (:mod:`fpk_vibro.montecarlo`), so a
second run at 2 dt with the same paths, times, burn-in and seed family (and, with
coloured noise, the same τ: the scheme's bias is O(h²) uniformly in h/τ, its kicks'
gain κ(h/τ) making their zero-frequency intensity exact, :func:`._params.kick_gain`)
gives
bias(dt) ≈ (m(2 dt) − m(dt)) / 3, with its own standard error
sqrt(SE² + SE₂²) / 3 (taken as independent samples; where the two runs share their
start, as a transient's do, this overstates it).  Where 2 dt is refused (beyond a
stability limit of the system), the second run is at dt/2 and
bias(dt) ≈ 4 (m(dt) − m(dt/2)) / 3.  The second run costs about half (2 dt) or
twice (dt/2) the first.

A transient (:func:`~fpk_vibro.montecarlo.transient`) makes one second transient
run for all its times (the same initial ensemble, times and seed; on the first
estimate asked of any of them, :func:`shared_second_run`).  Each interval between
output times is cut into equal steps, h_j = τ_j / ceil(τ_j / dt), so the second run's
steps h'_j are not always 2 h_j (one step of an interval ≤ dt stays one step).  With
a bias built up evenly over the history, bias(t) ∝ S = Σ τ_j h_j² over the intervals
up to t, and::

    bias(dt) ≈ S / (S − S') × (m(dt) − m'),     S' = Σ τ_j h'_j²

which is −1/3 (2 dt) and 4/3 (dt/2) where every ratio is exact, and the stationary
factor with S = dt², S' = dt'².  At t = 0 (no step: S = 0) the two runs hold the same
initial ensemble and the bias is 0; where S' = S (every interval a single step in
both runs) it cannot be told: the estimate is then 2 SE with ``bias`` NaN.  Assumes
the bias follows its leading order between the two steps.  A partial (interrupted)
run, or a transient read from a file saved before its estimate was made, has no second
run: its estimate is 2 SE with ``bias`` NaN, and ``assumes`` says so.  An estimate made
before saving is kept in the file and returned as made (:meth:`fpk_vibro.Solution.save`).
"""
from __future__ import annotations

import contextvars
import functools
import math
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from .._checks import InputError
from ..keys import JUDGED, moment_scale

__all__ = ["error_estimate", "second_run", "shared_second_run", "bias_factor", "STOPPED",
           "JUDGED", "second_run_label", "interruption_note"]

#: What a member's second-run source gives: (the second run's solution at the same
#: time, the bias factor, "2 dt" or "dt/2", seconds the second run took).
Second = tuple[Any, float, str, float]


def _scale(key: str, value: float) -> float:
    return max(moment_scale(key, value), 1e-300)        # (a zero moment: no division)


def bias_factor(steps: Sequence[tuple[float, float]], steps2: Sequence[float]) -> float:
    """The factor f of bias(dt) ≈ f (m(dt) − m') (module docstring).

    Parameters
    ----------
    steps : sequence of (float, float)
        ``(τ_j, h_j)``: each interval's length and step in the run estimated (one
        pair for a stationary run: any τ > 0 and its dt).
    steps2 : sequence of float
        The second run's step h'_j on the same intervals.

    Returns
    -------
    float
        S / (S − S'); 0 where no step was taken (S = 0: the same ensemble); NaN where
        the two runs took the same steps (S' = S: no bias can be told).
    """
    S = math.fsum(tau * h * h for tau, h in steps)
    S2 = math.fsum(tau * h2 * h2 for (tau, _), h2 in zip(steps, steps2))
    if S == 0.0:
        return 0.0
    if S2 == S:
        return math.nan
    return S / (S - S2)


#: What stops a second run at a step: refused (beyond the stability limit or the
#: budget, InputError) or blown up (non-finite paths, FloatingPointError).
STOPPED = (InputError, FloatingPointError)


def _line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


#: The step of the second run in progress in this context ("2 dt" or "dt/2"), else None.
_SECOND: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "fpk_vibro_montecarlo_second_run", default=None)


def second_run_label() -> str:
    """What a progress line adds within a second run (", bias run at 2 dt"), else ""."""
    step = _SECOND.get()
    return "" if step is None else f", bias run at {step}"


def interruption_note(text: str) -> None:
    """The engine's note on stderr that a signal cut its run short; none within a
    second run, whose estimate says what is kept (:func:`second_run`)."""
    if _SECOND.get() is None:
        print(text, file=sys.stderr)


def _at(run: Callable[[float], Any], h: float, step: str, kept: str) -> Any:
    """``run(h)`` as the second run at ``step``; interrupted, or partial, it raises
    ``KeyboardInterrupt`` after one note that says what is kept."""
    def note() -> None:
        print(f"\n[montecarlo] interrupted during the error estimate's second run (at "
              f"{step}): {kept} is kept, its error estimate not computed", file=sys.stderr)
    token = _SECOND.set(step)
    try:
        other = run(h)
    except KeyboardInterrupt:
        note()
        raise
    finally:
        _SECOND.reset(token)
    if getattr(other, "partial", False):
        note()
        raise KeyboardInterrupt("montecarlo: the error estimate's second run was interrupted")
    return other


def second_run(run: Callable[[float], Any], dt: float, kept: str = "the answer"
               ) -> tuple[Any, str]:
    """``run(2 dt)``, or ``run(dt/2)`` where 2 dt is refused or blows up
    (:data:`STOPPED`); with "2 dt" or "dt/2".

    The second run's progress line (a stationary or transient run shows it where the
    run estimated showed its own) is labelled "bias run at 2 dt"
    (:func:`second_run_label`); its own note on an interruption is not printed (it
    would speak of its samples or times as if they were the answer's).

    Parameters
    ----------
    run : callable
        ``run(dt')``: the run again at step dt'.
    dt : float
        The step of the run estimated.
    kept : str
        What the note after an interruption says is kept.

    Raises
    ------
    InputError
        Where dt/2 is stopped too: one line naming both reasons.
    KeyboardInterrupt
        Where the second run is interrupted, or returns a partial run: no estimate
        is made of a part of it (the answer is unchanged; one note on stderr).
    """
    try:
        return _at(run, 2.0 * dt, "2 dt", kept), "2 dt"
    except STOPPED as coarse:
        try:
            return _at(run, 0.5 * dt, "dt/2", kept), "dt/2"
        except STOPPED as fine:
            raise InputError(f"the second run was refused (2 dt: {_line(coarse)}; dt/2: "
                             f"{_line(fine)})", name="dt") from None


def shared_second_run(run: Callable[[float], Any], dt: float,
                      steps: Sequence[tuple[float, float]]) -> list[Callable[[], Second]]:
    """One source of the second run per time of a transient, all sharing one run.

    Parameters
    ----------
    run : callable
        ``run(dt')``: the same transient at largest step dt' (a list of solutions at
        the same times).
    dt : float
        The largest step of the run estimated.
    steps : sequence of (float, float)
        ``(τ_j, h_j)`` of the run estimated, one per output time (τ = 0 for t = 0).

    Returns
    -------
    list of callable
        The i-th gives :data:`Second` for the i-th time; the run is made on the first
        call of any of them and kept (not kept if it raised or was interrupted:
        ``KeyboardInterrupt``, :func:`second_run`).
    """
    steps = [(float(tau), float(h)) for tau, h in steps]

    @functools.cache
    def once() -> tuple[Any, str, float]:
        t0 = time.perf_counter()
        other, step = second_run(run, dt, kept=f"the answer (all {len(steps)} times)")
        return other, step, time.perf_counter() - t0

    def member(i: int) -> Second:
        other, step, seconds = once()
        f = bias_factor(steps[:i + 1], [o.dt for o in other[:i + 1]])
        return other[i], f, step, seconds

    return [functools.partial(member, i) for i in range(len(steps))]


def _stationary_second(sol) -> Second:
    """The stationary run again at 2 dt (or dt/2), the same paths, times and seed."""
    stationary = type(sol).rerun     # the engine's solver (set by it: no import back)
    kw = dict(n_paths=int(sol.n_paths), t_burn=float(sol.t_burn),
              t_sample=float(sol.t_sample), n_batches=int(sol.n_batches),
              seed=None if sol.seed_entropy is None else int(sol.seed_entropy),
              quantities=("x",) + (("inter_impact",) if "inter_impact" in sol.quantities
                                   else ()),
              progress=getattr(sol, "_progress", False))
    t0 = time.perf_counter()
    other, step = second_run(lambda dt: stationary(sol.system, dt=dt, **kw), sol.dt)
    return other, bias_factor([(1.0, sol.dt)], [other.dt]), step, time.perf_counter() - t0


def _stationary_paired(sol) -> tuple[dict[str, tuple[float, float]], float, str, float]:
    """The paired bias run of a stationary answer (:mod:`._paired`, attached by the
    engine as ``rerun_paired``: no import back up): per figure m(dt) − m(other) and its
    SE, the bias factor, "2 dt" or "dt/2", and the seconds it took."""
    t0 = time.perf_counter()
    step = "2 dt"
    token = _SECOND.set(step)
    try:
        diffs, step = type(sol).rerun_paired(sol, sol._meta.get("device", "cpu"))
    except KeyboardInterrupt:
        print("\n[montecarlo] interrupted during the error estimate's paired bias run: "
              "the answer is kept, its error estimate not computed", file=sys.stderr)
        raise
    finally:
        _SECOND.reset(token)
    dt2 = 2.0 * sol.dt if step == "2 dt" else 0.5 * sol.dt
    return diffs, bias_factor([(1.0, sol.dt)], [dt2]), step, time.perf_counter() - t0


def impact_figures(sol) -> dict[str, tuple[float, float]]:
    """The impact figures an estimate covers besides the moments, as (value, SE):
    ``mean_inter_impact_time`` (where the run kept "inter_impact") and
    ``mean_impact_energy_<wall>`` (each wall that removes energy, where the result
    holds it)."""
    out: dict[str, tuple[float, float]] = {}
    if "inter_impact" in sol.quantities:
        out["mean_inter_impact_time"] = (sol.mean_inter_impact_time(),
                                         sol.mean_inter_impact_time_se())
    imp = sol._meta.get("impacts", {})
    for side, wall in sol.system.walls:
        d = imp.get(side, {})
        if not wall.elastic and "mean_energy" in d and d.get("count", 0) > 0:
            out[f"mean_impact_energy_{side}"] = (d["mean_energy"], d["mean_energy_se"])
    return out


def coloured_figures(sol) -> dict[str, tuple[float, float]]:
    """With coloured external noise: ``E_zeta_y`` (value, SE), the power ζ puts in
    (:meth:`~fpk_vibro.montecarlo.MonteCarloSolution.coloured_moments`); else none."""
    if sol.system.external is None or "coloured" not in sol._meta:
        return {}
    c = sol.coloured_moments()
    return {"E_zeta_y": (c["E_zeta_y"], c["E_zeta_y_se"])}


def _scales(sol, m: dict[str, float], keys: list[str]) -> dict[str, float]:
    """What each figure's error is relative to (module docstring)."""
    out = {k: _scale(k, m[k]) for k in keys}
    if "E_zeta_y" in out:
        c = sol.coloured_moments()
        out["E_zeta_y"] = max(abs(m["E_zeta_y"]),
                              1e-3 * math.sqrt(max(c["E_zeta2"] * m["E_y2"], 0.0)), 1e-300)
    return out


def error_estimate(sol, paired: bool = False) -> dict[str, Any]:
    """The estimate of the module docstring for a :class:`MonteCarloSolution`;
    ``paired`` (stationary): the bias from the paired run of :mod:`._paired` (the
    same Brownian increments at dt and 2 dt) instead of an independent second run.
    Measured (issue 33): pairing cancels the noise ~30× on a linear oscillator but
    hardly at all where impacts or barrier hops decouple the twins (paper case: 0.8 %
    against 0.67 % unpaired), and costs 3–61 s against 0.2–9 s for the answer, so it
    is not the default.

    Returns
    -------
    dict
        The relative estimate of each judged moment, ``bias`` (relative, signed, per
        moment; NaN where not estimated), ``assumes`` and ``seconds`` (the second
        run's time: a transient's is shared by its times).
    """
    m, se = sol.moments(), sol.moments_se()
    keys = [k for k in JUDGED if k in m]
    use_pairs, paired = paired, None
    if sol.time is not None or sol._meta.get("periodic"):
        # a transient or a periodic response: the engine's shared source, if any
        source = getattr(sol, "_second_run", None)
        use_pairs = False
    else:
        second = _stationary_paired if use_pairs else _stationary_second
        source = functools.partial(second, sol) if sol.dt and sol.t_sample else None
    if sol.partial or source is None:
        other, factor, seconds = None, math.nan, 0.0
        assumes = ("2 standard errors only: no second run (an interrupted run, or a "
                   "transient or periodic response read from a file saved before its "
                   "estimate was made), so the time-step bias is not estimated")
    elif sol.time is None and use_pairs:
        paired, factor, step, seconds = source()
        other = None
        assumes = (f"2 standard errors plus the time-step bias from a paired run at dt and "
                   f"{'2 dt' if step == '2 dt' else 'dt/2'} (the same Brownian increments; "
                   "O(dt²) scheme) and twice its standard error from the batch differences")
    else:
        other, factor, step, seconds = source()
        if math.isnan(factor):
            assumes = (f"2 standard errors only: the run at {step} took the same steps "
                       "(every interval up to this time is one step), so the time-step "
                       "bias cannot be told")
        else:
            assumes = (f"2 standard errors plus the time-step bias from a run at {step} "
                       "(O(dt²) scheme) and twice its standard error")
            if sol.time is not None:
                assumes += ("; one second transient for all times, its bias taken as "
                            "built up evenly over the steps so far")
            elif sol._meta.get("periodic"):
                assumes += "; one second periodic run for all phases and the average"
    told = not math.isnan(factor)
    m2, se2 = (other.moments(), other.moments_se()) if other is not None else (m, se)
    figs = impact_figures(sol) | coloured_figures(sol)
    figs2 = (impact_figures(other) | coloured_figures(other)) if other is not None else figs
    for k, (v, e) in figs.items():           # judged like the moments
        if k in figs2 and (paired is None or k in paired):
            keys.append(k)
            m[k], se[k] = v, e
            m2[k], se2[k] = figs2[k]
    if paired is None:                       # two runs: independent noise
        paired = {k: (m[k] - m2[k], math.sqrt(se[k] ** 2 + se2[k] ** 2)) for k in keys}
    out: dict[str, Any] = {}
    bias: dict[str, float] = {}
    scale = _scales(sol, m, keys)
    for k in keys:
        d, d_se = paired.get(k, (0.0, 0.0))
        b = factor * d if told else 0.0
        b_se = abs(factor) * d_se if told else 0.0
        bias[k] = b / scale[k]
        out[k] = (2.0 * se[k] + abs(b) + 2.0 * b_se) / scale[k]
    out.update(bias=bias if told else math.nan, assumes=assumes, seconds=seconds)
    return out
