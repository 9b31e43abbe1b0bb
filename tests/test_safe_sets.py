"""The safe sets of a first passage (fpk_vibro.safe_sets) and the energy one impact
dissipates (fpk_vibro.impact_energy): parsing, one-line refusals, and the density of
e = (1 − r(u)²) u²/2 against closed forms."""
import math

import numpy as np
import pytest

from fpk_vibro import Restitution, VibroImpactSystem, Wall
from fpk_vibro._checks import InputError
from fpk_vibro.first_passage import parse_start
from fpk_vibro.impact_energy import energy_density, mean_energy
from fpk_vibro.safe_sets import SafeSet, parse_safe_set, refuse

P = VibroImpactSystem.paper()
W = "fem.first_passage"


def test_each_kind_parses_and_describes_itself():
    assert parse_safe_set(W, P, energy=0.3) == SafeSet("energy", energy=0.3)
    d = parse_safe_set(W, P, displacement=0.4)
    assert (d.x_lo, d.x_hi) == (-0.4, 0.4) and d.describe() == "-0.4 < x < 0.4"
    d = parse_safe_set(W, P, displacement=(-0.2, 5.0))      # beyond the right wall: open
    assert (d.x_lo, d.x_hi) == (-0.2, math.inf) and d.describe() == "x > -0.2"
    assert d.to_dict() == {"kind": "displacement", "value": [-0.2, None]}
    u = parse_safe_set(W, P, impact_speed=0.5)
    assert u.speed == 0.5 and u.contains(P, 0.59, 10.0)


@pytest.mark.parametrize("kw, name", [
    ({}, "energy"),
    ({"energy": 0.3, "displacement": 0.2}, "energy"),
    ({"displacement": -0.1}, "displacement"),
    ({"displacement": (0.3, 0.1)}, "displacement"),
    ({"displacement": (0.1, 0.2, 0.3)}, "displacement"),
    ({"displacement": 2.0}, "displacement"),                 # beyond both walls (±0.6)
    ({"displacement": (0.7, 0.9)}, "displacement"),          # off the strip
    ({"displacement": float("nan")}, "displacement"),
    ({"impact_speed": 0.0}, "impact_speed"),
    ({"impact_speed": math.inf}, "impact_speed"),
    ({"energy": -1.0}, "energy"),
])
def test_bad_safe_sets_are_one_line_naming_the_keyword(kw, name):
    with pytest.raises(InputError) as exc:
        parse_safe_set(W, P, **kw)
    assert "\n" not in str(exc.value) and name in str(exc.value)


def test_impact_speed_needs_a_wall_and_a_start_must_be_inside():
    free = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.1, barriers="none")
    with pytest.raises(InputError, match="impact_speed.*wall"):
        parse_safe_set(W, free, impact_speed=1.0)
    d = parse_safe_set(W, P, displacement=0.3)
    assert parse_start(W, P, (0.1, 5.0), d) == ("point", (0.1, 5.0))    # any velocity
    with pytest.raises(InputError, match="-0.3 < x < 0.3"):
        parse_start(W, P, (0.35, 0.0), d)


def test_refusal_names_the_engines_that_do():
    from fpk_vibro.safe_sets import SUPPORTED_BY
    assert "averaging" in SUPPORTED_BY["displacement"]
    with pytest.raises(InputError) as exc:
        refuse("toy", "displacement")
    assert "averaging" in str(exc.value) and "\n" not in str(exc.value)


def _rayleigh(u):
    return u * np.exp(-u * u / 2.0)


def test_constant_r_gives_the_exponential_law():
    """u Rayleigh, e = k u² with k = (1 − r²)/2: p_e = exp(−e/2k)/(2k)."""
    w, k = Wall(0.5, r=0.8), 0.5 * (1 - 0.64)
    e = np.linspace(0.01, 1.0, 7)
    got = energy_density(w, _rayleigh, e, u_max=9.0)
    assert np.allclose(got, np.exp(-e / (2 * k)) / (2 * k), rtol=2e-3)
    assert abs(mean_energy(w, _rayleigh, u_max=9.0) - 2 * k) < 1e-6


def test_a_law_that_folds_g_keeps_the_mass_and_the_mean():
    """r(u) = 0.9 − 0.2 tanh(u): e = g(u) on every branch; ∫p_e de = 1 and E[e] =
    ∫ g p_u du (quadrature of the same integrand)."""
    w = Wall(0.5, r=Restitution.tanh(0.9, 0.2, 1.0))
    e = np.linspace(0.0, 20.0, 200001)
    p = energy_density(w, _rayleigh, e, u_max=9.0)
    assert p.min() >= 0 and abs(np.trapezoid(p, e) - 1.0) < 1e-3
    u = np.linspace(0, 9.0, 200001)
    exact = np.trapezoid(w.loss(u) * _rayleigh(u), u)
    assert abs(mean_energy(w, _rayleigh, u_max=9.0) - exact) < 1e-6 * exact


def test_an_elastic_wall_dissipates_nothing():
    w = Wall(0.5, r=Restitution.tanh(1.0, 0.0, 1.0))
    assert w.elastic and mean_energy(w, _rayleigh, u_max=9.0) == 0.0
    assert not energy_density(w, _rayleigh, [0.1, 1.0], u_max=9.0).any()
