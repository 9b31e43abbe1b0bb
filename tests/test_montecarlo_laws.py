"""Monte Carlo with restitution laws r(u): a constant given as a law is the number to
the bit, the kernels' r(u) is the law's, the energy the impacts remove follows the law
(the power balance closes for a steep law), and the step size rules take the law."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import Restitution, VibroImpactSystem, Wall
from fpk_vibro import montecarlo as mc
from fpk_vibro.montecarlo import _laws, _step_size

PAPER = VibroImpactSystem.paper(r=0.8)
RUN = dict(seed=5, n_paths=256, t_sample=150.0, progress=False,
           quantities=("x", "impact_energy"))


def with_law(system, law):
    return system.replace(**{"left.r": law, "right.r": law})


@pytest.mark.parametrize("law", [Restitution.table([0.0, 1.0], [0.8, 0.8]),
                                 Restitution.tanh(0.8, 0.0, 1.0)])
def test_a_constant_law_is_the_number_bit_for_bit(law):
    a = mc.stationary(PAPER, **RUN)
    b = mc.stationary(with_law(PAPER, law), **RUN)
    assert a.moments() == b.moments() and a.impacts() == b.impacts()
    assert np.array_equal(a.histogram("x")[1], b.histogram("x")[1])
    assert np.array_equal(a.impact_energy_histogram("left")[1],
                          b.impact_energy_histogram("left")[1])
    kw = dict(n_paths=256, seed=3, progress=False)
    for safe in ({"energy": 0.3}, {"impact_speed": 0.4}, {"displacement": 0.5}):
        fa = mc.first_passage(PAPER, **safe, **kw)
        fb = mc.first_passage(with_law(PAPER, law), **safe, **kw)
        assert fa.mean == fb.mean and np.array_equal(fa.survival, fb.survival), safe


@pytest.mark.parametrize("law", [Restitution.tanh(0.9, 0.2, 1.0),
                                 Restitution.table([0.0, 0.3, 1.0], [0.95, 0.7, 0.5]),
                                 Restitution.callable(lambda u: 0.9 / (1.0 + u))])
def test_the_kernels_r_is_the_laws(law):
    """The packed law the kernels read gives the law's r(u) (the table of a callable
    to its tabulation error, the others to rounding) and the encoding's bit for bit."""
    w = Wall(0.5, r=law)
    buf = _laws.pack(w, w, 10.0)
    enc = _laws.encode(w, 10.0)
    u = np.linspace(0.0, 12.0, 997)
    for side in (0, 1):
        got = np.array([_laws.restitution_side(v, buf, side) for v in u])
        ref = np.array([_laws.restitution(v, *enc) for v in u])
        assert np.array_equal(got, ref)
        tol = 1e-5 if law.kind == "callable" else 1e-15
        np.testing.assert_allclose(got[u <= 10.0], law(u[u <= 10.0]), rtol=0, atol=tol)


def test_energy_per_impact_and_the_power_balance_follow_a_steep_law():
    steep = with_law(PAPER, Restitution.tanh(0.95, 0.6, 0.3))
    sol = mc.stationary(steep, seed=8, n_paths=1024, t_sample=400.0, progress=False,
                        quantities=("x", "impacts", "impact_energy"))
    for side in ("left", "right"):
        d = sol.impacts()[side]
        # identity: the mean energy per impact is energy_rate / rate
        assert sol.mean_impact_energy(side) == pytest.approx(d["energy_rate"] / d["rate"],
                                                             rel=1e-12)
        # the old ½(1 − r²) E[u²] with r at any one speed is not it
        r0 = float(steep.left.r(0.0))
        assert abs(0.5 * (1 - r0 ** 2) * d["mean_square_speed"] - d["mean_energy"]) > \
            10 * d["mean_energy_se"]
        # the histogram of e holds the impacts, and its mean is the mean (to a bin)
        edges, dens, _ = sol.impact_energy_histogram(side)
        mid, w = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
        assert np.sum(dens * w) == pytest.approx(1 - sol.overflow[f"impact_energy_{side}"],
                                                 abs=1e-12)
        assert np.sum(mid * dens * w) == pytest.approx(d["mean_energy"], abs=w[0])
    pb = sol.power_balance()
    assert abs(pb["residual"]) <= 3 * pb["residual_se"] + 0.005, pb


def test_the_step_size_takes_the_law_at_its_lowest():
    law = Restitution.tanh(0.9, 0.6, 0.5)
    s = with_law(PAPER, law)
    r = _step_size.wall_r(s, s.left)
    assert 0.3 <= r < 0.9 and r == pytest.approx(s.left.r_bounds(100.0)[0], abs=0.05)
    number = with_law(PAPER, r)
    E = _step_size.typical_energy(number)
    assert _step_size.crossing_divisor(s, E) == _step_size.crossing_divisor(number, E)
