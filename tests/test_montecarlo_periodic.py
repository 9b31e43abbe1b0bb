"""montecarlo.periodic and the forced kernels (issue 34): exact Gaussian response of
the linear oscillator, F = 0, the power balance with walls, bit-identity, refusals."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import Harmonic, VibroImpactSystem
from fpk_vibro import montecarlo as mc
from fpk_vibro._checks import InputError
from fpk_vibro.montecarlo import _kernel as K
from fpk_vibro.montecarlo import _setup as S
from fpk_vibro.montecarlo._periodic_grid import instant_weights, step_weights
from fpk_vibro.periodic import PeriodicResponse

W, F, C, D1 = 0.9, 0.1, 0.1, 0.01
PH = np.arange(8) * 2 * np.pi / 8


def _linear(F_=F):
    return VibroImpactSystem(a=1.0, b=0.0, c=C, D1=D1, barriers="none",
                             forcing=Harmonic(F_, W))


@pytest.fixture(scope="module")
def linear():
    return mc.periodic(_linear(), PH, seed=3, n_paths=1024, n_batches=16, phase_bin=0.0,
                       progress=False)


def test_linear_oscillator_is_the_exact_gaussian(linear):
    r = linear
    A = F / math.hypot(1 - W * W, C * W)
    th = math.atan2(C * W, 1 - W * W)
    assert abs(r.amplitude - A) < 3 * r.info["amplitude_se"] + 1e-3 * A
    assert abs(r.lag - th) < 3 * r.info["lag_se"] + 2e-3
    for i, ph in enumerate(PH):                 # phase_bin 0 on the grid: point values
        sol = r.at(i)
        m, se = sol.moments(), sol.moments_se()
        mx = A * math.cos(ph - th)
        my = -A * W * math.sin(ph - th)
        assert abs(sol.mean_x() - mx) < 3 * sol.mean_x_se() + 1e-3 * A
        assert abs(m["E_x2"] - (D1 / C + mx * mx)) < 3 * se["E_x2"] + 3e-3 * m["E_x2"]
        assert abs(m["E_y2"] - (D1 / C + my * my)) < 3 * se["E_y2"] + 3e-3 * m["E_y2"]
    avg = r.average().moments()
    assert abs(avg["E_x2"] - (D1 / C + A * A / 2)) < 3 * r.average().moments_se()["E_x2"] \
        + 3e-3 * avg["E_x2"]


def test_estimate_covers_the_exact_amplitude(linear):
    est = linear.error_estimate()
    A = F / math.hypot(1 - W * W, C * W)
    assert abs(linear.amplitude - A) <= est["amplitude"] + 1e-3 * A
    assert len(est["phases"]) == 8 and "E_x2" in est["phases"][0]
    assert np.isfinite(est["amplitude_bias"])


def test_zero_forcing_is_the_stationary_answer():
    r = mc.periodic(_linear(0.0), PH[::2], seed=5, n_paths=1024, n_batches=16,
                    progress=False)
    assert r.amplitude < 4 * r.info["amplitude_se"]
    for sol in [r.at(i) for i in range(4)] + [r.average()]:
        m, se = sol.moments(), sol.moments_se()
        assert abs(m["E_x2"] - D1 / C) < 3 * se["E_x2"] + 3e-3 * D1 / C
        assert abs(m["E_y2"] - D1 / C) < 3 * se["E_y2"] + 3e-3 * D1 / C


def test_power_balance_with_walls():
    s = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(amplitude=0.2, frequency=0.9))
    r = mc.periodic(s, [0.0], seed=7, n_paths=1024, n_batches=16, n_periods=150,
                    progress=False)
    avg = r.average()
    m, se = avg.moments(), avg.moments_se()
    # ⟨F cos φ E[y]⟩ with E[y] = d/dt E[x]: only the first harmonic works, F A Ω sin θ / 2
    work = 0.2 * r.amplitude * 0.9 * math.sin(r.lag) / 2
    work_se = 0.2 * 0.9 / 2 * math.hypot(r.info["amplitude_se"] * math.sin(r.lag),
                                          r.amplitude * r.info["lag_se"])
    imp = avg.impacts()
    lhs = s.D1 + s.D2 * m["E_x2"] + work
    rhs = s.c * m["E_y2"] + sum(d["energy_rate"] for d in imp.values())
    tol = 3 * math.sqrt((s.D2 * se["E_x2"]) ** 2 + (s.c * se["E_y2"]) ** 2 + work_se ** 2
                        + sum(d["energy_rate_se"] ** 2 for d in imp.values()))
    assert work > 0.05 * lhs                    # the forcing's work is no rounding error
    assert abs(lhs - rhs) < tol + 5e-3 * lhs


def _advance(system, forced_zero):
    p, ip = S.step_params(system, 0.05, 64)
    if forced_zero:
        p = p._replace(f_amp=0.0, f_omega=0.9, f_phase=0.3)
        ip = ip._replace(forced=1)
    nb, n = 2, 200
    rng = S.rng_states(np.random.SeedSequence(11).spawn(nb))
    xs = np.linspace(-0.5, 0.5, n)
    ys = np.linspace(0.3, -0.3, n)
    mom = np.zeros((nb, K.NM))
    imp = np.zeros((nb, 2))
    xext = np.tile([np.inf, -np.inf], (nb, 1))
    e = np.zeros((nb, 0))
    K.advance(xs, ys, rng, S.block_starts(n, nb), 300, 0, 7, p, ip, mom, imp, xext, e, e, e,
              np.zeros((nb, 0, 0)), threads=1, t0=2.0)
    return np.concatenate([xs, ys, mom.ravel(), imp.ravel()])


def test_forced_kernel_with_zero_force_is_the_unforced_kernel():
    s = VibroImpactSystem.paper(r=0.8)
    a, b = _advance(s, False), _advance(s, True)
    assert np.array_equal(a, b)


def test_bin_weights():
    for w in (0.0, 0.05, 0.3):
        for ph in (0.0, 1.234, 2 * np.pi - 1e-3):
            iw, sw = instant_weights(ph, 0.2, 144, w), step_weights(ph, 0.2, 144, w)
            assert math.isclose(sum(iw.values()), 1.0) and min(iw.values()) > 0
            assert math.isclose(sum(sw.values()), 1.0)
            # the weights' mean phase is the phase itself (no first-order shift)
            u = (ph - 0.2) % (2 * np.pi) / (2 * np.pi) * 144
            g = np.array(list(iw)), np.array(list(iw.values()))
            off = (g[0] - u + 72) % 144 - 72
            assert abs(off @ g[1]) < 1e-9


def test_refusals_are_one_line(tmp_path):
    s = _linear()
    for call, word in ((lambda: mc.periodic(s, [7.0]), "phases"),
                       (lambda: mc.periodic(s, PH, phase_bin=2.0), "phase_bin"),
                       (lambda: mc.periodic(_linear().replace(forcing=None), PH), "forc"),
                       (lambda: mc.stationary(s), "forc")):
        with pytest.raises(InputError) as exc:
            call()
        assert "\n" not in str(exc.value) and word in str(exc.value)


def test_transient_with_forcing_follows_the_mean():
    """From rest, E[x](t) of the linear oscillator solves x'' + c x' + x = F cos Ωt."""
    s = _linear()
    t = np.array([2.0, 5.0])
    run = mc.transient(s, initial={"mean": (0.0, 0.0), "std": (0.0, 0.0)}, times=t,
                       n_paths=2048, seed=2, progress=False)
    from scipy.integrate import solve_ivp
    ref = solve_ivp(lambda t_, u: [u[1], F * math.cos(W * t_) - C * u[1] - u[0]],
                    (0, 5), [0, 0], t_eval=t, rtol=1e-10, atol=1e-12).y[0]
    for sol, x in zip(run, ref):
        assert abs(sol.mean_x() - x) < 3 * sol.mean_x_se() + 2e-3 * abs(x)


def test_save_and_load(linear, tmp_path):
    out = PeriodicResponse.load(linear.save(tmp_path / "per"))
    assert out.amplitude == linear.amplitude
    assert out.at(3).moments() == linear.at(3).moments()


def _windowed_amplitude(c, F_, W_, burn, n_per, K_=16):
    """The first harmonic of the exact mean of x'' + c x' + x = F cos(Ωt) from rest,
    sampled as montecarlo.periodic samples it: K_ phases of every period after
    ``burn`` periods, averaged per phase over ``n_per`` periods."""
    from fpk_vibro.forcing import first_harmonic
    A = F_ / math.hypot(1 - W_ * W_, c * W_)
    th = math.atan2(c * W_, 1 - W_ * W_)
    T, wd = 2 * math.pi / W_, math.sqrt(1 - c * c / 4)
    C1 = -A * math.cos(th)                       # the transient cancels x(0), x'(0)
    C2 = (-A * W_ * math.sin(th) + c / 2 * C1) / wd
    j = np.arange(1, K_ * n_per + 1)
    t = burn * T + j * T / K_
    x = A * np.cos(W_ * t - th) + np.exp(-c * t / 2) * (C1 * np.cos(wd * t) + C2 * np.sin(wd * t))
    ex = x.reshape(n_per, K_).mean(axis=0)      # phases 1/K_ .. 1 of a period
    return first_harmonic(2 * math.pi * np.arange(1, K_ + 1) / K_, ex)[1]


def test_near_resonance_burn_in_covers_the_mean_transient():
    """Ω = 1 = ω0, c = 0.05: the mean amplitude F/(cΩ) = 1 builds up like e^{−ct/2},
    at half the noise's relaxation rate.  A reduced run (512 paths, 20 periods) with the
    default burn-in (12/c) meets the exact amplitude within its SE and its estimate;
    the old rule's 6/c (20 periods) is seen 1.3 % low, as the exact transient says."""
    c, F_, D1_ = 0.05, 0.05, 1e-4
    s = VibroImpactSystem(a=1.0, b=0.0, c=c, D1=D1_, barriers="none",
                          forcing=Harmonic(F_, 1.0))
    kw = dict(seed=1, n_paths=512, n_periods=20, progress=False)
    r = mc.periodic(s, [0.0, math.pi / 2], **kw)
    assert r.info["burn_periods"] == math.ceil(12 / c / (2 * math.pi))
    se = r.info["amplitude_se"]
    assert abs(r.amplitude - 1.0) < 3 * se + 5e-4
    assert abs(r.amplitude - 1.0) <= r.error_estimate()["amplitude"]
    assert abs(r.lag - math.pi / 2) < 3 * r.info["lag_se"] + 1e-3
    m = r.at(1).moments()                       # φ = π/2: E[x] = A, E[x²] = D1/c + A²
    assert abs(m["E_x2"] - (D1_ / c + 1.0)) < 3 * r.at(1).moments_se()["E_x2"] + 3e-3
    old = mc.periodic(s, [0.0], burn_periods=20, **kw)
    pred = _windowed_amplitude(c, F_, 1.0, 20, 20)
    assert 1.0 - pred > 8 * old.info["amplitude_se"]        # the old rule's bias shows
    assert abs(old.amplitude - pred) < 3 * old.info["amplitude_se"] + 5e-4


def test_estimate_counts_the_periodic_work():
    """fpk-vibro check's cost: n_paths × (burn + n_periods) × steps per period, plus
    the bias run at 2 dt (half the steps)."""
    from fpk_vibro.montecarlo.options import Options
    s = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(amplitude=0.05, frequency=1.0))
    o = Options.from_call("periodic", {"n_paths": 512, "n_periods": 20})
    pl = o.periodic_plan(s)
    assert pl["burn_periods"] == math.ceil(12 / 0.025 / (2 * math.pi))
    cost = o.estimate(s, "periodic")
    periods = pl["burn_periods"] + 20
    assert cost.work == 512 * periods * (pl["M"] + pl["M"] // 2)
    assert cost.unit == "path-steps" and cost.seconds > 1.0
    r = mc.periodic(s, [0.0], seed=1, n_paths=512, n_periods=20, progress=False,
                    quantities=())
    assert r.info["steps_per_period"] == pl["M"]
    assert r.info["burn_periods"] == pl["burn_periods"]
