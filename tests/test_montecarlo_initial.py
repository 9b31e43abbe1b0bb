"""The shared ``initial`` spec parser (fpk_vibro.initial) used by transient methods."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from fpk_vibro import VibroImpactSystem
from fpk_vibro.initial import InitialCondition, parse_initial

S = VibroImpactSystem.paper(r=0.9)


def test_gaussian_truncated_to_strip():
    ic = parse_initial({"mean": (0.5, 0.1), "std": (0.3, 0.2)}, S)
    x, y = ic.sample(20000, np.random.default_rng(0))
    assert x.shape == y.shape == (20000,)
    assert x.min() >= -0.6 and x.max() <= 0.6
    assert abs(y.mean() - 0.1) < 0.01 and abs(y.std() - 0.2) < 0.01
    # density integrates to one over the strip and is zero outside
    val = integrate.dblquad(lambda yy, xx: ic.pdf(xx, yy), -0.6, 0.6, -2, 2)[0]
    assert val == pytest.approx(1.0, abs=1e-6)
    assert ic.pdf(0.61, 0.0) == 0.0
    # the sample follows the truncated density (mean of x)
    mx = integrate.quad(lambda xx: xx * integrate.quad(lambda yy: ic.pdf(xx, yy), -2, 2)[0],
                        -0.6, 0.6)[0]
    assert abs(x.mean() - mx) < 4 * x.std() / np.sqrt(x.size)


def test_far_tail_truncation_is_stable():
    s = VibroImpactSystem(a=1, b=0, c=0.1, D1=0.1, delta=1.0, barriers="right")
    ic = parse_initial({"mean": (1.0, 0.0), "std": (1e-3, 0.0)}, s)
    x, y = ic.sample(1000, np.random.default_rng(1))
    assert np.all(x <= 1.0) and np.all(x > 0.99) and np.all(y == 0.0)


def test_point_mass_and_callable():
    ic = parse_initial({"mean": (0.1, -0.2), "std": (0, 0)}, S)
    x, y = ic.sample(5, np.random.default_rng(0))
    assert np.all(x == 0.1) and np.all(y == -0.2)
    assert not ic.has_density
    with pytest.raises(ValueError, match="pdf needs"):
        ic.pdf(0.0, 0.0)

    def pairs(n, rng):
        return rng.uniform(-0.5, 0.5, n), rng.normal(size=n)

    ic2 = parse_initial(pairs, S)
    x, y = ic2.sample(7, np.random.default_rng(0))
    assert x.shape == (7,) and parse_initial(ic2, S) is ic2


@pytest.mark.parametrize("spec, match", [
    ({"mean": (0.0, 0.0)}, "std must be given"),
    ({"mean": (0.0, 0.0), "std": (0.1,)}, "std must be a pair"),
    ({"mean": (0.0, np.nan), "std": (0.1, 0.1)}, "mean must be a pair of finite"),
    ({"mean": (0.9, 0.0), "std": (0.1, 0.1)}, r"mean\[0\] \(x0\) must be in the strip"),
    ({"mean": (0.0, 0.0), "std": (0.1, -1)}, "std must be a pair of numbers >= 0"),
    ({"mean": (0.0, 0.0), "std": (0.1, 0.1), "cov": 1}, "keys"),
    (3.0, "initial must be"),
])
def test_bad_specs(spec, match):
    with pytest.raises(ValueError, match=match):
        parse_initial(spec, S)


@pytest.mark.parametrize("out, match", [
    (lambda n, rng: np.zeros((n, 3)), "shape"),
    (lambda n, rng: np.full((n, 2), np.nan), "finite"),
    (lambda n, rng: np.full((n, 2), 0.7), "strip"),
    (lambda n, rng: (np.zeros(n - 1), np.zeros(n - 1)), "samples"),
])
def test_bad_sampler_output(out, match):
    ic = parse_initial(out, S)
    assert isinstance(ic, InitialCondition)
    with pytest.raises(ValueError, match=match):
        ic.sample(10, np.random.default_rng(0))
