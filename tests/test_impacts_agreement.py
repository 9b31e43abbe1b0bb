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
