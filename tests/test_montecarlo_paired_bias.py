"""The paired time-step bias run of ``error_estimate()`` (fpk_vibro.montecarlo._paired):
the coarse path driven by the fine path's increments, so the noise cancels batch by
batch."""
from __future__ import annotations

import math

import pytest

from fpk_vibro import VibroImpactSystem, Wall
from fpk_vibro import montecarlo as mc
from fpk_vibro.exact import gibbs
from fpk_vibro.montecarlo._paired import stationary_pairs

LINEAR = VibroImpactSystem(a=1.0, b=0.0, c=0.5, D1=0.1, barriers="none")


def test_pairing_cancels_the_noise_on_a_linear_oscillator():
    # coupled linear paths at h and 2h differ by O(h²) for ever: the difference's SE
    # is far below the run's own (independent runs: sqrt(2) x it)
    sol = mc.stationary(LINEAR, n_paths=512, t_sample=100.0, seed=3, progress=False)
    d, step = stationary_pairs(sol)
    se = sol.moments_se()
    assert step == "2 dt"
    for k in ("E_H", "E_x2", "E_y2"):
        assert d[k][1] < 0.1 * se[k], (k, d[k], se[k])
    # BAOAB samples x exactly for a linear force: no bias in E[x²] between h and 2h
    assert abs(d["E_x2"][0]) <= 3 * d["E_x2"][1] + 1e-12 * se["E_x2"]


@pytest.mark.parametrize("system", [
    VibroImpactSystem(a=-1.0, b=1.0, c=0.5, D1=0.1, barriers="none"),
    VibroImpactSystem(a=1.0, b=0.5, c=0.2, D1=0.05, left=Wall(-0.4, r=1.0),
                      right=Wall(0.5, r=1.0)),
    LINEAR,
], ids=["double well", "elastic walls", "linear"])
def test_estimate_covers_the_true_error_and_is_not_vacuous(system):
    ref = gibbs(system).moments()
    sol = mc.stationary(system, n_paths=512, t_sample=200.0, seed=5, progress=False)
    est = sol.error_estimate(paired=True)
    assert "paired" in est["assumes"]
    m, se = sol.moments(), sol.moments_se()
    for k in ("E_H", "E_x2", "E_y2"):
        true = abs(m[k] - ref[k]) / abs(ref[k])
        rel_se = se[k] / abs(ref[k])
        assert true <= est[k], (k, true, est[k])
        # not vacuous: within 10x of what the statistics allow (2 SE), and of the
        # true error where that is larger
        assert est[k] <= 10 * max(true, 2 * rel_se), (k, true, est[k], rel_se)
        assert math.isfinite(est["bias"][k])
