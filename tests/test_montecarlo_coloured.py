"""Monte Carlo with coloured external noise (issue 35) on the CPU: the exact Gaussian
of the linear oscillator, the scheme's own discrete covariance (its second order),
the vectorised kernel against the scalar step, the white path untouched, the power
balance with the coloured input, transients, estimates and refusals."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp
from scipy.linalg import expm, solve_discrete_lyapunov

from fpk_vibro import OrnsteinUhlenbeck, VibroImpactSystem, Wall
from fpk_vibro import montecarlo as mc
from fpk_vibro._checks import InputError
from fpk_vibro.linear import drift_and_noise, stationary_covariance
from fpk_vibro.montecarlo import _kernel as K
from fpk_vibro.montecarlo import _setup as S
from fpk_vibro.montecarlo._flight import NX
from fpk_vibro.montecarlo._params import kick_gain
from fpk_vibro.montecarlo._rng import _normal
from fpk_vibro.montecarlo._scalar_step import CPU, encode_walls

#: The scalar step written once (:mod:`._scalar_step`), its CPU compilation.
STEP = CPU.step
TAU = 0.5
LINEAR = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none",
                           external=OrnsteinUhlenbeck(tau=TAU))


def _covariances(sol):
    """(E[x²], E[y²], E[ζ y], E[ζ²]) and their standard errors."""
    m, se, c = sol.moments(), sol.moments_se(), sol.coloured_moments()
    return (np.array([m["E_x2"], m["E_y2"], c["E_zeta_y"], c["E_zeta2"]]),
            np.array([se["E_x2"], se["E_y2"], c["E_zeta_y_se"], c["E_zeta2_se"]]))


def _exact(cov):
    return np.array([cov[0, 0], cov[1, 1], cov[1, 2], cov[2, 2]])


def scheme_covariance(system, h):
    """The stationary covariance of the scheme itself on a linear system without walls
    (D2 = 0): one step B A [O, Z] A B is a linear map of (x, y, ζ) and the normal ξ',
    so its law solves Σ = M Σ Mᵀ + N Nᵀ; y at the step's end, ζ's kick gain κ."""
    a, c, D1, tau = system.a, system.c, system.D1, system.external.tau
    hh, kz = 0.5 * h, kick_gain(h, tau)
    B, A, O = np.eye(4), np.eye(4), np.eye(4)
    B[1, 0], B[1, 2] = -a * hh, kz * hh
    A[0, 1] = hh
    O[1, 1], O[2, 2] = math.exp(-c * h), math.exp(-h / tau)
    O[2, 3] = math.sqrt(D1 / tau * -math.expm1(-2.0 * h / tau))
    T = B @ A @ O @ A @ B
    S_ = solve_discrete_lyapunov(T[:3, :3], T[:3, 3:] @ T[:3, 3:].T)
    return np.array([S_[0, 0], S_[1, 1], kz * S_[1, 2], S_[2, 2]])


def test_linear_oscillator_is_the_exact_gaussian():
    """a = 1, b = 0, c = 0.1, D1 = 0.01, τ = 0.5 without walls: E[x²], E[y²], E[ζ y],
    E[ζ²] within 3 SE + 0.3 % of the Lyapunov covariance (the default step's bias,
    8e-4 on E[x²] by the scheme's own covariance, is inside the 0.3 %)."""
    sol = mc.stationary(LINEAR, n_paths=2048, seed=1, t_sample=5000.0, progress=False)
    est, se = _covariances(sol)
    exact = _exact(stationary_covariance(LINEAR))
    assert np.all(np.abs(est - exact) <= 3 * se + 3e-3 * exact), (est, se, exact)
    assert np.all(se < 3e-3 * exact)                 # the check is tight
    # the coloured force lowers both variances (0.1 with white noise)
    assert est[0] < 0.095 and est[1] < 0.09
    pb = sol.power_balance()                         # input E[ζ y] = c E[y²] (no wall)
    assert abs(pb["residual"]) <= 3 * pb["residual_se"]
    with pytest.raises(InputError, match="white external noise has no state"):
        mc.stationary(LINEAR.replace(external=None), n_paths=64, t_sample=20.0,
                      seed=1, progress=False).coloured_moments()


def test_scheme_is_second_order():
    """At coarse steps the Monte Carlo matches the scheme's exact discrete covariance
    (so the code is that scheme), whose bias falls 4x per halving (weak order 2):
    E[x²] +5.1 % at h = 0.4, +1.24 % at h = 0.2.  κ = 1 (the plain kicks) would give
    +10.6 % at h = 0.4: it is told apart."""
    exact = _exact(stationary_covariance(LINEAR))
    bias = {}
    for h in (0.4, 0.2):
        sol = mc.stationary(LINEAR, n_paths=2048, seed=2, t_sample=1500.0, dt=h,
                            progress=False)
        est, se = _covariances(sol)
        pred = scheme_covariance(LINEAR, h)
        assert np.all(np.abs(est - pred) <= 3 * se + 5e-4 * pred), (h, est, se, pred)
        bias[h] = (pred - exact) / exact
    assert bias[0.4][0] > 0.045 and abs(bias[0.4][0] - 0.106) > 10 * 3e-3
    ratio = bias[0.4][:3] / bias[0.2][:3]
    assert np.all((ratio > 3.7) & (ratio < 4.3)), ratio
    small = (scheme_covariance(LINEAR, 0.05) - exact) / exact
    assert np.all(np.abs(small[:3]) < 1e-3)


@njit
def scalar_reference(xs, ys, zs, rng, starts, n_steps, p, has_d2, maxk, kinds, par,
                     tab_u, tab_r, chunk):
    """Every path by the scalar step of :mod:`._scalar_step` (the step written once),
    the kicks with κ ζ_k and κ ζ_{k+1}, drawing the normals in the kernel's order
    (per block: chunk, step, the y noise's normals of the chunk where D2 > 0, then
    ζ's)."""
    a, bc, hh = p.a, p.b, p.hh
    acc = np.zeros((2, NX))
    rec = (np.zeros((2, 0)), np.zeros((2, 0)), np.zeros(0), acc,
           (0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    nimp = 0
    for b in range(starts.size - 1):
        s0, s1, s2, s3 = rng[b, 0], rng[b, 1], rng[b, 2], rng[b, 3]
        for i0 in range(starts[b], starts[b + 1], chunk):
            n = min(chunk, starts[b + 1] - i0)
            z = np.zeros(n)
            xi = np.empty(n)
            for k in range(n_steps):
                if has_d2:
                    for j in range(n):
                        z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                for j in range(n):
                    xi[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                for j in range(n):
                    i = i0 + j
                    x = xs[i]
                    zn = p.z_e * zs[i] + p.z_s * xi[j]
                    out = STEP(x, ys[i], -(a + bc * x * x) * x, z[j], hh, p.ec, p.sd0,
                               p.d1s2, p.d2s2, a, bc, p.lo, p.hi, p.f_lo, p.f_hi, kinds, par,
                               tab_u, tab_r, has_d2, maxk, 0.0, -1.0, 0, rec, p.z_k * zs[i],
                               p.z_k * zn)
                    xs[i], ys[i], zs[i] = out[0], out[1], zn
                    nimp += out[5] + out[6]
        rng[b, 0], rng[b, 1], rng[b, 2], rng[b, 3] = s0, s1, s2, s3
    return nimp


CASES = {
    "walls, D2": VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.05, delta=0.3, r=0.6,
                                   external=OrnsteinUhlenbeck(tau=0.3)),
    "one wall, short tau": VibroImpactSystem(a=1.0, b=0.5, c=0.05, D1=0.05,
                                             right=Wall(0.2, r=0.8), barriers="right",
                                             external=OrnsteinUhlenbeck(tau=0.01)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_vectorised_kernel_is_the_scalar_step(name):
    """The CPU's vectorised sweep with ζ in its kicks against the scalar step written
    once for every target: the same normals (the streams end in the same state), the
    same impacts, the same paths to rounding; two blocks of 75 paths (a full and a
    partial chunk)."""
    system = CASES[name]
    dt = 2.0 * S.default_dt(system)
    p, ip = S.step_params(system, dt, 64)
    n_paths, n_blocks, n_steps = 150, 2, 300
    starts = S.block_starts(n_paths, n_blocks)
    rng = S.rng_states(np.random.SeedSequence(3).spawn(n_blocks))
    gen = np.random.default_rng(4)
    lo, hi = system.x_bounds
    xs = gen.uniform(max(lo, -1.0), min(hi, 1.0), n_paths)
    ys = gen.normal(0.0, 0.5, n_paths)
    zs = gen.normal(0.0, math.sqrt(system.external.variance(system.D1)), n_paths)
    xr, yr, zr, rr = xs.copy(), ys.copy(), zs.copy(), rng.copy()
    nimp = scalar_reference(xr, yr, zr, rr, starts, n_steps, p, ip.has_d2 != 0, 64,
                            *encode_walls(system), K.CHUNK)
    hist = S.Histograms(system, (), S.check_bins("bins", 10, "t"), n_blocks, 1.0)
    mom, imp = np.zeros((n_blocks, K.NM)), np.zeros((n_blocks, 2))
    xext = np.tile([np.inf, -np.inf], (n_blocks, 1))
    K.advance(xs, ys, rng, starts, n_steps, 0, 0, p, ip, mom, imp, xext, hist.hH, hist.hx,
              hist.hy, hist.hj, threads=1, zeta=zs)
    assert np.array_equal(rng, rr)
    assert imp[:, 0].sum() == nimp > 100
    assert np.array_equal(zs, zr)                      # ζ's own update is exact arithmetic
    assert np.allclose(xs, xr, rtol=0, atol=1e-9)
    assert np.allclose(ys, yr, rtol=0, atol=1e-9)
    assert np.all((xs >= lo) & (xs <= hi))
    with pytest.raises(ValueError, match="zeta"):
        K.advance(xs, ys, rng, starts, 1, 0, 0, p, ip, mom, imp, xext, hist.hH, hist.hx,
                  hist.hy, hist.hj)


@pytest.mark.parametrize("D2, per_step", [(0.0, 1), (0.01, 2)])
def test_normals_drawn(D2, per_step):
    """White noise draws one normal a path-step, as before issue 35 (the white path
    takes none of the coloured code: its records hold no ζ); coloured noise one too
    with D2 = 0 (for ζ) and two with D2 > 0."""
    white = VibroImpactSystem.paper(r=0.92, D2=D2)
    coloured = white.replace(external=OrnsteinUhlenbeck(tau=0.5))
    pw, iw = S.step_params(white, 0.05, 64)
    assert (pw.z_e, pw.z_s, pw.z_k, iw.coloured) == (0.0, 0.0, 0.0, 0) and pw.sd0 > 0
    pc, ic = S.step_params(coloured, 0.05, 64)
    assert pc.sd0 == pc.d1s2 == 0.0 and ic.coloured == 1 and pc.d2s2 == pw.d2s2
    n, steps = 100, 7
    for system, (p, ip), k in ((white, (pw, iw), 1), (coloured, (pc, ic), per_step)):
        starts = S.block_starts(n, 1)
        rng = S.rng_states(np.random.SeedSequence(5).spawn(1))
        floor = rng.copy()
        K.normals_floor(floor, n * steps * k, threads=1)
        hist = S.Histograms(system, (), S.check_bins("bins", 10, "t"), 1, 1.0)
        zeta = np.zeros(n) if ip.coloured else None
        K.advance(np.zeros(n), np.zeros(n), rng, starts, steps, 0, 0, p, ip,
                  np.zeros((1, K.NM)), np.zeros((1, 2)), np.tile([np.inf, -np.inf], (1, 1)),
                  hist.hH, hist.hx, hist.hy, hist.hj, threads=1, zeta=zeta)
        assert np.array_equal(rng, floor)


def test_same_seed_same_bits_and_white_runs_hold_no_zeta():
    system = VibroImpactSystem.paper(r=0.92, D2=0.0, external=OrnsteinUhlenbeck(tau=0.5))
    kw = dict(n_paths=256, n_batches=8, t_sample=400.0, seed=9, progress=False,
              quantities=("energy", "x", "y", "joint", "impacts", "impact_energy",
                          "inter_impact"))
    one = mc.stationary(system, threads=1, **kw)
    two = mc.stationary(system, threads=2, **kw)
    for k, v in one._arrays.items():
        assert np.array_equal(v, two._arrays[k], equal_nan=True), k
    assert one.coloured_moments() == two.coloured_moments()
    assert one.impacts() == two.impacts() and one.inter_impact() == two.inter_impact()
    # the impact records work with ζ too: mean gap = 1/(impact rate), within its SE
    gap, rate = one.mean_inter_impact_time(), one.impact_rate
    assert abs(gap * rate - 1.0) <= 3 * one.mean_inter_impact_time_se() * rate + 0.01
    white = mc.stationary(system.replace(external=None), **kw)
    assert "coloured" not in white._meta
    assert white.moments() != one.moments()


def test_power_balance_with_the_coloured_input():
    """Paper system with walls ±0.6, r = 0.92, D2 = 0, τ = 0.5: E[ζ y] = c E[y²] + the
    walls' losses within 3 residual SE; the white-noise input D1 would leave a
    residual of about +42 % (E[ζ y] ≈ 0.0058 against D1 = 0.01)."""
    system = VibroImpactSystem.paper(r=0.92, D2=0.0, external=OrnsteinUhlenbeck(tau=0.5))
    sol = mc.stationary(system, n_paths=2048, seed=4, t_sample=1500.0, progress=False)
    pb = sol.power_balance()
    assert abs(pb["residual"]) <= 3 * pb["residual_se"], pb
    assert pb["residual_se"] < 0.02
    c = sol.coloured_moments()
    assert abs(c["E_zeta2"] - 0.02) <= 3 * c["E_zeta2_se"] + 1e-3 * 0.02
    white_residual = (system.D1 - pb["damping"] - pb["impacts"]) / system.D1
    assert white_residual > 0.3


def _linear_transient_covariance(system, cov0, t):
    """dΣ/dt = A Σ + Σ Aᵀ + B Bᵀ from Σ(0) = ``cov0``: the exact transient of the
    linear system without walls."""
    A, B = drift_and_noise(system)
    Q = B @ B.T
    n = A.shape[0]

    def rhs(_, s):
        S_ = s.reshape(n, n)
        return (A @ S_ + S_ @ A.T + Q).ravel()
    out = solve_ivp(rhs, (0.0, t), cov0.ravel(), rtol=1e-10, atol=1e-14)
    return out.y[:, -1].reshape(n, n)


def test_transient_from_a_point_is_the_exact_gaussian():
    """From (x, y) = (0.3, 0) exactly and ζ from its stationary law: at t = 0, 2, 8 the
    second moments (x0² added to the covariance's) within 3 SE + 0.3 % of the Lyapunov
    ODE's; at t = 0 E[ζ y] = 0 and E[ζ²] = D1/τ."""
    x0 = 0.3
    times = [0.0, 2.0, 8.0]
    run = mc.transient(LINEAR, initial={"mean": (x0, 0.0), "std": (0.0, 0.0)}, times=times,
                       n_paths=8192, seed=6, progress=False)
    A, _ = drift_and_noise(LINEAR)
    cov0 = np.diag([0.0, 0.0, LINEAR.external.variance(LINEAR.D1)])
    for t, sol in zip(times, run):
        cov = _linear_transient_covariance(LINEAR, cov0, t) if t > 0 else cov0
        from scipy.linalg import expm
        mean = expm(A * t) @ np.array([x0, 0.0, 0.0])
        exact = _exact(cov + np.outer(mean, mean))
        est, se = _covariances(sol)
        tol = 3 * se + 3e-3 * np.abs(exact)
        if t == 0:
            assert est[0] == pytest.approx(x0 * x0, rel=1e-12)
            assert est[1] == 0.0 and est[2] == 0.0
            assert abs(est[3] - exact[3]) <= tol[3]
        else:
            assert np.all(np.abs(est - exact) <= tol), (t, est, se, exact)
    assert run[1].time == 2.0 and "coloured" in run[1]._meta


def test_estimate_covers_the_exact_answer_and_judges_zeta_y(tmp_path):
    """error_estimate() of a coloured answer: 2 SE + the bias from a run at 2 dt (the
    same τ), E[ζ y] among its figures; it covers the exact Lyapunov values; kept by
    save/load with the coloured moments."""
    sol = mc.stationary(LINEAR, n_paths=1024, seed=7, t_sample=1000.0, dt=0.2,
                        progress=False)
    est = sol.error_estimate()
    m, c = sol.moments(), sol.coloured_moments()
    cov = stationary_covariance(LINEAR)
    for key, value, exact in (("E_x2", m["E_x2"], cov[0, 0]), ("E_y2", m["E_y2"], cov[1, 1]),
                              ("E_zeta_y", c["E_zeta_y"], cov[1, 2])):
        assert abs(value - exact) / abs(value) <= est[key], (key, value, exact, est[key])
    assert est["bias"]["E_x2"] > 0.005                 # the 1.2 % bias at dt = 0.2, seen
    back = type(sol).load(sol.save(tmp_path / "coloured.npz"))
    assert back.coloured_moments() == c
    assert back.system.external == LINEAR.external
    assert back.error_estimate()["E_zeta_y"] == est["E_zeta_y"]


def test_refusals_in_one_line():
    system = VibroImpactSystem.paper(r=0.92, D2=0.0, external=OrnsteinUhlenbeck(tau=0.5))
    for call in (lambda: mc.first_passage(system, energy=0.3),
                 lambda: mc.first_passage(system, displacement=(-0.3, 0.3))):
        with pytest.raises(InputError) as e:
            call()
        msg = str(e.value)
        assert "\n" not in msg and "coloured" in msg
        assert "montecarlo.stationary" in msg and "montecarlo.transient" in msg
        assert "fem.stationary" in msg
    with pytest.raises(InputError) as e:
        mc.periodic(system, [0.0])
    assert "\n" not in str(e.value) and "montecarlo.stationary" in str(e.value)
    sol = mc.stationary(system, n_paths=64, n_batches=4, t_sample=20.0, seed=1,
                        progress=False)
    with pytest.raises(InputError) as e:
        sol.error_estimate(paired=True)
    assert "\n" not in str(e.value) and "paired" in str(e.value)
