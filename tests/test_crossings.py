"""Level crossings, peaks and the Rice estimate from a density (fpk_vibro/crossings.py).

Exact: the Gibbs closed form ν⁺(b) = (D1/c) e^{−βG(b)}/Z; identities: ν⁺ at a wall =
the impact rate there (every method's own), ν⁺ = ν⁻ in the stationary state; physics:
the Rice/Poisson rate against the finite-element first passage out of the same band.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem
from fpk_vibro.wall import Wall
from fpk_vibro._checks import InputError
from fpk_vibro.exact import gibbs_upcrossing_rate
from fpk_vibro.crossings import (downcrossing_rate, peak_exceedance,
                                 peak_rate, rice_reliability, upcrossing_rate)
from fpk_vibro.exact import gibbs

from conftest import gibbs_cases

LINEAR = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none")


@pytest.fixture(scope="module")
def fem_paper():
    from fpk_vibro import fem
    return {r: fem.stationary(VibroImpactSystem.paper(r=r)) for r in (0.92, 0.5)}


def _levels(system, n=41):
    lo, hi = system.x_bounds
    X = 3.0 * math.sqrt(gibbs(system).moments()["E_x2"])
    return np.linspace(max(lo, -X), min(hi, X), n)


@pytest.mark.parametrize("name", ["paper", "softening", "unilateral", "no_barrier",
                                  "quartic", "asymmetric"])
def test_gibbs_closed_form(name):
    """Quadrature of the Gibbs density = the closed form to rounding, for any walls."""
    cases = dict(gibbs_cases(), asymmetric=VibroImpactSystem(
        a=1.0, b=0.2, c=0.05, D1=0.02, left=Wall(-0.3, 1.0), right=Wall(0.8, 1.0)))
    s = cases[name]
    b = _levels(s)
    exact = gibbs_upcrossing_rate(s, b)
    quad = upcrossing_rate(gibbs(s), b)
    assert np.max(np.abs(quad - exact)) <= 1e-12 * np.max(exact)
    assert np.max(np.abs(downcrossing_rate(gibbs(s), b) - exact)) <= 1e-12 * np.max(exact)


def test_linear_known_numbers():
    """Linear, no walls: ν⁺(0) = ω0/2π and ν⁺(b) = ν⁺(0) exp(−b²/2σ²), σ² = D1/(ac)."""
    s = VibroImpactSystem(a=4.0, b=0.0, c=0.2, D1=0.01, barriers="none")
    b = np.array([0.0, 0.1, 0.3])
    nu = upcrossing_rate(gibbs(s), b)
    want = 2.0 / (2 * math.pi) * np.exp(-b ** 2 / (2 * s.D1 / (s.a * s.c)))
    assert np.max(np.abs(nu / want - 1)) < 1e-12
    assert np.max(np.abs(gibbs_upcrossing_rate(s, b) / want - 1)) < 1e-12


@pytest.mark.parametrize("name", ["paper", "unilateral", "asymmetric"])
def test_gibbs_wall_is_impact_rate(name):
    cases = dict(gibbs_cases(), asymmetric=VibroImpactSystem(
        a=1.0, b=0.2, c=0.05, D1=0.02, left=Wall(-0.3, 1.0), right=Wall(0.8, 1.0)))
    s = cases[name]
    sol = gibbs(s)
    imp = sol.impacts()
    for side, w in s.walls:
        rate = imp[side]["rate"]
        nu = upcrossing_rate(sol, w.position) if side == "right" else \
            downcrossing_rate(sol, w.position)
        assert abs(nu / rate - 1) < 1e-12
        assert abs(gibbs_upcrossing_rate(s, w.position) / rate - 1) < 1e-12


@pytest.mark.parametrize("r", [0.92, 0.5])
def test_fem_wall_identity(fem_paper, r):
    """FE at its default accuracy: ν⁺(Δ) = right impact rate, ν⁻(−Δ) = left impact rate,
    ν⁺(−Δ) (the rebound flux) = left impact rate.  Measured: 1.2e-7 (r = 0.92), 1.8e-6
    (r = 0.5): the y quadrature against the FE's exact trace rule; both far inside the
    solution's own impact-rate estimate (2.2e-5, 5.1e-4)."""
    sol = fem_paper[r]
    imp = sol.impacts()
    checks = [(upcrossing_rate(sol, 0.6), imp["right"]["rate"]),
              (downcrossing_rate(sol, -0.6), imp["left"]["rate"]),
              (upcrossing_rate(sol, -0.6), imp["left"]["rate"]),
              (downcrossing_rate(sol, 0.6), imp["right"]["rate"])]
    own = sol.error_estimate()["impact_rate"]
    for nu, rate in checks:
        assert abs(nu / rate - 1) < min(5e-6, own)


def test_fem_stationary_balance(fem_paper):
    """ν⁺(b) = ν⁻(b) at every level of the stationary density (measured ≤ 2.8e-6)."""
    sol = fem_paper[0.5]
    b = np.linspace(-0.6, 0.6, 25)
    up, down = upcrossing_rate(sol, b), downcrossing_rate(sol, b)
    assert np.max(np.abs(up - down) / up) < 1e-5


def test_averaging_wall_identity():
    """Averaging's own impact rates (measured 1e-16 symmetric, 1.3e-10 asymmetric walls,
    where Φ has a kink at the far wall's energy between the y nodes)."""
    from fpk_vibro import averaging
    for s in (VibroImpactSystem.paper(r=0.7),
              VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.02, left=Wall(-0.3, 0.8),
                                right=Wall(0.8, 0.8))):
        sol = averaging.stationary(s)
        imp = sol.impacts()
        assert abs(upcrossing_rate(sol, s.right.position) / imp["right"]["rate"] - 1) < 1e-9
        assert abs(downcrossing_rate(sol, s.left.position) / imp["left"]["rate"] - 1) < 1e-9


def test_shapes_and_strip():
    s = VibroImpactSystem.paper(r=1.0, D2=0.0)
    sol = gibbs(s)
    assert isinstance(upcrossing_rate(sol, 0.1), float)
    b = np.array([[-1.0, -0.6, 0.0], [0.3, 0.6, 0.61]])
    nu = upcrossing_rate(sol, b)
    assert nu.shape == (2, 3)
    assert nu[0, 0] == 0.0 and nu[1, 2] == 0.0          # beyond the walls
    assert nu[0, 1] > 0 and nu[1, 1] > 0                 # at the walls
    closed = gibbs_upcrossing_rate(s, b)
    assert closed.shape == (2, 3) and closed[0, 0] == 0.0 and closed[1, 2] == 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, [0.0, -math.inf], "0.3", None,
                                 [0.1, "x"]])
def test_hostile_levels(bad):
    sol = gibbs(LINEAR)
    for f in (upcrossing_rate, downcrossing_rate, peak_rate, peak_exceedance):
        with pytest.raises(InputError) as e:
            f(sol, bad)
        assert "\n" not in str(e.value) and " b " in f" {str(e.value)}"
    with pytest.raises(InputError):
        gibbs_upcrossing_rate(LINEAR, bad)


@pytest.mark.parametrize("kw", [dict(displacement=-0.3), dict(displacement=(0.3, 0.1)),
                                dict(displacement=(0.1, math.nan)),
                                dict(displacement="wide"), dict(displacement=(1, 2, 3))])
def test_hostile_bands(kw):
    with pytest.raises(InputError) as e:
        rice_reliability(gibbs(LINEAR), 1.0, **kw)
    assert "displacement" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(InputError, match="t"):
        rice_reliability(gibbs(LINEAR), -1.0, displacement=0.3)


def test_gibbs_refuses_impacts():
    with pytest.raises(InputError, match="Gibbs"):
        gibbs_upcrossing_rate(VibroImpactSystem.paper(r=0.9), 0.1)


def test_peaks():
    """Linear, no walls (narrow band at c = 0.1): P(peak > b) = exp(−b²/2σ²), the
    Rayleigh law; the rate below the mean is the rate of excursions ν⁺(m)."""
    sol = gibbs(LINEAR)
    b = np.linspace(0.0, 1.0, 11)
    assert np.max(np.abs(peak_exceedance(sol, b) - np.exp(-b ** 2 / 0.2))) < 1e-12
    assert peak_rate(sol, -0.5) == peak_rate(sol, 0.0) == upcrossing_rate(sol, 0.0)
    assert peak_exceedance(sol, -0.5) == 1.0


def test_peaks_asymmetric_walls():
    """With walls at −0.3, 0.8 the mean is off 0; peaks count from it, none beyond
    the right wall; the exceedance falls from 1 to the wall's share."""
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.02, left=Wall(-0.3, 1.0),
                          right=Wall(0.8, 1.0))
    sol = gibbs(s)
    m = sol.mean_x()
    assert m > 0.01
    b = np.linspace(m, 0.8, 30)
    p = peak_exceedance(sol, b)
    assert p[0] == 1.0 and np.all(np.diff(p) < 0) and peak_exceedance(sol, 0.9) == 0.0
    assert abs(p[-1] - sol.impacts()["right"]["rate"] / upcrossing_rate(sol, m)) < 1e-12
    assert peak_rate(sol, -0.2) == upcrossing_rate(sol, m)


def _decay_rate(fp):
    """The slowest decay rate of the true reliability: a fit of ln R on the last 70 %
    of the solver's grid (where one mode is left)."""
    T, S = fp.times, fp.survival
    k = (S > 1e-8) & (T > 0.3 * T[-1])
    return -np.polyfit(T[k], np.log(S[k]), 1)[0]


def _passage(system, band, sol):
    from fpk_vibro import fem
    nu = upcrossing_rate(sol, band) + downcrossing_rate(sol, -band)
    times = np.linspace(0.0, 10.0 / nu, 41)
    fp = fem.first_passage(system, displacement=band, start="stationary", times=times)
    return nu, _decay_rate(fp), times, fp.reliability(times), fp


def test_rice_broad_band_high_level():
    """Heavily damped (ζ = 0.5), |x| < 3σ: the crossings are nearly Poisson; Rice's rate
    and the true decay rate agree (measured ν/λ = 1.018; 0.961 at 2σ, 0.62 at 1σ,
    where exits are faster than Rice says) and Rice's R is below the true one."""
    s = VibroImpactSystem(a=1.0, b=0.0, c=1.0, D1=0.1, barriers="none")
    sol = gibbs(s)
    band = 3.0 * math.sqrt(0.1)
    nu, lam, times, R, _ = _passage(s, band, sol)
    assert 1.0 < nu / lam < 1.03
    assert np.all(rice_reliability(sol, times, displacement=band) <= R + 1e-12)


def test_rice_narrow_band_clusters():
    """Lightly damped (ζ = 0.05), |x| < 3σ: the crossings come in clumps (one per period
    while the envelope is above the level), the true decay rate is about half Rice's
    (measured ν/λ = 1.954; Vanmarcke's clumping estimate 1.93), and Rice's R is below
    the true one at every time (conservative)."""
    band = 3.0 * math.sqrt(0.1)
    sol = gibbs(LINEAR)
    nu, lam, times, R, _ = _passage(LINEAR, band, sol)
    r, delta_e = 3.0, math.sqrt(4 * 0.05 / math.pi) ** 1.2
    vanmarcke = (1 - math.exp(-r * r / 2)) / (1 - math.exp(-math.sqrt(math.pi / 2) * delta_e * r))
    assert 1.8 < nu / lam < 2.1
    assert abs(nu / lam / vanmarcke - 1) < 0.05
    assert np.all(rice_reliability(sol, times, displacement=band) <= R + 1e-12)


def test_rice_with_walls(fem_paper):
    """Paper case r = 0.92, |x| < 0.45 (walls at ±0.6): the impacting orbits make the
    crossings cluster strongly: Rice's rate is 3.3 times the true decay rate; yet at
    early times the true R falls faster (the stationary start holds orbits that leave
    within half a period): measured min(R_true − R_Rice) = −0.10 at t ≈ 0.2 τ."""
    s = VibroImpactSystem.paper(r=0.92)
    sol = fem_paper[0.92]
    nu, lam, times, R, fp = _passage(s, 0.45, sol)
    assert 3.0 < nu / lam < 3.6
    rice = rice_reliability(sol, times, displacement=0.45)
    late = times > 2 * fp.mean
    assert np.all(rice[late] < R[late]) and np.any(rice > R + 0.05)


def test_below_the_methods():
    """fpk_vibro.crossings imports no method: the Solution methods call it."""
    import subprocess
    import sys
    code = ("import sys, fpk_vibro.crossings; print(sorted(m for m in sys.modules if "
            "m.split('.')[1:2] in (['fem'], ['montecarlo'], ['averaging'])))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"
