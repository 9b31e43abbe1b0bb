"""Fast transients: the default adaptive BDF2 against the stored packet reference, and
the positivity-preserving exponential integrator (fpk_vibro.fem.transient.exponential).

The full default run of the packet to t = 80 (36 765 DOFs) is the benchmark
``python -m fpk_vibro.fem.benchmark_transient``, not a test: here the default time
control runs on nx = 48 at t = 5, 20, 80, where that mesh is fine enough (at t = 1
E[x²] carries the one-cell width of the initial x-spread: 0.4 % at nx = 48)."""
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem
from fpk_vibro.fem.benchmark_transient import PACKET, relative_errors
from fpk_vibro.fem.transient import discretise, exponential, transient

SMOOTH = {"mean": (0.1, 0.3), "std": (0.15, 0.3)}


@pytest.fixture(scope="module")
def paper92():
    return VibroImpactSystem.paper(r=0.92)


def l1(disc, p, q):
    return float(disc.unit @ np.abs(p - q))


def test_default_time_control_meets_the_packet_reference(paper92):
    sols = transient(paper92, initial=PACKET, times=[5.0, 20.0, 80.0], nx=48)
    err = relative_errors(sols, times=[5.0, 20.0, 80.0])
    assert err.max() < 1e-3, err
    for s in sols:
        assert abs(s.mass - 1) < 1e-10      # ~1000 LU solves' round-off
    assert sols[-1].info["steps"] < 1200


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
