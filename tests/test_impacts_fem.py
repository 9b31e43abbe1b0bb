"""Impacts, power balance and first passage from finite elements.

Exact references (r = 1, D2 = 0: p = p_X(x) N(y; 0, σ²), σ² = D1/c):
impact rate at wall w  ν_w = p_X(x_w) σ / sqrt(2π);
impact-speed density   f(u) = (u/σ²) exp(−u²/2σ²) (Rayleigh), mean speed σ sqrt(π/2).
"""
import math

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, Wall, fem

EXACT = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, left=Wall(-0.4), right=Wall(0.8))
SIGMA = math.sqrt(EXACT.D1 / EXACT.c)


def _exact_px(x):
    from scipy import integrate
    w = lambda s: np.exp(-EXACT.c / EXACT.D1 * EXACT.potential(s))
    return w(x) / integrate.quad(w, -0.4, 0.8, epsabs=0, epsrel=1e-13)[0]


def test_impact_rate_and_speed_pdf_are_exact_at_order_two():
    """Measured (Q1, nx = 16, 32, 64): speed-pdf error 7.5e-3, 1.9e-3, 4.7e-4 of its peak."""
    errs = []
    for nx in (16, 32, 64):
        sol = fem.stationary(EXACT, nx=nx, y_max=5.0, positivity=False)
        imp = sol.impacts()
        rate_err = max(abs(imp[s]["rate"] / (_exact_px(w.position) * SIGMA / math.sqrt(2 * math.pi)) - 1)
                       for s, w in EXACT.walls)
        speed_err = max(abs(imp[s]["mean_speed"] / (SIGMA * math.sqrt(math.pi / 2)) - 1)
                        for s, _ in EXACT.walls)
        u = np.linspace(0.02, 2.0, 60)
        f = u / SIGMA ** 2 * np.exp(-u ** 2 / (2 * SIGMA ** 2))
        pdf_err = max(np.max(np.abs(sol.impact_speed_pdf(s, u) - f)) / f.max() for s, _ in EXACT.walls)
        errs.append((rate_err, speed_err, pdf_err))
    errs = np.array(errs)
    assert np.all(errs[-1] < 1e-3), errs
    orders = np.log2(errs[:-1] / errs[1:])
    assert np.all(orders > 1.8), orders


def test_power_balance_residual_falls_under_refinement_and_is_small_on_the_paper():
    """Measured: 2.9e-6, 1.8e-7, 1.1e-8 (Q1 nx = 16, 32, 64 on the exact strip);
    6e-8 and 2.5e-7 at the default mesh for r = 0.92, 0.98 (the y truncation's floor)."""
    res = [abs(fem.stationary(EXACT, nx=n, y_max=5.0, positivity=False).power_balance()["residual"])
           for n in (16, 32, 64)]
    assert all(math.log2(res[i] / res[i + 1]) >= 1.5 for i in range(2)), res
    for r in (0.98, 0.92):
        sol = fem.stationary(VibroImpactSystem.paper(r=r))
        assert abs(sol.info["power_balance_residual"]) < 1e-4
        pb = sol.power_balance()
        assert pb["impacts"] > 0 and pb["damping"] > 0


def test_impact_speed_pdf_is_a_density_and_names_bad_walls():
    sol = fem.stationary(VibroImpactSystem.paper(r=0.92), degree=2, nx=32)
    u = np.linspace(0.0, sol.y_max, 4001)
    assert np.trapezoid(sol.impact_speed_pdf("left", u), u) == pytest.approx(1.0, abs=1e-4)
    assert np.all(sol.impact_speed_pdf("right", -u[1:]) == 0)
    with pytest.raises(ValueError, match="wall"):
        sol.impact_speed_pdf("top", u)
    one = fem.stationary(VibroImpactSystem.paper(r=0.92, barriers="right"), nx=32)
    assert set(one.impacts()) == {"right"}
    with pytest.raises(ValueError, match="wall"):
        one.impact_speed_pdf("left", u)


PAPER = VibroImpactSystem.paper(r=0.92)


def test_mean_first_passage_converges_at_order_two():
    """τ from (0, 0) to H_c = 0.5 (3 E[H]) on the paper case, r = 0.92: measured
    79.683, 80.157, 80.326, 80.449, 80.492, 80.523 at nx = 8, 12, 16, 24, 32, 48."""
    tau = [fem.first_passage(PAPER, energy=0.49833, nx=n).mean for n in (8, 16, 32)]
    order = math.log2((tau[1] - tau[0]) / (tau[2] - tau[1]))
    assert order > 1.5, tau
    assert 80.0 < tau[-1] < 81.0


def test_first_passage_identities():
    fp = fem.first_passage(PAPER, energy=0.5)
    T = np.linspace(0.0, 40 * fp.mean, 40001)
    assert np.trapezoid(fp.reliability(T), T) == pytest.approx(fp.mean, rel=2e-3)   # ∫R = τ
    assert fp.reliability(0.0) == 1.0 and np.all(np.diff(fp.reliability(T)) <= 1e-12)
    assert fp.mean_time(0.3, 0.2) == pytest.approx(fp.mean_time(-0.3, -0.2), rel=1e-10)
    assert fp.mean_time(0.0, math.sqrt(2 * 0.5) * 0.9999) < 1.0        # next to H = H_c
    assert fp.mean_time(0.0, 2.0) == 0.0                               # already out
    st = fem.first_passage(PAPER, energy=0.5, start="stationary")
    assert 0 < st.mean < fp.mean       # the stationary start is already nearer to H_c


@pytest.mark.parametrize("kwargs, words", [
    (dict(energy=-1.0), "energy"), (dict(energy=float("nan")), "energy"),
    (dict(energy=0.5, start=(0.0, 5.0)), "safe set"), (dict(energy=0.5, start=(2.0, 0.0)), "strip"),
    (dict(energy=0.5, start="somewhere"), "start"), (dict(energy=0.5, nx=1), "nx"),
])
def test_first_passage_bad_input_is_one_line(kwargs, words):
    with pytest.raises(ValueError) as exc:
        fem.first_passage(PAPER, **kwargs)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_mean_time_on_a_grid_covering_the_safe_set():
    """Points between the curved boundary H = H_c and the mesh's straight edges get a
    value (τ is O(h²) there), not an error."""
    fp = fem.first_passage(PAPER, energy=0.5)
    X, Y = np.meshgrid(np.linspace(-0.6, 0.6, 61), np.linspace(-1.0, 1.0, 81))
    T = fp.mean_time(X, Y)
    assert T.shape == X.shape and np.all(T >= 0) and np.all(np.isfinite(T))
    assert np.all(T[PAPER.energy(X, Y) >= 0.5] == 0) and T.max() == pytest.approx(fp.mean, rel=0.02)
