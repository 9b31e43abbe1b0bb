"""Monte Carlo first passage: the mean time and reliability against the finite-element
solution of the backward equation (paper r = 0.92, H_c = 0.498), reproducibility for
1 and 2 threads, the three kinds of start, censoring and hostile inputs."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, fem
from fpk_vibro import montecarlo as mc

PAPER = VibroImpactSystem.paper(r=0.92)
H_C = 0.498


@pytest.fixture(scope="module")
def fe():
    """FE at its default nx = 24: τ = 80.33 (80.41 at nx = 48, ~80.43 converged)."""
    return fem.first_passage(PAPER, energy=H_C, start=(0.0, 0.0))


@pytest.fixture(scope="module")
def run():
    # default dt (T0/120): bias −0.1 ± 0.03 % of τ (measured against FE with 6 × 2²⁰
    # paths), well inside the 1 % allowed; 2¹⁶ paths give an SE of ~0.4 % in ~1 s
    return mc.first_passage(PAPER, energy=H_C, n_paths=2 ** 16, seed=2024, progress=False)


def test_mean_first_passage_time_agrees_with_fem(run, fe):
    assert run.method == "montecarlo" and run.start == ("point", (0.0, 0.0))
    assert run.energy == H_C and run.info["censored"] == 0.0
    assert 0 < run.mean_se < 0.006 * run.mean
    assert abs(run.mean - fe.mean) <= 3 * run.mean_se + 0.01 * fe.mean, (run.mean, fe.mean)
    assert run.mean_time() == run.mean
    # T is roughly exponential for H_c = 3 E[H]: SE ≈ τ / sqrt(n)
    assert run.mean_se * math.sqrt(run.info["n_paths"]) == pytest.approx(run.mean, rel=0.2)


def test_quantiles_and_survival(run):
    q, ci = run.info["quantiles"], run.info["quantiles_ci"]
    assert set(q) == {0.05, 0.5, 0.95}
    assert 0 < q[0.05] < q[0.5] < run.mean < q[0.95]
    for p in q:
        assert ci[p][0] <= q[p] <= ci[p][1]
    T, R = run.times, run.survival
    assert T[0] == 0.0 and R[0] == 1.0 and R[-1] == 0.0 and np.all(np.diff(R) <= 0)
    # R(median) = 1/2 and ∫ R dt = τ (the empirical survival of the recorded times)
    assert run.reliability(q[0.5]) == pytest.approx(0.5, abs=2e-3)
    area = float(np.sum(0.5 * (R[1:] + R[:-1]) * np.diff(T)))
    assert area == pytest.approx(run.mean, rel=5e-3)
    lo, hi = run.survival_band
    assert np.all(lo <= R) and np.all(R <= hi)
    assert np.max(hi - lo) <= 2 * run.info["band_halfwidth"] + 1e-12
    json.dumps(run.to_dict())
    with pytest.raises(ValueError, match="only"):
        run.mean_time(0.1, 0.0)


def test_reliability_band_contains_the_fem_reliability(run, fe):
    t = np.array([10.0, 30.0, 60.0, 100.0, 160.0, 250.0])
    lo, hi = (np.interp(t, run.times, b) for b in run.survival_band)
    R_fe = fe.reliability(t)
    assert np.all((lo <= R_fe) & (R_fe <= hi)), (lo, R_fe, hi)


def test_step_end_monitoring_alone_is_late():
    """Without the bridge the exits are seen late: τ +8 % at the default dt."""
    kw = dict(energy=H_C, n_paths=2 ** 14, seed=5, progress=False)
    late = mc.first_passage(PAPER, bridge=False, **kw)
    good = mc.first_passage(PAPER, **kw)
    assert late.info["exits_by_bridge"] == 0.0 < good.info["exits_by_bridge"]
    assert late.mean - good.mean > 0.04 * good.mean


def test_crossings_near_the_turning_points_are_caught():
    """A double well started at its saddle: exits near the boundary's turning points
    (y ≈ 0) matter, where a bridge of H alone leaves +2 % at the default dt (and step
    ends alone +22 %); the bridge of y agrees with dt/8 within 3 SE (0.5 %)."""
    dw = VibroImpactSystem(a=-1.0, b=1.0, c=0.1, D1=0.05, delta=1.5)
    kw = dict(energy=0.1, n_paths=2 ** 17, progress=False)
    coarse = mc.first_passage(dw, seed=1, **kw)
    fine = mc.first_passage(dw, seed=2, dt=coarse.info["dt"] / 8, **kw)
    assert coarse.mean / coarse.info["dt"] < 100          # τ is a few dozen steps
    assert abs(coarse.mean - fine.mean) <= 3 * math.hypot(coarse.mean_se, fine.mean_se)


def test_same_seed_same_numbers_for_one_and_two_threads():
    kw = dict(energy=H_C, n_paths=3000, seed=77, progress=False, t_max=150.0)
    with pytest.warns(RuntimeWarning):
        a = mc.first_passage(PAPER, threads=1, **kw)
    with pytest.warns(RuntimeWarning):
        b = mc.first_passage(PAPER, threads=2, **kw)
    assert a.mean == b.mean and a.mean_se == b.mean_se
    assert np.array_equal(a.survival, b.survival) and np.array_equal(a.times, b.times)
    assert a.info["quantiles"] == b.info["quantiles"]
    assert a.info["path_steps"] == b.info["path_steps"]
    with pytest.warns(RuntimeWarning):
        c = mc.first_passage(PAPER, threads=2, **{**kw, "seed": 78})
    assert c.mean != a.mean


def test_censoring_is_reported_and_warned():
    kw = dict(energy=H_C, n_paths=2048, seed=9, progress=False)
    full = mc.first_passage(PAPER, **kw)
    assert full.info["censored"] == 0.0 and full.info["rounds"] >= 1
    with pytest.warns(RuntimeWarning, match="lower bound"):
        cut = mc.first_passage(PAPER, t_max=60.0, **kw)
    frac = cut.info["censored"]
    assert 0.3 < frac < 0.7 and cut.info["n_censored"] == round(frac * 2048)
    assert cut.info["t_max"] == pytest.approx(60.0, abs=cut.info["dt"])
    assert cut.mean < full.mean and cut.times[-1] == cut.info["t_max"]
    assert cut.survival[-1] == pytest.approx(frac)
    assert cut.info["quantiles"][0.95] == math.inf
    assert cut.info["censored_bias_estimate"] > 0
    # R(t) before the horizon is unbiased: both bands hold the other estimate
    t = np.linspace(0.0, 55.0, 12)
    eps = cut.info["band_halfwidth"]
    assert np.all(np.abs(cut.reliability(t) - full.reliability(t)) <= eps)


@pytest.mark.parametrize("start, tol", [({"mean": (0.1, 0.3), "std": (0.1, 0.1)}, 0.02),
                                        ("stationary", 0.02)])
def test_gaussian_and_stationary_starts(start, tol):
    m = mc.first_passage(PAPER, energy=H_C, start=start, n_paths=2 ** 13, seed=3,
                         progress=False, times=[5.0, 500.0])
    f = fem.first_passage(PAPER, energy=H_C, start=start)
    assert m.start[0] == ("gaussian" if isinstance(start, dict) else "stationary")
    assert abs(m.mean - f.mean) <= 3 * m.mean_se + tol * f.mean, (m.mean, f.mean)
    assert 5.0 in m.times
    if start == "stationary":
        info = m.info["stationary_start"]
        assert 0.9 < info["safe_fraction"] < 1.0 and info["t_burn"] >= 9 / PAPER.c


def test_a_start_that_puts_no_mass_inside_is_refused():
    with pytest.raises(ValueError, match="start"):
        mc.first_passage(PAPER, energy=H_C, start={"mean": (0.0, 2.0), "std": (0.0, 0.01)},
                         n_paths=64)
    with pytest.raises(ValueError, match="start"):
        mc.first_passage(PAPER, energy=1e-5, start="stationary", n_paths=64, seed=1)


@pytest.mark.parametrize("kwargs, name", [
    (dict(energy=0.0), "energy"), (dict(energy=-1.0), "energy"),
    (dict(energy=float("nan")), "energy"), (dict(energy=True), "energy"),
    (dict(energy="0.5"), "energy"), (dict(energy=math.inf), "energy"),
    (dict(start=(0.7, 0.0)), "start"), (dict(start=(0.0, 2.0)), "start"),
    (dict(start=(float("nan"), 0.0)), "start[0]"), (dict(start=(0.0, True)), "start[1]"),
    (dict(start="bogus"), "start"), (dict(start=(0.0,)), "start"), (dict(start=True), "start"),
    (dict(start={"mean": (0.0, 0.0)}), "std"),
    (dict(n_paths=1), "n_paths"), (dict(n_paths=True), "n_paths"),
    (dict(n_paths=100.0), "n_paths"), (dict(n_paths=10 ** 12), "n_paths"),
    (dict(dt=0.0), "dt"), (dict(dt=-0.1), "dt"), (dict(dt=float("nan")), "dt"),
    (dict(dt=10.0), "dt"), (dict(dt=True), "dt"),
    (dict(t_max=0.0), "t_max"), (dict(t_max=float("inf")), "t_max"),
    (dict(t_max=1e-3), "t_max"), (dict(t_max=False), "t_max"),
    (dict(seed=-1), "seed"), (dict(seed=1.5), "seed"), (dict(seed=True), "seed"),
    (dict(times=[-1.0]), "times"), (dict(times=True), "times"), (dict(times="10"), "times"),
    (dict(times=[1.0, float("nan")]), "times"), (dict(times=[True]), "times"),
    (dict(threads=0), "threads"), (dict(threads=2.0), "threads"),
    (dict(progress="yes"), "progress"), (dict(bridge=1), "bridge"),
])
def test_hostile_inputs_are_one_line_errors_naming_the_parameter(kwargs, name):
    kw = dict(energy=H_C, n_paths=64, seed=1, progress=False) | kwargs
    with pytest.raises(ValueError) as err:
        mc.first_passage(PAPER, **kw)
    msg = str(err.value)
    assert name in msg and "\n" not in msg, msg


def test_the_system_is_checked():
    with pytest.raises(ValueError, match="system"):
        mc.first_passage("paper", energy=H_C)
