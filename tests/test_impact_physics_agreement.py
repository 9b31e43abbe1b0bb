"""Issue 32 across the engines: the path-integration peer's restitution law on the
paper system (FE against Monte Carlo within 3 SE + 0.3 %, the density non-negative),
Kac's identity (mean time between impacts = 1/total impact rate) by every engine, and
displacement first passage from FE against Monte Carlo."""
import numpy as np
import pytest

from fpk_vibro import Restitution, VibroImpactSystem, averaging, fem, montecarlo

#: r(v) = 0.9 − 0.2 tanh(v): PathIntegrationMethod.jl's velocity-dependent restitution.
PEER_LAW = Restitution.tanh(0.9, 0.2, 1.0)
PEER = VibroImpactSystem.paper().replace(**{"left.r": PEER_LAW, "right.r": PEER_LAW})


@pytest.fixture(scope="module")
def peer_fem():
    return fem.stationary(PEER)


@pytest.fixture(scope="module")
def peer_mc():
    return montecarlo.stationary(PEER, seed=2024, n_paths=4096, target_rse=2e-3,
                                 quantities=("energy", "x", "y", "inter_impact",
                                             "impact_energy"), progress=False)


def test_the_peer_law_fe_against_monte_carlo(peer_fem, peer_mc):
    f, m = peer_fem.moments(), peer_mc.moments()
    se = peer_mc.moments_se()
    for k in ("E_H", "E_x2", "E_y2", "P_impact"):
        assert abs(f[k] - m[k]) <= 3 * se[k] + 3e-3 * abs(f[k]), (k, f[k], m[k], se[k])
    fi, mi = peer_fem.impacts(), peer_mc.impacts()
    for side in ("left", "right"):
        for k in ("rate", "energy_rate"):
            assert abs(fi[side][k] - mi[side][k]) <= (3 * mi[side][f"{k}_se"]
                                                      + 3e-3 * fi[side][k]), (side, k)
    assert peer_fem.dofs.min() >= 0.0
    x, y = np.meshgrid(np.linspace(-0.6, 0.6, 121), np.linspace(-2.0, 2.0, 161))
    assert peer_fem.pdf_joint(x, y).min() >= 0.0


def _total_rate(sol) -> float:
    return sum(v["rate"] for v in sol.impacts().values())


def test_kac_identity_by_every_engine(peer_fem, peer_mc):
    """The mean time between successive impacts is 1/(total impact rate), whatever
    the law: each engine computes the mean its own way (FE: first passage to the walls
    from the post-impact flux; Monte Carlo: the gaps of the paths; averaging: orbit
    times at the impact energies and excursions below the walls)."""
    assert abs(peer_fem.mean_inter_impact_time() * _total_rate(peer_fem) - 1) < 1e-4
    se = peer_mc.mean_inter_impact_time_se() if hasattr(
        peer_mc, "mean_inter_impact_time_se") else peer_mc.error_estimate()[
        "mean_inter_impact_time"] * peer_mc.mean_inter_impact_time() / 2
    rate, rate_se = _total_rate(peer_mc), sum(v["rate_se"] for v in peer_mc.impacts().values())
    inv = 1.0 / rate
    assert abs(peer_mc.mean_inter_impact_time() - inv) <= 3 * (se + inv * rate_se / rate)
    av = averaging.stationary(PEER)
    assert abs(av.mean_inter_impact_time() * _total_rate(av) - 1) < 1e-6


def test_energy_per_impact_agrees(peer_fem, peer_mc):
    for side in ("left", "right"):
        e_f, e_m = peer_fem.mean_impact_energy(side), peer_mc.mean_impact_energy(side)
        assert abs(e_f - e_m) <= 3 * peer_mc.mean_impact_energy_se(side) + 3e-3 * e_f
        e = np.linspace(0.005, 0.2, 8)
        assert np.all(peer_fem.impact_energy_pdf(side, e) >= 0)


def test_displacement_first_passage_fe_against_monte_carlo():
    """The paper system leaving −0.2 < x < 0.4 from the origin: FE τ(0, 0) ≈ 6.761
    (converged to 1e-4 under refinement) against Monte Carlo within 3 SE plus its
    time-step allowance of 0.5 %."""
    s = VibroImpactSystem.paper()
    f = fem.first_passage(s, displacement=(-0.2, 0.4), start=(0.0, 0.0))
    m = montecarlo.first_passage(s, displacement=(-0.2, 0.4), start=(0.0, 0.0),
                                 n_paths=20000, seed=7, progress=False)
    assert f.safe_set.kind == m.safe_set.kind == "displacement"
    assert abs(f.mean - m.mean) <= 3 * m.mean_se + 5e-3 * f.mean, (f.mean, m.mean, m.mean_se)
    t = np.array([1.0, 3.0, 6.0])
    assert np.all(np.abs(f.reliability(t) - m.reliability(t)) <= 0.02)
