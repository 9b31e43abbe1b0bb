"""Accuracy of fem.first_passage by default and its error estimate (issues 23, 31).

Converged references: ``fpk_vibro.benchmarks.fem_first_passage.CONVERGED`` (issue 31:
the isoparametric Q2 mesh graded toward walls with r < 1 at nx = 256; the Richardson
extrapolation of nx = 64 and 128 graded as s⁴ agrees within 1e-5 on these; the
references of issue 23 on the ungraded mesh were 1.5e-5 to 2e-5 off where walls have
r < 1; docs/fem_first_passage.md).  τ from (0, 0) unless said: the paper's system
with r = 0.92, c = 0.2, H_c = 0.15; a softening spring b = −0.2, r = 0.5, c = 0.2,
H_c = 0.3 (both walls reached); one wall at 0.6 (r = 0.92, c = 0.2), H_c = 0.25; the
paper's with r = 0.2, c = 0.2, H_c = 0.3; a double well a = −1, b = 1, c = 0.2, one
well, H_c = −0.1 from (1, 0).

R(t) of the paper case at t = 4, 10, 20, 40, 80, 120 and of the softening spring at
t = 40 … 1200 from nx = 128, n_steps = 800 (their own estimates 4.1e-4, 1.2e-4).
"""
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, fem
from fpk_vibro.benchmarks.fem_first_passage import CASES as BENCH, CONVERGED

P = VibroImpactSystem.paper
PAPER = P(r=0.92).replace(c=0.2)
SOFT = P(r=0.5, b=-0.2, c=0.2)
ONE_WALL = P(r=0.92, c=0.2, barriers="right")
R_SMALL = P(r=0.2, c=0.2)
WELLS = VibroImpactSystem(a=-1.0, b=1.0, c=0.2, D1=0.01, D2=0.01, barriers="none")

CASES = {
    "paper": (PAPER, 0.15, (0.0, 0.0), CONVERGED["paper c=0.2 H_c=0.15"][0]),
    "soft": (SOFT, 0.3, (0.0, 0.0), CONVERGED["softening b=-0.2 r=0.5"][0]),
    "one_wall": (ONE_WALL, 0.25, (0.0, 0.0), CONVERGED["one wall at 0.6"][0]),
    "r_small": (R_SMALL, 0.3, (0.0, 0.0), CONVERGED["r=0.2 H_c=0.3"][0]),
    "wells": (WELLS, -0.1, (1.0, 0.0), CONVERGED["double well, one well"][0]),
}
T_PAPER = np.array([4.0, 10.0, 20.0, 40.0, 80.0, 120.0])
R_PAPER = np.array([0.9850254, 0.8545445, 0.6347263, 0.3481928, 0.1047750, 0.0315279])
T_SOFT = np.array([40.0, 100.0, 200.0, 400.0, 800.0, 1200.0])
R_SOFT = np.array([0.9266752, 0.8004756, 0.6271287, 0.3849205, 0.1450118, 0.0546306])


def test_the_systems_are_the_benchmarks():
    """The systems here are those CONVERGED holds references for."""
    names = ["paper c=0.2 H_c=0.15", "softening b=-0.2 r=0.5", "one wall at 0.6",
             "r=0.2 H_c=0.3", "double well, one well"]
    for case, name in zip(CASES.values(), names):
        assert case[:3] == BENCH[name], name


def solve(name, **kw):
    system, H_c, start, ref = CASES[name]
    return fem.first_passage(system, energy=H_c, start=start, **kw), ref


@pytest.mark.parametrize("name", ["paper", "soft", "r_small", "wells"])
def test_default_within_0p2_percent(name):
    """Measured at the default nx = 32: 5e-6, 1.0e-4, 1.3e-4, 5.5e-5 (before the
    wall grading of issue 31: 4.5e-5, 2.9e-4, 5.1e-4, 6e-5; 3.6e-3 on the paper case
    with the uniform straight-edged mesh at nx = 24)."""
    fp, ref = solve(name)
    assert abs(fp.mean / ref - 1.0) < 2e-3
    est = fp.error_estimate()
    assert abs(fp.mean / ref - 1.0) <= 2.0 * est["mean_time"]


@pytest.mark.parametrize("name, nxs", [("paper", (32, 64)), ("soft", (32,)),
                                       ("one_wall", (32,))])
def test_mean_time_estimate_effectivity(name, nxs):
    """true / estimate in [1/30, 2]; measured paper 0.12, 0.39, soft 0.17, one wall
    0.08 (the two-level estimate alone: soft 12 at nx = 32; at nx = 16, where the
    estimate is the two fine levels alone, 0.02–4: not asserted)."""
    for nx in nxs:
        fp, ref = solve(name, nx=nx)
        true = abs(fp.mean / ref - 1.0)
        est = fp.error_estimate()["mean_time"]
        assert est / 30.0 <= true <= 2.0 * est, (nx, true, est)


@pytest.mark.parametrize("name, nx", [("paper", 32), ("soft", 16), ("soft", 32)])
def test_reliability_estimate_effectivity(name, nx):
    """Measured true / estimate: paper 0.22 (nx = 32), softening 0.24, 0.16."""
    times, ref = (T_PAPER, R_PAPER) if name == "paper" else (T_SOFT, R_SOFT)
    fp, _ = solve(name, nx=nx, times=times)
    true = float(np.max(np.abs(fp.reliability(times) - ref)))
    est = fp.error_estimate()["reliability"]
    assert est / 30.0 <= true <= 2.0 * est, (true, est)


@pytest.mark.parametrize("name", ["one_wall", "wells"])
def test_convergence_order(name):
    """Orders 4.9 (one wall) and 3.7 (double well) from nx = 8, 16, 32 (the
    straight-edged uniform mesh: erratic, 38.30, 38.22, 38.12 at nx = 12, 24, 48 on
    the paper case, which is now within 4e-5 from nx = 8 on: no order to see)."""
    tau = [solve(name, nx=nx, n_steps=40)[0].mean for nx in (8, 16, 32)]
    order = np.log2(abs(tau[1] - tau[0]) / abs(tau[2] - tau[1]))
    assert order > 1.7, tau


def test_rtol_refines_until_met():
    fp, ref = solve("soft", nx=8, rtol=3e-3)
    est = fp.error_estimate()
    assert fp.info["rtol_met"] and fp.info["nx"] > 8
    assert est["mean_time"] <= 3e-3 and est["reliability"] <= 3e-3
    assert abs(fp.mean / ref - 1.0) <= 3e-3
    assert "assumes" in est and est["levels"][-1][0] == fp.info["nx"]
    assert fp.info["nx"] >= 32       # the three-level estimate


def test_estimate_of_other_methods():
    """A result built by hand: averaging's model error against the FE first passage of
    the same system, energy and start (here τ = 38.0 is the converged value, so it is
    about FE's own estimate); Monte Carlo without its run's step and seed: 2 SE only."""
    import math
    from fpk_vibro.first_passage import FirstPassage
    av = FirstPassage("averaging", PAPER, 0.15, ("point", (0.0, 0.0)), 38.0, 0.0,
                      np.array([0.0, 1.0]), np.array([1.0, 0.9]))
    est = av.error_estimate()
    assert abs(38.0 / 38.0770 - 1.0) <= est["mean_time"] <= 0.01
    assert "default accuracy" in est["reference"]
    mc = FirstPassage("montecarlo", PAPER, 0.15, ("point", (0.0, 0.0)), 38.0, 0.5,
                      np.array([0.0, 1.0]), np.array([1.0, 0.9]))
    mc_est = mc.error_estimate()
    assert mc_est["mean_time"] == pytest.approx(2.0 * 0.5 / 38.0)
    assert math.isnan(mc_est["bias"]) and "2 standard errors only" in mc_est["assumes"]
