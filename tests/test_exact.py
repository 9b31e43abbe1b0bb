"""The exact Gibbs solution: normalisation, moments by independent quadrature, errors."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from fpk_vibro import Solution, VibroImpactSystem, exact

from conftest import gauss_total, gibbs_cases, quad_total

DOUBLE_WELL = VibroImpactSystem(a=-1.0, b=1.0, c=0.05, D1=0.05, delta=2.0)


@pytest.mark.parametrize("system", list(gibbs_cases().values()) + [DOUBLE_WELL],
                         ids=list(gibbs_cases()) + ["double_well"])
def test_normalised_and_consistent(system):
    sol = exact.gibbs(system)
    lo, hi = system.x_bounds
    lo, hi = max(lo, -8.0), min(hi, 8.0)
    beta = system.c / system.D1
    assert gauss_total(sol.pdf_x, [lo, -1.0, 0.0, 1.0, hi]) == pytest.approx(1, abs=1e-10)
    assert gauss_total(sol.pdf_y, [-20 / math.sqrt(beta), 0.0, 20 / math.sqrt(beta)]) == pytest.approx(1, abs=1e-12)
    g0 = min(0.0, float(system.potential(np.sqrt(max(-system.a / system.b, 0.0)))) if system.b else 0.0)
    Hb = system.barrier_energy if system.has_barrier else 1.0
    Htop = g0 + 60 / beta
    assert quad_total(sol.pdf_energy, g0, Htop, [0.0, Hb]) == pytest.approx(1, abs=1e-8)
    # moments: E[y²] = D1/c exactly; E[H] = E[y²]/2 + E[G] from the marginal
    m = sol.moments()
    assert m["E_y2"] == pytest.approx(1 / beta, rel=1e-14)
    EG = gauss_total(lambda x: system.potential(x) * sol.pdf_x(x), [lo, -1.0, 0.0, 1.0, hi])
    assert m["E_H"] == pytest.approx(0.5 / beta + EG, rel=1e-10)
    # E[H] also from p(H): the two routes share nothing but the density's definition
    # (the double well's p(H) is a quad per energy: its normalisation above suffices)
    if system is not DOUBLE_WELL:
        EH = quad_total(lambda h: h * sol.pdf_energy(h), g0, Htop, [0.0, Hb])
        assert m["E_H"] == pytest.approx(EH, rel=1e-7)


def test_impact_probability_by_brute_force():
    system = gibbs_cases()["paper"]
    sol = exact.gibbs(system)
    Hb = system.barrier_energy
    below = quad(sol.pdf_energy, 0, Hb, epsabs=0, epsrel=1e-12, limit=200)[0]
    assert sol.moments()["P_impact"] == pytest.approx(1 - below, rel=1e-9)


@pytest.mark.parametrize("kw, name", [(dict(r=0.9), "r"), (dict(D2=0.01), "D2")])
def test_only_for_exact_cases(kw, name):
    with pytest.raises(ValueError, match=name):
        exact.gibbs(VibroImpactSystem.paper(**{"r": 1.0, "D2": 0.0, **kw}))


def test_round_trip(tmp_path):
    sol = exact.gibbs(DOUBLE_WELL)
    back = Solution.load(sol.save(tmp_path / "gibbs.npz"))
    assert isinstance(back, exact.GibbsSolution)
    assert back.moments() == sol.moments()
    x = np.linspace(-2.5, 2.5, 11)
    assert np.array_equal(back.pdf_joint(x, x), sol.pdf_joint(x, x))


def test_load_rejects_other_files(tmp_path):
    np.savez(tmp_path / "other.npz", a=np.arange(3))
    with pytest.raises(ValueError, match="not an fpk_vibro solution"):
        Solution.load(tmp_path / "other.npz")
