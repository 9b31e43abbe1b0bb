"""Time between impacts from FE (issue 32): Kac's identity, the density, wall pairs."""
import numpy as np
import pytest

from fpk_vibro import Restitution, VibroImpactSystem, fem

TWO = VibroImpactSystem.paper()
ONE = VibroImpactSystem.paper(r=0.7).replace(left=None)
LAW = TWO.replace(**{"left.r": Restitution.tanh(0.9, 0.2, 1.0),
                     "right.r": Restitution.tanh(0.9, 0.2, 1.0)})


def _rate(sol):
    return sum(v["rate"] for v in sol.impacts().values())


@pytest.mark.parametrize("system", [TWO, ONE, LAW], ids=["two walls", "one wall", "law"])
def test_mean_is_one_over_rate(system):
    # the Galerkin density: exact (the discrete Kac identity, fem.inter_impact), to the
    # solves' rounding
    # (the rate of the operator's outflow functional; impacts() clips the trace at 0)
    for nx in (8, 16):
        sol = fem.stationary(system, degree=2, nx=nx, positivity=False)
        assert abs(sol.mean_inter_impact_time() * sol._inter_impact().rate - 1.0) < 1e-8
    # against impacts()' rate of the default density (made >= 0 by a local correction,
    # its trace clipped at 0): to the size of those changes, shrinking under refinement
    gaps = []
    for nx in (8, 16, 32):
        sol = fem.stationary(system, degree=2, nx=nx)
        gaps.append(abs(sol.mean_inter_impact_time() * _rate(sol) - 1.0))
    assert gaps[2] <= gaps[0] and gaps[2] < 3e-4
    # and the mean converges with the rate (nx = 16 against 32)
    m16 = fem.stationary(system, degree=2, nx=16).mean_inter_impact_time()
    m8 = fem.stationary(system, degree=2, nx=8).mean_inter_impact_time()
    fine = sol.mean_inter_impact_time()
    assert abs(m16 - fine) < abs(m8 - fine) and abs(m16 - fine) < 2e-3 * fine


def test_density_integrates_to_one_and_gives_the_mean():
    sol = fem.stationary(TWO, degree=2, nx=12)
    ii = sol._inter_impact()
    t = ii.times
    tail = ii.survival[-1]
    assert abs(np.trapezoid(ii.density, t) + tail - 1.0) < 2e-3
    mean = np.trapezoid(ii.survival, t) + tail / ii.decay
    assert abs(mean - sol.mean_inter_impact_time()) < 2e-3 * mean
    f = sol.inter_impact_pdf(np.array([0.0, 1.0, 5.0, 100.0]))
    assert np.all(f >= -1e-9) and f[-1] < f[1]


def test_wall_pairs():
    sol = fem.stationary(TWO, degree=2, nx=12)
    pairs = sol.inter_impact_pairs()
    for i in ("left", "right"):
        assert abs(sum(pairs[f"{i}->{j}"]["probability"] for j in ("left", "right")) - 1) < 1e-10
    # symmetric system: the pairs mirror each other
    assert abs(pairs["left->right"]["probability"] - pairs["right->left"]["probability"]) < 1e-6
    # the mean over pairs, weighted by the wall rates, is the mean
    imp = sol.impacts()
    nu = _rate(sol)
    total = sum(imp[i]["rate"] / nu * pairs[f"{i}->{j}"]["probability"]
                * pairs[f"{i}->{j}"]["mean_time"] for i in imp for j in imp)
    assert abs(total - sol.mean_inter_impact_time()) < 1e-6 * total


def test_no_walls_refused():
    sol = fem.stationary(VibroImpactSystem.paper(barriers="none"), degree=2, nx=8)
    with pytest.raises(ValueError, match="no impacts"):
        sol.mean_inter_impact_time()
