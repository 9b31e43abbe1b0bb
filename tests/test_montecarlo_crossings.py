"""Counted level crossings and peaks (issue 36): ``montecarlo.crossings``.

Exact references: Rice's formula for a Gaussian stationary x (the linear oscillator,
white or coloured: x and y independent at one time), ν⁺(b) = σ_y/(2π σ_x)
exp(−b²/(2σ_x²)), and the Gibbs density p ∝ exp(−(c/D1) H) for r = 1, D2 = 0 with
walls, whose velocity is N(0, D1/c) independent of x, so ν⁺(b) = p_x(b) sqrt(D1/c)/√(2π).
Identities: ν⁺ at a wall is that wall's impact rate (count by count); every counted
peak above b > m follows an up-crossing of b.  The CUDA kernel runs on numba's
simulator (tiny runs) against the CPU kernel.
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

if "numba.cuda" not in sys.modules:
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

from fpk_vibro import OrnsteinUhlenbeck, VibroImpactSystem, Wall  # noqa: E402
from fpk_vibro._checks import InputError  # noqa: E402
from fpk_vibro.exact import gibbs  # noqa: E402
from fpk_vibro.forcing import Harmonic  # noqa: E402
from fpk_vibro.linear import stationary_covariance  # noqa: E402
from fpk_vibro.montecarlo import CrossingRates, crossings  # noqa: E402
from fpk_vibro.montecarlo import _kernel as K  # noqa: E402
from fpk_vibro.montecarlo import _setup as S  # noqa: E402
from fpk_vibro.montecarlo._device import simulator  # noqa: E402
from fpk_vibro.montecarlo._paths import Paths  # noqa: E402
from fpk_vibro.restitution import Restitution  # noqa: E402

SIM = simulator() and ("numba.cuda" not in sys.modules
                       or sys.modules["numba.cuda"].config.ENABLE_CUDASIM)
needs_sim = pytest.mark.skipif(not SIM, reason="numba.cuda was imported before this module "
                               "could switch on the CUDA simulator")
GIBBS = VibroImpactSystem.paper(r=1.0, D2=0.0)
LINEAR = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none")
QUIET = dict(progress=False)


def gaussian_rate(system, b):
    cov = stationary_covariance(system)
    sx, sy = math.sqrt(cov[0, 0]), math.sqrt(cov[1, 1])
    return sy / (2.0 * math.pi * sx) * np.exp(-np.asarray(b) ** 2 / (2.0 * cov[0, 0])), sx


@pytest.mark.parametrize("external", [None, 0.3])
def test_linear_rates_are_rices_gaussian_formula(external):
    """White and coloured (OU, τ = 0.3) external noise: ν⁺(b) within 3.5 SE + 0.3 % of
    the exact Gaussian rate at levels from −1 to 2.5 σ_x."""
    system = LINEAR if external is None else LINEAR.replace(
        external=OrnsteinUhlenbeck(tau=external))
    _, sx = gaussian_rate(system, 0.0)
    b = sx * np.array([-1.0, 0.0, 0.5, 1.0, 1.8, 2.5])
    c = crossings(system, b, seed=11, n_paths=256, n_batches=16, t_sample=1500.0, **QUIET)
    exact, _ = gaussian_rate(system, b)
    assert np.all(np.abs(c.upcrossing_rate - exact) <= 3.5 * c.upcrossing_rate_se
                  + 3e-3 * exact)
    assert np.all(c.upcrossing_rate_se < 0.05 * exact)            # the check has teeth
    assert c.mean_level == 0.0
    assert c.excursion_rate == pytest.approx(c.upcrossing_rate[1], rel=1e-3)


def test_gibbs_rates_with_walls_and_the_impact_identity():
    """r = 1, D2 = 0, walls at ±0.6: ν⁺(b) = p_x(b) sqrt(D1/c)/√(2π) within 3.5 SE at
    interior levels and at both walls, where the count equals the impact count (up to
    grazes and double touches: 1e-3); peaks above b never outnumber the crossings."""
    system = GIBBS
    g = gibbs(system)
    b = np.array([-0.6, -0.45, 0.0, 0.3, 0.5, 0.59, 0.6])
    c = crossings(system, b, seed=5, n_paths=256, n_batches=16, t_sample=2500.0, **QUIET)
    exact = g.pdf_x(b) * math.sqrt(system.D1 / system.c) / math.sqrt(2.0 * math.pi)
    z = (c.upcrossing_rate - exact) / c.upcrossing_rate_se
    assert np.all(np.abs(z) < 3.5), z
    assert c.upcrossing_rate[-1] == pytest.approx(c.impact_rate["right"], rel=1e-3)
    assert c.upcrossing_rate[0] == pytest.approx(c.impact_rate["left"], rel=1e-3)
    assert c.impact_rate["right"] == pytest.approx(exact[-1], abs=3.5 * c.impact_rate_se["right"])
    above = b > c.mean_level
    t = c.info["t_sample"] * c.info["n_paths"]
    assert np.all(np.round(c.peak_rate[above] * t) <= np.round(c.upcrossing_rate[above] * t))
    assert c.peak_rate[-1] > 0.95 * c.upcrossing_rate[-1]       # high level: one each
    assert np.all(c.peak_rate[~above] == c.peak_rate[2])          # below m: every peak
    assert c.peak_rate[2] <= c.excursion_rate


def test_the_paths_are_the_stationary_engines():
    """The path kernel takes the engine's very step: the same seed and start give the
    same states bit for bit as ``_kernel.advance`` (walls, a tanh law, D2 > 0)."""
    law = Restitution.tanh(0.9, 0.3, 0.5)
    system = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.02,
                               left=Wall(-0.5, r=law), right=Wall(0.4, r=0.8))
    make = dict(n_paths=150, n_batches=2, dt=0.05, seed=3, max_impacts=64, threads=1,
                device="cpu")
    P, Q = Paths(system, **make), Paths(system, **make)
    P.count_from_here(np.array([-0.5, 0.0, 0.4]), 0.0)
    out = np.empty((150, 30))
    P.advance(300, 10, out)
    none = S.Histograms(system, (), S.check_bins("bins", 10, None), 2, 1.0)
    mom, imp = np.zeros((2, K.NM)), np.zeros((2, 2))
    xext, wimp = np.tile([np.inf, -np.inf], (2, 1)), np.zeros((2, 2, K.NW))
    K.advance(Q.xs, Q.ys, Q.rng, Q.starts, 300, 0, 0, Q.p, Q.ip, mom, imp, xext, none.hH,
              none.hx, none.hy, none.hj, threads=1, walls=wimp, law=Q.law)
    assert np.array_equal(P.xs, Q.xs) and np.array_equal(P.ys, Q.ys)
    assert np.array_equal(P.rng, Q.rng)
    assert np.array_equal(P.wcnt[:, :2], wimp[:, :, 0]) and wimp.sum() > 0
    assert np.array_equal(out[:, -1], P.xs)
    assert P.cnt[:, 2] == pytest.approx(P.wcnt[:, 1], abs=2)     # arrivals at x = 0.4


def test_crossings_counted_at_every_step_not_from_samples():
    """Counted from the scheme's vertices: at least the crossings of the step ends
    sampled at every step, and at most a few per cent more (the midpoints)."""
    system = GIBBS.replace(r=0.8)
    P = Paths(system, n_paths=64, n_batches=4, dt=0.05, seed=9, max_impacts=64,
              threads=None, device="cpu")
    lev = np.array([-0.3, 0.1, 0.45])
    P.count_from_here(lev, 0.0)
    x0 = P.xs.copy()
    out = np.empty((64, 4000))
    P.advance(4000, 1, out)
    path = np.concatenate([x0[:, None], out], axis=1)
    ends = np.array([np.sum((path[:, :-1] < b) & (path[:, 1:] >= b)) for b in lev])
    counted = P.cnt[:, :3].sum(axis=0)
    assert np.all(counted >= ends) and np.all(counted <= 1.05 * ends)
    assert counted.min() > 500


def test_asymmetric_walls_take_the_pilot_mean():
    """Walls at −0.3 and 0.6 (r = 1, D2 = 0): the excursions are about the pilot run's
    E[x], close to the Gibbs mean; the rates stay the Gibbs ones."""
    system = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, left=Wall(-0.3, r=1.0),
                               right=Wall(0.6, r=1.0))
    g = gibbs(system)
    c = crossings(system, [0.2, 0.6], seed=2, n_paths=256, n_batches=16, t_sample=1500.0,
                  **QUIET)
    assert c.mean_level == pytest.approx(g.mean_x(), abs=0.02)
    assert c.mean_level != 0.0
    exact = g.pdf_x(np.array([0.2, 0.6])) * math.sqrt(system.D1 / system.c / (2 * math.pi))
    assert np.all(np.abs(c.upcrossing_rate - exact) <= 3.5 * c.upcrossing_rate_se)


def test_speed_dependent_restitution_keeps_the_identity():
    law = Restitution.tanh(0.95, 0.4, 0.3)
    system = VibroImpactSystem.paper(r=law)
    c = crossings(system, [-0.6, 0.6], seed=4, n_paths=128, n_batches=8, t_sample=500.0,
                  **QUIET)
    assert c.upcrossing_rate == pytest.approx([c.impact_rate["left"], c.impact_rate["right"]],
                                              rel=2e-3)


def test_same_seed_same_counts_and_files_round_trip(tmp_path):
    kw = dict(seed=7, n_paths=64, n_batches=8, t_sample=200.0, **QUIET)
    a = crossings(GIBBS, [0.6, 0.0, 0.3], **kw)
    b = crossings(GIBBS, [0.6, 0.0, 0.3], threads=1, **kw)
    assert np.array_equal(a.upcrossing_rate, b.upcrossing_rate)
    assert np.array_equal(a.peak_rate, b.peak_rate)
    assert a.upcrossing_rate[0] < a.upcrossing_rate[2] < a.upcrossing_rate[1]  # given order
    for name in ("c.npz", "c.json"):
        p = a.save(tmp_path / name)
        back = CrossingRates.load(p)
        for k in ("levels", "upcrossing_rate", "upcrossing_rate_se", "peak_rate"):
            assert np.array_equal(getattr(back, k), getattr(a, k))
        assert back.impact_rate == a.impact_rate and back.system == a.system
        assert back.mean_level == a.mean_level
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "something else"}')
    with pytest.raises(InputError, match="bad.json") as e:
        CrossingRates.load(bad)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("levels, match", [
    ([0.0, 0.7], "within the strip"), ([math.nan], "levels"), ([], "levels"),
    ("0.1", "levels"), (np.linspace(-0.5, 0.5, 200), "levels"), ([[0.1, 0.2]], "levels")])
def test_bad_levels_are_one_line(levels, match):
    with pytest.raises(InputError, match=match) as e:
        crossings(GIBBS, levels, seed=1)
    assert "\n" not in str(e.value) and "montecarlo.crossings" in str(e.value)


@pytest.mark.parametrize("kw, name", [
    (dict(seed=-1), "seed"), (dict(seed="a"), "seed"), (dict(n_paths=1), "n_paths"),
    (dict(dt=5.0), "dt"), (dict(t_sample=-1.0), "t_sample"), (dict(bias_run=1), "bias_run"),
    (dict(device="gpu"), "device")])
def test_bad_options_are_one_line(kw, name):
    with pytest.raises(InputError) as e:
        crossings(GIBBS, [0.0], **kw)
    assert e.value.name == name and "\n" not in str(e.value)
    assert str(e.value).startswith("montecarlo.crossings")


def test_a_forced_system_is_refused():
    forced = GIBBS.replace(forcing=Harmonic(amplitude=0.1, frequency=1.0))
    with pytest.raises(InputError, match="montecarlo.crossings: does not handle harmonic"):
        crossings(forced, [0.0])


@needs_sim
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_gpu_simulator_counts_agree_with_the_cpu():
    """Tiny run on the simulator: the wall identity exactly as on the CPU, and the
    rates within 4 combined SE of a CPU run (different streams)."""
    system = GIBBS.replace(r=0.9)
    lev = [-0.6, 0.0, 0.35, 0.6]
    kw = dict(seed=3, n_batches=4, t_sample=40.0, t_burn=20.0, **QUIET)
    gpu = crossings(system, lev, device="cuda", n_paths=8, **kw)
    cpu = crossings(system, lev, n_paths=256, n_batches=8, seed=3, t_sample=600.0, **QUIET)
    assert gpu.info["device"] != "cpu"
    assert gpu.upcrossing_rate[-1] == pytest.approx(gpu.impact_rate["right"], rel=0.02)
    assert gpu.upcrossing_rate[0] == pytest.approx(gpu.impact_rate["left"], rel=0.02)
    se = np.hypot(gpu.upcrossing_rate_se, cpu.upcrossing_rate_se)
    assert np.all(np.abs(gpu.upcrossing_rate - cpu.upcrossing_rate) <= 4.0 * se)
    assert gpu.upcrossing_rate.min() > 0
    assert abs(gpu.excursion_rate - cpu.excursion_rate) <= 4.0 * math.hypot(
        gpu.excursion_rate_se, cpu.excursion_rate_se)


@needs_sim
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_gpu_simulator_coloured_parametric_one_wall():
    """The GPU kernel's coloured branch (OU force, D2 > 0, one wall at 0.3): the wall
    identity, the pilot mean, and the rate at 0 within 4 combined SE of the CPU's."""
    system = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.01,
                               right=Wall(0.3, r=0.8), barriers="right",
                               external=OrnsteinUhlenbeck(tau=0.2))
    gpu = crossings(system, [0.0, 0.3], device="cuda", seed=1, n_paths=8, n_batches=4,
                    t_sample=30.0, t_burn=10.0, **QUIET)
    cpu = crossings(system, [0.0, 0.3], seed=1, n_paths=256, n_batches=8, t_sample=400.0,
                    **QUIET)
    assert gpu.upcrossing_rate[1] == pytest.approx(gpu.impact_rate["right"], rel=0.02)
    assert gpu.mean_level < -0.1 and cpu.mean_level < -0.1      # the wall pushes it left
    assert abs(gpu.upcrossing_rate[0] - cpu.upcrossing_rate[0]) <= 4.0 * math.hypot(
        gpu.upcrossing_rate_se[0], cpu.upcrossing_rate_se[0])
