"""Monte Carlo's error estimate, 2 SE + |bias| + 2 SE(bias)
(fpk_vibro/montecarlo/estimate.py), checked against references it does not see.

- stationary: on ten systems drawn at random (two of each kind: single well,
  double well with walls outside the wells, softening spring, one wall, asymmetric
  walls; parametric noise, r down to 0.3; the default step or four times it) the
  estimate covers the true error, against a converged FE density, on ≥ 90 % of
  E[H], E[x²], E[y²], P_impact;
- transient: one second transient at 2 dt, shared by all the times; the estimate
  covers the error against an FE transient on ≥ 90 % of the moments, and at a
  coarse step, where 2 SE alone does not, against a long Monte Carlo run at dt/8;
- the bookkeeping: one second run for all times, t = 0, dt/2 where 2 dt is refused,
  a sampler initial, an interrupted run, a pickled copy.
"""
from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fpk_vibro import VibroImpactSystem, fem, montecarlo
from fpk_vibro.keys import JUDGED, moment_scale
from fpk_vibro.model import Wall
from fpk_vibro.montecarlo import _engine
from fpk_vibro.montecarlo import _setup as S

KINDS = ("single", "double", "softening", "one-sided", "asymmetric")


def _true(m, ref, k):
    """The true error as the estimate states it: relative (P_impact absolute below 1e-3)."""
    return abs(m[k] - ref[k]) / moment_scale(k, ref[k])


def _coverage(rows):
    """rows: (label, true, estimate); the fraction covered and the misses."""
    misses = [r for r in rows if not r[1] <= r[2]]
    return 1.0 - len(misses) / len(rows), misses


@st.composite
def systems(draw, kind):
    """A system of the given kind with drawn damping, noise and restitution, and a step
    multiplier (1: the default dt; 4: four times it, clipped below the stability
    limit, where the bias is a visible part of the estimate)."""
    c = draw(st.sampled_from([0.05, 0.1, 0.2]))
    D1 = draw(st.sampled_from([0.01, 0.02, 0.05]))
    D2 = draw(st.sampled_from([0.0, 0.02, 0.05]))
    r = draw(st.floats(0.3, 1.0))
    coarse = draw(st.sampled_from([1, 4]))
    if kind == "single":
        s = VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, delta=0.4, r=r)
    elif kind == "double":      # wells at ±1, barrier 1/4, the walls beyond the wells
        s = VibroImpactSystem(a=-1.0, b=1.0, c=c, D1=2 * D1 + 0.02, D2=D2,
                              delta=draw(st.sampled_from([1.4, 2.0])), r=r)
    elif kind == "softening":   # G has its maximum at |x| = √2, beyond the walls
        s = VibroImpactSystem(a=1.0, b=-0.5, c=c, D1=D1, D2=D2, delta=0.8, r=r)
    elif kind == "one-sided":
        s = VibroImpactSystem(a=1.0, b=0.5, c=c, D1=D1, D2=D2, delta=0.3, r=r,
                              barriers=draw(st.sampled_from(["left", "right"])))
    else:
        s = VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, left=Wall(-0.5, r),
                              right=Wall(0.3, min(1.0, r + 0.3)))
    return s, coarse


@settings(max_examples=1, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(st.tuples(*(systems(kind) for kind in KINDS * 2)))
def test_stationary_estimate_covers_systems_drawn_at_random(draws):
    """One derandomized draw of ten systems, two per kind, judged together: coverage
    is a fraction over all their moments, so the draw is one example (max_examples=1)
    and ``assume`` rejects the all-simplest tuple Hypothesis tries first (its two
    systems per kind are equal), so the list judged is Hypothesis's first random one.
    Each system runs by default (target_rse 0.005) at the default step or four times
    it (below 0.9 × the stability limit; there 2 dt may be refused and the bias run is
    at dt/2).  Reference: Q4 FE on 48 wall-graded cells (~1e-5).  Passes when the
    estimate covers the true error on ≥ 90 % of the moments; measured 40 of 40,
    true / estimate 0.002–0.76 (median 0.22), where 2 SE alone covers 29 of 40."""
    assume(len({repr(d) for d in draws}) == len(draws))
    rows = []
    for seed, (s, coarse) in enumerate(draws):
        dt = min(coarse * S.default_dt(s, None), 0.9 * S.dt_limit(s))
        sol = montecarlo.stationary(s, dt=dt, seed=seed, progress=False)
        est = sol.error_estimate()
        assert "2 dt" in est["assumes"] or "dt/2" in est["assumes"]
        assert all(math.isfinite(est["bias"][k]) for k in est["bias"])
        ref = fem.stationary(s, degree=4, nx=48, wall_grading=2.0,
                             positivity=False).moments()
        m = sol.moments()
        rows += [((seed, coarse, k), _true(m, ref, k), est[k]) for k in JUDGED if k in m]
    frac, misses = _coverage(rows)
    assert frac >= 0.9, misses


TRANSIENT_CASES = [
    (VibroImpactSystem(a=1.0, b=0.2, c=0.2, D1=0.01, D2=0.05, left=Wall(-0.4, 0.6),
                       right=Wall(0.5, 0.95)), {"mean": (0.2, 0.0), "std": (0.05, 0.2)}),
    (VibroImpactSystem(a=1.0, b=-0.5, c=0.1, D1=0.02, D2=0.02, delta=0.8, r=0.7),
     {"mean": (0.3, 0.0), "std": (0.1, 0.1)}),
]
TIMES = [0.0, 1.0, 3.0, 8.0]


@pytest.mark.long
def test_transient_estimate_covers_an_fe_transient():
    """Asymmetric walls with parametric noise, and a softening spring: 16384 paths at
    the default step and at four times it, estimates at t = 1, 3, 8 against an FE
    transient (rtol 5e-3: its own estimate ≤ 0.2 %, a tenth of Monte Carlo's).  Passes
    when ≥ 90 % of the 48 moments are covered; measured 47 of 48, true / estimate
    median 0.28, the miss 1.09 (E[H] of the walls at t = 8, four times the step: 2 SE
    1.1 %, the true error 2.2 %)."""
    rows = []
    for i, (s, init) in enumerate(TRANSIENT_CASES):
        ref = fem.transient(s, initial=init, times=TIMES[1:], rtol=5e-3, progress=False)
        for coarse in (1, 4):
            dt = coarse * S.default_dt(s, None)
            run = montecarlo.transient(s, initial=init, times=TIMES, n_paths=16384, dt=dt,
                                       seed=10 * i + coarse, progress=False)
            for sol, fe in zip(run[1:], ref):
                est, m, mr = sol.error_estimate(), sol.moments(), fe.moments()
                assert "2 dt" in est["assumes"]
                rows += [((i, coarse, sol.time, k), _true(m, mr, k), est[k])
                         for k in JUDGED if k in m]
    frac, misses = _coverage(rows)
    assert frac >= 0.9, misses


def test_transient_bias_is_what_covers_a_coarse_step():
    """The paper's system at six times the default step (dt ≈ 0.3, bias ~1–3 %),
    2¹⁸ paths (SE ≈ 0.1–0.4 %), against 2¹⁹ paths at dt/8 (bias 1/64 of it): 2 SE
    alone covers at most half the 12 moments at t = 1, 3, 8 (measured 3 of 12), the
    estimate with the bias ≥ 90 % of them (measured 12 of 12, true / estimate ≤ 0.74).
    At eight times (the second run at 0.81, near the stability limit 0.91) E[x²] at
    t = 3 is missed (true / estimate 1.2–1.4): the bias is no longer in its leading
    order there."""
    s = VibroImpactSystem.paper()
    init = {"mean": (0.0, 0.5), "std": (0.1, 0.1)}
    dt = 6 * S.default_dt(s, None)
    run = montecarlo.transient(s, initial=init, times=TIMES, n_paths=1 << 18, dt=dt,
                               seed=5, quantities=(), progress=False)
    ref = montecarlo.transient(s, initial=init, times=TIMES, n_paths=1 << 19, dt=dt / 8,
                               seed=6, quantities=(), progress=False)
    with_bias, se_only = [], []
    for sol, fine in zip(run[1:], ref[1:]):
        est, m, se = sol.error_estimate(), sol.moments(), sol.moments_se()
        mr = fine.moments()
        for k in JUDGED:
            true = _true(m, mr, k)
            with_bias.append(((sol.time, k), true, est[k]))
            se_only.append(((sol.time, k), true, 2 * se[k] / moment_scale(k, mr[k])))
    frac, misses = _coverage(with_bias)
    assert frac >= 0.9, misses
    assert _coverage(se_only)[0] <= 0.5, se_only


def test_one_second_transient_for_all_times(monkeypatch):
    """The bias run is made once, on the first estimate asked of any time, with the
    same initial ensemble (t = 0: bias exactly 0, estimate 2 SE); a sampler initial
    works; a pickled copy keeps an estimate made, or says it has none."""
    calls = []
    real = _engine.transient

    def counted(*args, **kw):
        calls.append(kw.get("dt"))
        return real(*args, **kw)

    monkeypatch.setattr(_engine, "transient", counted)
    s = VibroImpactSystem.paper(r=0.7)

    def sampler(n, rng):
        return rng.uniform(-0.5, 0.5, n), rng.normal(0.0, 0.3, n)

    for init in ({"mean": (0.1, 0.2), "std": (0.1, 0.1)}, sampler):
        calls.clear()
        run = montecarlo.transient(s, initial=init, times=[0.0, 0.5, 2.0], dt=0.05,
                                   n_paths=512, seed=3, progress=False)
        copy = pickle.loads(pickle.dumps(run[1]))
        ests = [sol.error_estimate() for sol in reversed(run)]
        assert calls == [0.1]            # (the public name is not patched): one at 2 dt
        last, first = ests[0], ests[-1]
        assert first["bias"] == {k: 0.0 for k in first["bias"]}
        se = run[0].moments_se()
        assert first["E_H"] == pytest.approx(2 * se["E_H"] / run[0].moments()["E_H"])
        assert all(math.isfinite(v) for v in last["bias"].values())
        assert "2 dt" in last["assumes"] and "one second transient" in last["assumes"]
        assert len({e["seconds"] for e in ests}) == 1
        assert last["E_H"] > 2 * run[-1].moments_se()["E_H"] / run[-1].moments()["E_H"]
        assert math.isnan(copy.error_estimate()["bias"])
        assert "not estimated" in copy.error_estimate()["assumes"]
        assert pickle.loads(pickle.dumps(run[1])).error_estimate() == ests[1]


def test_transient_bias_at_half_dt_where_two_dt_is_refused():
    s = VibroImpactSystem.paper(r=0.7)
    dt = 0.9 * S.dt_limit(s)
    run = montecarlo.transient(s, initial={"mean": (0.1, 0.2), "std": (0.1, 0.1)},
                               times=[2.0, 4.0], dt=dt, n_paths=512, seed=4, progress=False)
    est = run[-1].error_estimate()
    assert "dt/2" in est["assumes"]
    assert all(math.isfinite(v) for v in est["bias"].values())


def test_steps_no_coarser_in_the_second_run_leave_the_bias_untold():
    """Times closer than dt: every interval is one step in both runs (h' = h)."""
    run = montecarlo.transient(VibroImpactSystem.paper(), initial={"mean": (0.1, 0.2),
                               "std": (0.1, 0.1)}, times=[0.01, 0.02], n_paths=256, seed=1,
                               progress=False)
    est = run[-1].error_estimate()
    assert np.isnan(est["bias"]) and "cannot be told" in est["assumes"]
    m, se = run[-1].moments(), run[-1].moments_se()
    assert est["E_x2"] == pytest.approx(2 * se["E_x2"] / m["E_x2"])


def test_an_interrupted_transient_keeps_two_standard_errors(monkeypatch):
    from fpk_vibro.montecarlo import _kernel

    real = _kernel.advance
    seen = {"n": 0}

    def interrupted(*args, **kwargs):
        seen["n"] += 1
        if seen["n"] > 1:                # during the second interval
            raise KeyboardInterrupt
        real(*args, **kwargs)

    monkeypatch.setattr(_kernel, "advance", interrupted)
    run = montecarlo.transient(VibroImpactSystem.paper(), initial={"mean": (0.1, 0.2),
                               "std": (0.1, 0.1)}, times=[0.5, 1.0], n_paths=256, seed=1,
                               progress=False)
    assert run.partial and len(run) == 1
    est = run[0].error_estimate()
    assert math.isnan(est["bias"]) and "interrupted" in est["assumes"]
    m, se = run[0].moments(), run[0].moments_se()
    assert est["E_H"] == 2 * se["E_H"] / m["E_H"]


def test_a_second_run_that_blows_up_falls_back_to_half_the_step(monkeypatch):
    """Non-finite paths at 2 dt (FloatingPointError) are a refusal like a stability
    limit: the second run is at dt/2; stopped there too, one InputError names both
    (which a scene run records as not computed, keeping the answer)."""
    from fpk_vibro._checks import InputError
    from fpk_vibro.montecarlo.solution import MonteCarloSolution
    sol = montecarlo.stationary(VibroImpactSystem.paper(), n_paths=256, t_sample=20.0,
                                seed=5, progress=False)
    real, steps = MonteCarloSolution.rerun, []

    def blows_up_above(limit):
        def rerun(system, *, dt, **kw):
            steps.append(dt)
            if dt > limit:
                raise FloatingPointError("montecarlo.stationary: non-finite states")
            return real(system, dt=dt, **kw)
        return staticmethod(rerun)
    monkeypatch.setattr(MonteCarloSolution, "rerun", blows_up_above(sol.dt))
    est = sol.error_estimate()
    assert steps == [2 * sol.dt, sol.dt / 2] and "dt/2" in est["assumes"]
    assert all(math.isfinite(est["bias"][k]) for k in ("E_H", "E_x2", "E_y2"))
    other = montecarlo.stationary(VibroImpactSystem.paper(), n_paths=256, t_sample=20.0,
                                  seed=6, progress=False)
    monkeypatch.setattr(MonteCarloSolution, "rerun", blows_up_above(0.0))
    with pytest.raises(InputError, match=r"2 dt: .*non-finite.*; dt/2: .*non-finite") as exc:
        other.error_estimate()
    assert "\n" not in str(exc.value)
