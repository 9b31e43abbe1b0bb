"""The 3-D FE solve of coloured external noise (fpk_vibro.fem.coloured): the exact
Gaussian of the linear system, mass and the ζ-marginal, the three-factor assembly, the
white limit, Monte Carlo on the paper case with walls, files and refusals."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fpk_vibro import OrnsteinUhlenbeck, VibroImpactSystem, averaging, fem, montecarlo
from fpk_vibro._checks import InputError
from fpk_vibro.fem.coloured_operator import assemble_coloured, zeta_nodes
from fpk_vibro.fem.kron import kron_sum
from fpk_vibro.fem.mesh import axis_nodes, domain, wall_nodes
from fpk_vibro.linear import stationary_covariance
from fpk_vibro.solution import Solution

LINEAR = VibroImpactSystem(a=1, b=0, c=0.1, D1=0.01, barriers="none",
                           external=OrnsteinUhlenbeck(tau=0.5))
PAPER = VibroImpactSystem.paper(r=0.92, D2=0.0, external=OrnsteinUhlenbeck(tau=0.5))


#: A small grid: both it and its estimate's richer level (18 × 24 × 12) solve in
#: seconds (the defaults' estimate takes a minute on 2 loaded cores).
SMALL = dict(nx=12, ny=16, nz=8)


@pytest.fixture(scope="module")
def linear():
    return fem.stationary(LINEAR, **SMALL)


@pytest.fixture(scope="module")
def paper():
    return fem.stationary(PAPER)


def test_three_factor_kron_sum_is_the_sum_of_kronecker_products():
    rng = np.random.default_rng(3)
    mats = [[sp.random(n, n, density=0.5, random_state=rng).tocsr() for n in (3, 4, 2)]
            for _ in range(3)]
    mats[2][2] = mats[0][2]                 # a shared last factor is folded once
    want = sum(sp.kron(sp.kron(a, b), c) for a, b, c in mats).toarray()
    np.testing.assert_allclose(kron_sum([tuple(m) for m in mats]).toarray(), want,
                               rtol=0, atol=1e-14)


def test_operator_keeps_mass_on_every_zeta_slice():
    dom = domain(PAPER.replace(external=None))
    op = assemble_coloured(PAPER, wall_nodes(dom, 6), axis_nodes(-dom.y_max, dom.y_max, 8,
                                                                 centre=0.0),
                           zeta_nodes(PAPER, 6), 2, dom=dom)
    scale = abs(op.L).max()
    assert np.max(np.abs(np.ones(op.size) @ op.L)) < 1e-13 * scale
    # the impact coupling alone, slice by slice: (1ᵀ B_wall) ⊗ (1ᵀ M_ζ) = 0
    assert np.max(np.abs(np.ones(op.parts["A"].shape[0]) @ op.parts["A"])) < 1e-13 * scale


def test_linear_system_is_the_lyapunov_gaussian_within_the_estimate(linear):
    S = stationary_covariance(LINEAR)
    m, z, est = linear.moments(), linear.coloured_moments(), linear.error_estimate()
    for got, want, key in ((m["E_x2"], S[0, 0], "E_x2"), (m["E_y2"], S[1, 1], "E_y2"),
                           (z["E_zeta_y"], S[1, 2], "E_zeta_y")):
        err = abs(got / want - 1.0)
        assert err <= est[key], (key, err, est[key])
        assert est[key] < 10 * max(err, 1e-5), (key, err, est[key])    # and not loose
    # ζ is autonomous: its marginal is N(0, D1/τ) exactly
    assert z["E_zeta2"] == pytest.approx(S[2, 2], rel=2e-3)     # nz = 8: 1.2e-3 off
    zs = np.linspace(-0.3, 0.3, 7)
    gauss = np.exp(-zs ** 2 / (2 * S[2, 2])) / np.sqrt(2 * np.pi * S[2, 2])
    np.testing.assert_allclose(linear.pdf_zeta(zs), gauss, rtol=3e-2)   # nz = 8: 2.4 % at 2σ


def test_paper_case_power_balance_and_mass(paper):
    assert paper.mass == pytest.approx(1.0, abs=1e-12)
    pb = paper.power_balance()
    # the input is E[ζ y], not D1: the white formula would leave a residual of −43 %
    assert abs(pb["residual"]) < 2e-3
    assert abs((PAPER.D1 - pb["damping"] - pb["impacts"]) / PAPER.D1) > 0.3
    assert paper.info["min_density"] > -1e-3


def test_paper_case_agrees_with_monte_carlo(paper):
    """FE against Monte Carlo within 3 SE + 0.3 % (the issue's cross-check)."""
    mc = montecarlo.stationary(PAPER, seed=35, target_rse=2e-3, n_paths=1024,
                               quantities=("energy", "x", "y", "impacts"))
    fm, mm, se = paper.moments(), mc.moments(), mc.moments_se()
    for key in ("E_H", "E_x2", "E_y2", "P_impact"):
        assert abs(fm[key] - mm[key]) <= 3 * se[key] + 3e-3 * abs(mm[key]), key
    fz, mz = paper.coloured_moments(), mc.coloured_moments()
    assert abs(fz["E_zeta_y"] - mz["E_zeta_y"]) <= 3 * mz["E_zeta_y_se"] + 3e-3 * mz["E_zeta_y"]
    fi, mi = paper.impacts(), mc.impacts()
    for side in ("left", "right"):
        assert abs(fi[side]["rate"] - mi[side]["rate"]) <= \
            3 * mi[side]["rate_se"] + 3e-3 * mi[side]["rate"], side


def test_white_limit_converges_at_first_order():
    """τ → 0: the coloured FE approaches the white FE of the same D1 (walls r = 0.92),
    its E[H] gap halving with τ (order 1: ζ is continuous at an impact while y flips)."""
    white = fem.stationary(PAPER.replace(external=None), degree=3, nx=48).moments()["E_H"]
    gaps = [abs(fem.stationary(PAPER.replace(**{"external.tau": tau}), nx=16, ny=32,
                               nz=12).moments()["E_H"] / white - 1.0)
            for tau in (0.1, 0.05, 0.025)]
    orders = np.log2(np.array(gaps[:-1]) / np.array(gaps[1:]))
    assert np.all((orders > 0.7) & (orders < 1.5)), (gaps, orders)


def test_save_and_load_keep_the_answer(paper, tmp_path):
    path = paper.save(tmp_path / "coloured.npz")
    back = Solution.load(path)
    assert type(back) is type(paper)
    assert back.moments() == paper.moments()
    assert back.coloured_moments() == paper.coloured_moments()
    np.testing.assert_array_equal(back.pdf_zeta([0.0, 0.1]), paper.pdf_zeta([0.0, 0.1]))


@pytest.mark.parametrize("call, match", [
    (lambda: fem.stationary(PAPER, nz=10, ny=15), "ny must be an even integer"),
    (lambda: fem.stationary(PAPER, nz=6), "nz must be"),
    (lambda: fem.stationary(PAPER, positivity=True), "positivity is not an option"),
    (lambda: fem.transient(PAPER, initial={"mean": [0, 0], "std": [0.1, 0.1]},
                           times=[1.0], positivity=True), "positivity is not an option"),
    (lambda: fem.transient(PAPER, initial={"mean": [0, 0], "std": [0.1, 0.1]},
                           times=[1.0], nz=9), "nz must be an even integer"),
    (lambda: averaging.stationary(PAPER), "fem.stationary.*montecarlo"),
    (lambda: fem.first_passage(PAPER, energy=0.2), "coloured external noise"),
])
def test_refusals_are_one_line(call, match):
    with pytest.raises(InputError, match=match) as exc:
        call()
    assert "\n" not in str(exc.value)


def test_inter_impact_is_refused(paper):
    with pytest.raises(InputError, match="montecarlo"):
        paper.mean_inter_impact_time()


def test_rtol_with_a_grid_is_refused_in_one_line():
    with pytest.raises(InputError, match="nx must not be given with rtol"):
        fem.stationary(PAPER, rtol=1e-3, nx=12)


def test_transient_follows_the_lyapunov_ode_within_its_estimate():
    """From x ~ N(0.3, 0.2²), y ~ N(0, 0.2²), ζ stationary: mean and covariance of the
    linear system solve m' = A m, Σ' = A Σ + Σ Aᵀ + B Bᵀ; mass stays 1."""
    from scipy.integrate import solve_ivp
    from scipy.linalg import expm
    from fpk_vibro.linear import drift_and_noise
    A, B = drift_and_noise(LINEAR)
    times = [1.0, 2.0]
    S0 = np.diag([0.04, 0.04, LINEAR.external.variance(LINEAR.D1)])
    cov = solve_ivp(lambda t, v: (A @ v.reshape(3, 3) + v.reshape(3, 3) @ A.T
                                  + B @ B.T).ravel(), (0.0, 2.0), S0.ravel(), t_eval=times,
                    rtol=1e-11, atol=1e-14).y.T.reshape(-1, 3, 3)
    run = fem.transient(LINEAR, initial={"mean": [0.3, 0.0], "std": [0.2, 0.2]},
                        times=times, dt=0.1, **SMALL)
    assert [s.time for s in run] == pytest.approx(times)
    for sol, S, t in zip(run, cov, times):
        mean = expm(A * t) @ np.array([0.3, 0.0, 0.0])
        assert abs(sol.info["mass_drift"]) < 1e-12
        est = sol.error_estimate()
        for key, want in (("E_x2", S[0, 0] + mean[0] ** 2), ("E_y2", S[1, 1] + mean[1] ** 2)):
            err = abs(sol.moments()[key] / want - 1.0)
            assert err <= est[key], (t, key, err, est[key])
            assert est[key] < 20 * max(err, 1e-4)          # and not loose


@pytest.mark.long
def test_rtol_bounds_the_estimated_moments():
    """The issue's speed case: the paper system with walls, τ = 0.5, within 1e-3 (one
    richer level proves the default one; 21 s measured on 2 cores, docs/measurements.md)."""
    sol = fem.stationary(PAPER, rtol=1e-3)
    est = sol.error_estimate()
    assert sol.info["rtol"] == 1e-3 and not sol.info.get("rtol_not_reached")
    assert max(est[k] for k in ("E_H", "E_x2", "E_y2", "P_impact", "E_zeta_y")) <= 1e-3
    assert "L1" in est                       # estimated, not bounded (module docstring)
