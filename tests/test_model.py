import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from fpk_vibro import VibroImpactSystem

GOOD = dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01, delta=0.6, r=0.92, barriers="both")
nonfinite = st.sampled_from([math.nan, math.inf, -math.inf])


def make(**kw):
    return VibroImpactSystem(**{**GOOD, **kw})


def assert_names(field, exc):
    assert field in str(exc.value)


def test_paper_parameters():
    s = VibroImpactSystem.paper(r=0.92)
    assert (s.a, s.b, s.c, s.D1, s.D2, s.delta, s.r, s.barriers) == (1, 0.2, 0.025, 0.01, 0.01, 0.6, 0.92, "both")
    assert VibroImpactSystem.paper(delta=1.0).delta == 1.0
    with pytest.raises(ValueError, match="unknown field"):
        VibroImpactSystem.paper(gamma=1)


def test_frozen_keyword_only():
    s = make()
    with pytest.raises(Exception):
        s.r = 0.5
    with pytest.raises(TypeError):
        VibroImpactSystem(1.0, 0.2, 0.025, 0.01)


def test_energy_and_amplitude():
    s = make()
    x = np.linspace(-0.6, 0.6, 7)
    assert np.allclose(s.potential(x), 0.5 * x**2 + 0.05 * x**4, rtol=1e-15)
    assert np.allclose(s.energy(x, 2 * x), 2 * x**2 + s.potential(x))
    assert s.barrier_energy == pytest.approx(0.5 * 0.36 + 0.05 * 0.6**4, rel=1e-15)
    H = np.array([0.0, 1e-300, 1e-12, 0.1, 10.0])
    assert np.allclose(s.potential(s.amplitude(H)), H, rtol=1e-14, atol=0)
    # the stable form keeps relative accuracy where the textbook one cancels
    assert s.amplitude(1e-20) == pytest.approx(math.sqrt(2e-20), rel=1e-12)


def test_effects():
    assert "parametric_noise" not in make(D2=0.0).effects
    assert "impact_left" not in make(barriers="right").effects
    eff = VibroImpactSystem(a=1, b=0, c=0.1, D1=0.1, barriers="none").effects
    assert not any(e.startswith("impact") for e in eff)


@settings(max_examples=40, deadline=None)
@given(field=st.sampled_from(["a", "b", "c", "D1", "D2", "r", "delta"]), value=nonfinite)
def test_nonfinite_rejected(field, value):
    with pytest.raises(ValueError) as exc:
        make(**{field: value})
    assert_names(field, exc)


@settings(max_examples=40, deadline=None)
@given(r=st.one_of(st.floats(max_value=-1e-12, allow_nan=False, allow_infinity=False),
                   st.floats(min_value=1 + 1e-12, allow_nan=False, allow_infinity=False)))
def test_r_out_of_range(r):
    with pytest.raises(ValueError) as exc:
        make(r=r)
    assert_names("r", exc)
    assert "[0, 1]" in str(exc.value)


@settings(max_examples=30, deadline=None)
@given(delta=st.floats(max_value=0.0, allow_nan=False, allow_infinity=False),
       barriers=st.sampled_from(["both", "right"]))
def test_delta_nonpositive(delta, barriers):
    with pytest.raises(ValueError) as exc:
        make(delta=delta, barriers=barriers)
    assert_names("delta", exc)


@settings(max_examples=30, deadline=None)
@given(c=st.floats(max_value=-1e-300, allow_nan=False, allow_infinity=False))
def test_negative_damping(c):
    with pytest.raises(ValueError) as exc:
        make(c=c)
    assert_names("c", exc)


@settings(max_examples=30, deadline=None)
@given(D1=st.floats(max_value=0.0, allow_nan=False, allow_infinity=False))
def test_no_external_noise(D1):
    with pytest.raises(ValueError) as exc:
        make(D1=D1)
    assert_names("D1", exc)
    assert "stationary density" in str(exc.value)


@settings(max_examples=30, deadline=None)
@given(D2=st.floats(max_value=-1e-300, allow_nan=False, allow_infinity=False))
def test_negative_parametric_noise(D2):
    with pytest.raises(ValueError) as exc:
        make(D2=D2)
    assert_names("D2", exc)


@settings(max_examples=30, deadline=None)
@given(barriers=st.text(max_size=8).filter(lambda s: s not in ("both", "right", "none")))
def test_unknown_barriers(barriers):
    with pytest.raises(ValueError) as exc:
        make(barriers=barriers)
    assert_names("barriers", exc)


@settings(max_examples=40, deadline=None)
@given(a=st.floats(-5, 5), b=st.floats(-5, 5), barriers=st.sampled_from(["right", "none"]))
def test_unconfined_side(a, b, barriers):
    confining = b > 0 or (b == 0 and a > 0)
    if confining:
        make(a=a, b=b, barriers=barriers)
        return
    with pytest.raises(ValueError) as exc:
        make(a=a, b=b, barriers=barriers)
    assert ("b" in str(exc.value)) or ("a" in str(exc.value))
    assert "confine" in str(exc.value)


@settings(max_examples=20, deadline=None)
@given(a=st.floats(-5, 5), b=st.floats(-5, 5))
def test_any_potential_between_two_barriers(a, b):
    assert make(a=a, b=b).a == a


@pytest.mark.parametrize("kw", [dict(r=1.0), dict(barriers="none", r=0.5)])
def test_no_dissipation(kw):
    with pytest.raises(ValueError) as exc:
        make(c=0.0, **kw)
    assert_names("c", exc)
    make(c=0.0, r=0.5)  # impacts alone dissipate: allowed


@pytest.mark.parametrize("bad", ["1.0", None, True, [1.0]])
def test_wrong_types(bad):
    with pytest.raises(ValueError) as exc:
        make(a=bad)
    assert_names("a", exc)


def test_dict_round_trip():
    s = make(barriers="right")
    assert VibroImpactSystem.from_dict(s.to_dict()) == s
