"""Fast transients: the default adaptive BDF2 against the stored packet reference, and
the positivity-preserving exponential integrator (fpk_vibro.fem.transient.exponential).

The default (Q2, nx = 48, 20 661 DOFs, adaptive BDF2 on a ladder of factorised step
matrices) runs the whole packet here; its seconds are the benchmark
``fpk-vibro bench fem-transient``, not a test."""
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem
from fpk_vibro.benchmarks.fem_transient import PACKET, TIMES, relative_errors
from fpk_vibro.fem.exponential import exponential
from fpk_vibro.fem.transient import discretise, transient

SMOOTH = {"mean": (0.1, 0.3), "std": (0.15, 0.3)}


@pytest.fixture(scope="module")
def paper92():
    return VibroImpactSystem.paper(r=0.92)


def l1(disc, p, q):
    return float(disc.unit @ np.abs(p - q))


def test_default_meets_the_packet_reference_to_0_1_percent(paper92):
    """Measured: worst 2.7e-4 (E[H] at t = 1), 1195 steps, 21 factorisations."""
    sols = transient(paper92, initial=PACKET, times=TIMES)
    err = relative_errors(sols)
    assert err.max() < 1e-3, err
    for s in sols:
        assert abs(s.mass - 1) < 1e-10      # ~1000 LU solves' round-off
        assert s.info["factorisations"] <= 30       # the step-matrix ladder, not one per step
    assert sols[-1].info["steps"] < 1500


def test_output_times_do_not_cut_steps(paper92):
    """Dense output: asking for many times costs no extra factorisation and gives the
    same density at a shared time (to the interpolant's error, below the tolerance)."""
    disc = discretise(paper92, nx=16)
    few = transient(paper92, initial=SMOOTH, times=[2.0], discretisation=disc)[0]
    many = transient(paper92, initial=SMOOTH, times=np.linspace(0.05, 2.0, 40),
                     discretisation=disc)
    assert many[-1].info["factorisations"] == few.info["factorisations"]
    assert l1(disc, many[-1].dofs, few.dofs) < 3e-4


@pytest.mark.parametrize("positivity", ["first-order", "quick"])
def test_exponential_is_non_negative_and_conservative(paper92, positivity):
    sols = exponential(paper92, initial=PACKET, times=[0.5, 1.0, 3.0], positivity=positivity,
                       nx=24, ny=48, dt=0.1)
    for s in sols:
        assert s.dofs.min() >= 0.0
        assert abs(s.mass - 1) < 1e-13


def test_first_order_exponential_is_exact_in_time(paper92):
    disc = discretise(paper92, nx=24, ny=48, positivity="first-order")
    once = exponential(paper92, initial=SMOOTH, times=[2.0], discretisation=disc)[0]
    twice = exponential(paper92, initial=SMOOTH, times=[0.7, 2.0], discretisation=disc)[-1]
    assert l1(disc, once.dofs, twice.dofs) < 1e-12
    # implicit Euler on the same generator converges to it at exactly first order
    errs = [l1(disc, transient(paper92, initial=SMOOTH, times=[2.0], dt=dt,
                               discretisation=disc)[0].dofs, once.dofs)
            for dt in (0.02, 0.01, 0.005)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - 1.0) < 0.08), orders


def test_limited_exponential_is_second_order_in_time(paper92):
    disc = discretise(paper92, nx=24, ny=48, positivity="quick")
    ref = exponential(paper92, initial=SMOOTH, times=[1.0], dt=1 / 256, discretisation=disc)[0]
    errs = [l1(disc, exponential(paper92, initial=SMOOTH, times=[1.0], dt=1 / n,
                                 discretisation=disc)[0].dofs, ref.dofs) for n in (16, 32, 64)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders >= 1.8), orders
    assert ref.dofs.min() >= 0.0
