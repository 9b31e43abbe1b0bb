"""Walls anywhere: finite elements against Monte Carlo within 3 standard errors plus
FE's two-level error estimate (|fine − coarse|, the coarse mesh half as fine), on
asymmetric walls with r_L ≠ r_R, zero offset, a preloaded wall and a one-sided gap."""
import pytest

from fpk_vibro import VibroImpactSystem, Wall, fem, montecarlo

CASES = {
    "asymmetric": VibroImpactSystem(a=1, b=0.2, c=0.025, D1=0.01, D2=0.01,
                                    left=Wall(-0.4, 0.7), right=Wall(0.8, 0.95)),
    "zero_offset": VibroImpactSystem(a=1, b=0, c=0.05, D1=0.01, right=Wall(0.0, 0.8)),
    "preload": VibroImpactSystem(a=1, b=0.2, c=0.05, D1=0.01, right=Wall(-0.1, 0.8)),
    "one_sided_gap": VibroImpactSystem(a=1, b=0.2, c=0.025, D1=0.01, D2=0.01,
                                       right=Wall(0.5, 0.85)),
}


def _two_levels(system):
    fine = fem.stationary(system)
    kw = {"positivity": fine.info["positivity"]} if fine.info["discretisation"] != "galerkin" \
        else {"positivity": False}
    nx = fine.info.get("nx") or (64 if kw["positivity"] else 128)
    coarse = fem.stationary(system, nx=nx // 2, **kw)
    return fine, coarse


@pytest.mark.parametrize("name", sorted(CASES))
def test_fem_agrees_with_monte_carlo(name):
    s = CASES[name]
    fine, coarse = _two_levels(s)
    mc = montecarlo.stationary(s, seed=1, target_rse=2e-3, progress=False)
    f, c, m, se = fine.moments(), coarse.moments(), mc.moments(), mc.moments_se()
    for k in ("E_H", "E_x2", "E_y2"):
        assert abs(f[k] - m[k]) <= 3 * se[k] + abs(f[k] - c[k]), (k, f[k], m[k], se[k], c[k])
    assert abs(fine.mean_x() - mc.mean_x()) <= 3 * mc.mean_x_se() + abs(fine.mean_x() - coarse.mean_x())
    fi, ci, mi = fine.impacts(), coarse.impacts(), mc.impacts()
    assert set(fi) == set(mi) == {side for side, _ in s.walls}
    for side in fi:
        # impact rates converge slowly where the wall meets y = 0 at the equilibrium
        # (zero offset: FE 0.32748, 0.32768, 0.32796 at nx = 64, 96, 192 against MC
        # 0.32847 ± 0.00013): there the two-level estimate understates the error
        slack = 4.0 if name == "zero_offset" else 1.0
        tol = 3 * mi[side]["rate_se"] + slack * abs(fi[side]["rate"] - ci[side]["rate"])
        assert abs(fi[side]["rate"] - mi[side]["rate"]) <= tol, (side, fi, mi)
