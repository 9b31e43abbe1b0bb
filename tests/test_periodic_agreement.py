"""Issue 34's cross-check with walls: the periodic response of the paper system with
r = 0.8 under F cos(0.9 t) + noise, finite elements (harmonic balance) against Monte
Carlo at 8 phases within 3 SE + 0.3 %.  Like is compared with like: Monte Carlo reads
each phase as a point value (``phase_bin=0``: the sampled instants fall on the
phases), FE evaluates its density at the phase."""
import numpy as np
import pytest

from fpk_vibro import Harmonic, VibroImpactSystem, fem, montecarlo

FORCED = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(amplitude=0.05, frequency=0.9))
PHASES = np.arange(8) * 2 * np.pi / 8


@pytest.fixture(scope="module")
def pair():
    f = fem.periodic(FORCED, PHASES)
    m = montecarlo.periodic(FORCED, PHASES, seed=2024, n_paths=4096, n_periods=200,
                            phase_bin=0.0, progress=False)
    return f, m


def test_fe_against_monte_carlo_at_eight_phases(pair):
    f, m = pair
    worst = 0.0
    for i in range(len(PHASES)):
        a, b = f.at(i).moments(), m.at(i).moments()
        se = m.at(i).moments_se()
        for k in ("E_x2", "E_y2", "E_H", "P_impact"):
            gap = abs(a[k] - b[k])
            assert gap <= 3 * se[k] + 3e-3 * abs(a[k]), (i, k, a[k], b[k], se[k])
            worst = max(worst, gap / se[k])
    # E[x] swings through zero: judged on the scale of its amplitude
    ex_f, ex_m = f.moments_vs_phase()["E_x"], m.moments_vs_phase()["E_x"]
    se_x = np.array([m.at(i).mean_x_se() for i in range(len(PHASES))])
    assert np.all(np.abs(ex_f - ex_m) <= 3 * se_x + 3e-3 * f.amplitude)
    assert worst > 0.0


def test_amplitude_and_lag_agree(pair):
    """The first harmonic of E[x]: FE reads it exactly from p_1, Monte Carlo fits it
    over 16 phases of every period, with SEs from batch means."""
    f, m = pair
    assert abs(f.amplitude - m.amplitude) <= 3 * m.info["amplitude_se"] + 3e-3 * f.amplitude
    assert abs(f.lag - m.lag) <= 3 * m.info["lag_se"] + 3e-3
    est = f.error_estimate()
    assert est["amplitude"] < 1e-3 * f.amplitude and est["lag"] < 1e-3
