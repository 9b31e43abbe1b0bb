"""Monte Carlo time between impacts: the exact identity mean = 1/(total impact rate)
within the standard errors (two inelastic walls, one wall), the density and the wall
pairs, kept only when asked, saved and loaded, and in the error estimate."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import Restitution, Solution, VibroImpactSystem, Wall
from fpk_vibro import montecarlo as mc

TWO = VibroImpactSystem.paper(r=0.7).replace(**{"right.r": Restitution.tanh(0.9, 0.3, 0.5)})
ONE = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.02, right=Wall(0.3, r=0.6))
KW = dict(n_paths=512, t_sample=600.0, progress=False,
          quantities=("x", "inter_impact", "impact_energy"))


@pytest.fixture(scope="module", params=["two walls", "one wall"])
def run(request):
    system = TWO if request.param == "two walls" else ONE
    return mc.stationary(system, seed=21, **KW)


def test_mean_time_between_impacts_is_one_over_the_impact_rate(run):
    mean, se = run.mean_inter_impact_time(), run.mean_inter_impact_time_se()
    inv, inv_se = 1.0 / run.impact_rate, run.impact_rate_se / run.impact_rate ** 2
    assert se > 0 and inv_se > 0
    assert abs(mean - inv) <= 3.0 * math.hypot(se, inv_se), (mean, inv, se, inv_se)
    gaps = run.inter_impact()
    assert gaps["unseen"] < 1e-3            # every sampled impact but a few has its gap
    pairs = gaps["pairs"]
    assert sum(p["count"] for p in pairs.values()) == gaps["count"]
    assert sum(p["fraction"] for p in pairs.values()) == pytest.approx(1.0, abs=1e-12)
    assert set(pairs) == ({"right->right"} if run.system.left is None else
                          {"left->left", "left->right", "right->left", "right->right"})


def test_inter_impact_density(run):
    edges, dens, se = run.inter_impact_histogram()
    w = np.diff(edges)
    assert np.all(dens >= 0) and edges[0] == 0.0
    assert np.sum(dens * w) == pytest.approx(1.0 - run.overflow["inter_impact"], abs=1e-12)
    assert run.overflow["inter_impact"] < 1e-3
    mid = 0.5 * (edges[1:] + edges[:-1])
    assert np.sum(mid * dens * w) == pytest.approx(run.mean_inter_impact_time(), abs=w[0])
    assert np.array_equal(run.inter_impact_pdf(mid), dens)
    assert run.inter_impact_pdf([-1.0, edges[-1] * 2]).tolist() == [0.0, 0.0]
    for side, _ in run.system.walls:
        d = run.impacts()[side]
        assert run.mean_impact_energy(side) == pytest.approx(d["energy_rate"] / d["rate"],
                                                             rel=1e-12)


def test_kept_only_when_asked_and_saved(tmp_path):
    kw = dict(seed=3, n_paths=128, t_sample=100.0, progress=False)
    plain = mc.stationary(TWO, quantities=("x",), **kw)
    asked = mc.stationary(TWO, quantities=("x", "inter_impact", "impact_energy"), **kw)
    assert plain.moments() == asked.moments() and plain.impacts() == asked.impacts()
    with pytest.raises(ValueError, match="inter_impact"):
        plain.mean_inter_impact_time()
    with pytest.raises(ValueError, match="needs a wall|no wall"):
        mc.stationary(VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.1, barriers="none"),
                      quantities=("inter_impact",), **kw)
    with pytest.raises(ValueError, match="stationary only"):
        mc.transient(TWO, initial={"mean": (0, 0), "std": (0.1, 0.1)}, times=[1.0],
                     quantities=("impact_energy",), n_paths=64, progress=False)
    back = Solution.load(asked.save(tmp_path / "s.npz"))
    assert back.inter_impact() == asked.inter_impact()
    assert np.array_equal(back.inter_impact_histogram()[1], asked.inter_impact_histogram()[1])
    assert np.array_equal(back.impact_energy_pdf("left", [0.01, 0.02]),
                          asked.impact_energy_pdf("left", [0.01, 0.02]))
    est = asked.error_estimate()
    for k in ("mean_inter_impact_time", "mean_impact_energy_left",
              "mean_impact_energy_right"):
        assert 0 < est[k] < 1 and math.isfinite(est["bias"][k]), k
    assert est["mean_inter_impact_time"] >= 2 * asked.mean_inter_impact_time_se() / \
        asked.mean_inter_impact_time()
