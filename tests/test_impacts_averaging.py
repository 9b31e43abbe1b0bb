"""Impacts and first passage from averaging (and the exact Gibbs solution)."""
import math

import numpy as np
import pytest
from scipy import integrate

from fpk_vibro import VibroImpactSystem, Wall, averaging, exact, fem

EXACT = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, left=Wall(-0.4), right=Wall(0.8))


def test_averaged_impacts_are_the_gibbs_closed_forms():
    """r = 1, D2 = 0: averaging is exact, so its rates and speed pdf equal the closed
    forms (measured: equal to 1e-15)."""
    a, g = averaging.stationary(EXACT).impacts(), exact.gibbs(EXACT).impacts()
    w = lambda s: np.exp(-EXACT.c / EXACT.D1 * EXACT.potential(s))
    Z = integrate.quad(w, -0.4, 0.8, epsabs=0, epsrel=1e-13)[0]
    sigma = math.sqrt(EXACT.D1 / EXACT.c)
    for side, wall in EXACT.walls:
        assert g[side]["rate"] == pytest.approx(w(wall.position) / Z * sigma / math.sqrt(2 * math.pi), rel=1e-10)
        for k in ("rate", "mean_speed", "mean_square_speed"):
            assert a[side][k] == pytest.approx(g[side][k], rel=1e-9), (side, k)
    u = np.linspace(0.0, 3.0, 61)
    assert np.allclose(averaging.stationary(EXACT).impact_speed_pdf("right", u),
                       exact.gibbs(EXACT).impact_speed_pdf("right", u), rtol=1e-9, atol=1e-12)


def test_averaged_impacts_against_fem_on_the_paper_case():
    """r = 0.92: averaging's impact rate is 3.8 % above FE's (its model error; E[H] is
    3.1 % high), the mean speed 0.2 % low."""
    s = VibroImpactSystem.paper(r=0.92)
    a, f = averaging.stationary(s).impacts(), fem.stationary(s).impacts()
    assert 0.02 < a["right"]["rate"] / f["right"]["rate"] - 1 < 0.06
    assert abs(a["right"]["mean_speed"] / f["right"]["mean_speed"] - 1) < 0.01


def test_averaged_first_passage_against_fem():
    """τ from (0, 0) to H_c = 0.498 on r = 0.92: averaging 78.78 against FE 80.45
    (−2.1 %); the quadrature τ and the finite-volume τ agree to 0.05 %."""
    s = VibroImpactSystem.paper(r=0.92)
    a = averaging.first_passage(s, energy=0.498)
    f = fem.first_passage(s, energy=0.498)
    assert -0.04 < a.mean / f.mean - 1 < 0.0
    assert a.info["tau_fv"] == pytest.approx(a.mean, rel=2e-3)
    T = np.linspace(0.0, 40 * a.mean, 20001)
    assert np.trapezoid(a.reliability(T), T) == pytest.approx(a.mean, rel=3e-3)
    assert a.mean_time(0.0, 0.3) == pytest.approx(a.mean_time(0.3 * 0.99, 0.0), rel=0.05)
    assert a.mean_time(0.0, 2.0) == 0.0


def test_averaged_first_passage_closed_form_zero_offset():
    """Zero offset, D2 = 0: m = D1 − λ1 H, σ² = 2 D1 H (docs/averaging_walls.md):
    Pontryagin's integral by quadrature equals the package's τ."""
    s = VibroImpactSystem(a=1.0, b=0.0, c=0.05, D1=0.01, right=Wall(0.0, 0.8))
    lam = (s.c + (1 - 0.8 ** 2) / math.pi) / s.D1
    Hc = 5.0 / lam
    ps = lambda u: lam * math.exp(-lam * u)
    F = lambda u: 1 - math.exp(-lam * u)
    ref = integrate.quad(lambda u: 2 * F(u) / (2 * s.D1 * u * ps(u)), 0.0, Hc,
                         epsabs=0, epsrel=1e-12)[0]
    got = averaging.first_passage(s, energy=Hc, start=(-1e-9, 0.0)).mean
    assert got == pytest.approx(ref, rel=1e-4)
