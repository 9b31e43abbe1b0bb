"""Impact statistics on the paper cases: FE against Monte Carlo per wall within 3
standard errors plus FE's two-level error (default mesh against nx = 64).

Measured (Monte Carlo target_rse = 1e-3, seed 1): r = 0.98 rate FE 0.131430 against
0.131697 ± 0.000166 (left), 0.131670 ± 0.000162 (right); r = 0.92 FE 0.096778 against
0.096494 ± 0.000153, 0.096430 ± 0.000159; mean speeds within 2 SE.
"""
import pytest

from fpk_vibro import VibroImpactSystem, fem, montecarlo


@pytest.mark.parametrize("r", [0.98, 0.92])
def test_fem_impacts_agree_with_monte_carlo(r):
    s = VibroImpactSystem.paper(r=r)
    fine, coarse = fem.stationary(s).impacts(), fem.stationary(s, nx=64).impacts()
    mc = montecarlo.stationary(s, seed=1, target_rse=2e-3, progress=False).impacts()
    assert set(fine) == set(mc) == {"left", "right"}
    for side in fine:
        for key in ("rate", "mean_speed", "mean_square_speed", "energy_rate"):
            tol = 3 * mc[side][key + "_se"] + abs(fine[side][key] - coarse[side][key])
            assert abs(fine[side][key] - mc[side][key]) <= tol, (side, key, fine[side], mc[side])


@pytest.mark.parametrize("r", [0.98, 0.92])
def test_fem_impact_speed_pdf_inside_the_monte_carlo_bars(r):
    """FE's impact-speed density, averaged over each Monte Carlo bin, lies within 3 SE
    (plus FE's two-level difference) of the histogram for speeds above 0.03 m/s
    (about 5 % of the mean speed): at most one of ~100 bins outside, as chance allows.
    Below that the wall corner's singularity is not resolved by the default mesh:
    at r = 0.92 the first bin (u < 0.017) is 4.5–4.8 SE low; at r = 0.98 it is inside."""
    import numpy as np
    s = VibroImpactSystem.paper(r=r)
    fine, coarse = fem.stationary(s), fem.stationary(s, nx=64)
    mc = montecarlo.stationary(s, seed=1, target_rse=2e-3, quantities=("energy", "impacts"),
                               progress=False)
    t, w = np.polynomial.legendre.leggauss(6)
    for side in ("left", "right"):
        edges, dens, se = mc.impact_speed_histogram(side)
        mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
        u = mid[:, None] + half[:, None] * t
        fb = (fine.impact_speed_pdf(side, u) * w).sum(axis=1) / 2
        cb = (coarse.impact_speed_pdf(side, u) * w).sum(axis=1) / 2
        trust = (edges[:-1] >= 0.03) & (se > 0)
        outside = np.abs(fb - dens) > 3 * se + np.abs(fb - cb)
        assert np.sum(outside & trust) <= 1, (side, np.flatnonzero(outside & trust))


def test_power_balance_of_every_engine():
    """Monte Carlo closes the balance within its standard error; exact Gibbs to
    round-off; averaging leaves its model error (−3.8 % at r = 0.92)."""
    from fpk_vibro import averaging, exact
    s = VibroImpactSystem.paper(r=0.92)
    pb = montecarlo.stationary(s, seed=1, target_rse=2e-3, progress=False).power_balance()
    assert abs(pb["residual"]) < 3 * pb["residual_se"]
    assert abs(exact.gibbs(VibroImpactSystem.paper(r=1.0, D2=0.0)).power_balance()["residual"]) < 1e-12
    assert -0.06 < averaging.stationary(s).power_balance()["residual"] < -0.02
