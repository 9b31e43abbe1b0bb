"""Averaged first passage out of displacement and impact-speed safe sets: mapped to
an energy threshold H_c (the orbit reaches the bound once H > G(x_b); impacts faster
than u_c once H > G(x_w) + u_c²/2)."""
import math

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, Wall, averaging, references
from fpk_vibro._checks import InputError
from fpk_vibro.averaging.first_passage import model_error

S = VibroImpactSystem.paper(r=0.92)


def _same(a, b):
    assert a.mean == b.mean
    assert np.array_equal(a.times, b.times) and np.array_equal(a.survival, b.survival)
    x = np.array([0.0, 0.2, 0.4])
    assert np.array_equal(a.mean_time(x, 0 * x), b.mean_time(x, 0 * x))


@pytest.mark.parametrize("given, H_c", [
    (0.5, S.potential(0.5)),
    ((-0.3, 0.45), S.potential(0.3)),               # the nearer bound decides
    ((-2.0, 0.45), S.potential(0.45)),              # a bound beyond the wall never counts
])
def test_displacement_is_the_energy_first_passage_at_the_mapped_threshold(given, H_c):
    d = averaging.first_passage(S, displacement=given, times=[5.0, 50.0])
    e = averaging.first_passage(S, energy=float(H_c), times=[5.0, 50.0])
    _same(d, e)
    assert d.info["H_c"] == pytest.approx(float(H_c), rel=1e-15)
    assert d.safe_set.kind == "displacement" and d.energy is None
    assert "G(x_b)" in d.info["mapped"]


def test_impact_speed_is_the_energy_first_passage_at_the_lowest_wall():
    s = VibroImpactSystem.paper(left=Wall(-0.5, 0.9), right=Wall(0.7, 0.8))
    u_c = 0.4
    d = averaging.first_passage(s, impact_speed=u_c)
    H_c = float(s.potential(0.5)) + 0.5 * u_c ** 2
    _same(d, averaging.first_passage(s, energy=H_c))
    assert d.info["H_c"] == pytest.approx(H_c, rel=1e-15) and "left wall" in d.info["mapped"]
    assert d.safe_set.speed == u_c


def test_energy_keyword_unchanged():
    e = averaging.first_passage(S, energy=0.3)
    assert e.energy == 0.3 and e.safe_set.kind == "energy"


@pytest.mark.parametrize("kwargs, message", [
    ({"displacement": (0.1, 0.5)}, "only when it contains x = 0, which every orbit passes; "
                                   "0.1 < x < 0.5 does not"),
    ({"displacement": 0.5, "energy": 0.3}, "give exactly one safe set"),
    ({}, "give exactly one safe set"),
    ({"impact_speed": -1.0}, "impact_speed must be"),
    ({"displacement": 0.5, "start": (0.55, 0.0)}, "inside the safe set -0.5 < x < 0.5"),
])
def test_refusals_are_one_line(kwargs, message):
    with pytest.raises(InputError) as exc:
        averaging.first_passage(S, **kwargs)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_impact_speed_needs_a_wall():
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, barriers="none")
    with pytest.raises(InputError, match="impact_speed"):
        averaging.first_passage(s, impact_speed=0.5)


def test_the_estimate_asks_fe_for_the_same_safe_set(monkeypatch):
    """The FE reference is asked with the same keyword; where FE refuses it, the
    estimate is infinite with FE's reason (no crash)."""
    seen = {}

    def fake(system, **options):
        seen.update(options)
        raise InputError("fem.first_passage: does not compute it", where="fem", name="x")
    monkeypatch.setitem(references._PROVIDERS, "fem-first-passage", fake)
    fp = averaging.first_passage(S, displacement=(-2.0, 0.45))
    est = model_error(fp)
    assert seen["displacement"] == (-0.6, 0.45) and seen["start"] == (0.0, 0.0)
    assert math.isinf(est["mean_time"]) and "does not compute it" in est["reference"]
    fp = averaging.first_passage(S, impact_speed=0.3)
    model_error(fp)
    assert seen["impact_speed"] == 0.3
