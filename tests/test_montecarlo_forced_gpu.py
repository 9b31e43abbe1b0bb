"""Harmonic forcing on the GPU engine (issues 33, 34), on numba's CUDA simulator.

The forced step of :mod:`fpk_vibro.montecarlo._scalar_step` (compiled for the GPU)
against its CPU compilation and against the CPU engine's vectorised kernel on the same
normals; the unforced kernels unchanged by a zero force; a tiny periodic run on the
simulator against the CPU engine within standard errors.  The simulator must be on
before ``numba.cuda`` is first imported (as in tests/test_montecarlo_cuda.py).
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
from numba import njit

if "numba.cuda" not in sys.modules:
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

from fpk_vibro import Harmonic, VibroImpactSystem, Wall  # noqa: E402
from fpk_vibro import montecarlo as mc  # noqa: E402
from fpk_vibro.montecarlo import _kernel as K  # noqa: E402
from fpk_vibro.montecarlo import _setup as S  # noqa: E402
from fpk_vibro.montecarlo._cuda_engine import Ensemble, steps_given  # noqa: E402
from fpk_vibro.montecarlo._device import simulator  # noqa: E402
from fpk_vibro.montecarlo._rng import _normal  # noqa: E402
from fpk_vibro.restitution import Restitution  # noqa: E402

SIM = simulator() and ("numba.cuda" not in sys.modules
                       or sys.modules["numba.cuda"].config.ENABLE_CUDASIM)
pytestmark = pytest.mark.skipif(not SIM, reason="numba.cuda was imported before this "
                                "module could switch on the CUDA simulator")


def _cases():
    f = Harmonic(amplitude=0.6, frequency=1.3, phase=0.4)
    narrow = VibroImpactSystem(a=1.0, b=0.2, c=0.01, D1=0.5, left=Wall(-0.05, r=1.0),
                               right=Wall(0.05, r=0.995), forcing=f)
    law = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.01, left=Wall(-0.35, r=0.7),
                            right=Wall(0.4, r=Restitution.tanh(0.9, 0.2, 1.0)), forcing=f)
    one = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, right=Wall(0.3, r=0.0),
                            barriers="right", forcing=f)
    return {"several impacts a flight": (narrow, 0.1, 8.0), "laws, D2": (law, 0.05, 1.5),
            "one wall, r=0": (one, 0.05, 1.0)}


@pytest.mark.parametrize("case", list(_cases()))
def test_forced_gpu_step_matches_cpu_scalar_copy(case):
    system, dt, speed = _cases()[case]
    rng = np.random.default_rng(7)
    n, k = 6, 50
    lo, hi = (max(v, -0.3) if i == 0 else min(v, 0.3) for i, v in enumerate(system.x_bounds))
    xs, ys = rng.uniform(lo, hi, n), rng.normal(0.0, speed, n)
    zs = rng.standard_normal((k, n))
    kw = dict(speeds=8, u_iw=4.0, energies=6, e_iw=8.0, gaps=8, g_iw=2.0, track=True,
              t0=3.7)
    cpu = steps_given(system, dt, xs, ys, zs, target="cpu", **kw)
    with np.errstate(over="ignore"):
        gpu = steps_given(system, dt, xs, ys, zs, target="cuda", **kw)
    for a, b in zip(cpu, gpu):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    assert cpu[4][:, [0, 4]].sum() > 0, "no impact: the case tests nothing"
    free = steps_given(system.replace(forcing=None), dt, xs, ys, zs, target="cpu", **kw)
    assert np.abs(free[0] - cpu[0]).max() > 1e-3          # the forcing acts


@njit
def _stream_normals(rng, n, k):
    """The normals the CPU engine's block 0 draws for n ≤ 64 paths and k steps."""
    s0, s1, s2, s3 = rng[0, 0], rng[0, 1], rng[0, 2], rng[0, 3]
    zs = np.empty((k, n))
    for i in range(k):
        for j in range(n):
            zs[i, j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
    return zs


@pytest.mark.parametrize("case", list(_cases()))
def test_forced_cpu_vectorised_kernel_matches_scalar_copy(case):
    """K.advance (vectorised sweep, merged kicks h g_k, the exact step for paths at a
    wall) against the scalar copy on the same normals, from t0 = 3.7."""
    system, dt, speed = _cases()[case]
    n, k, t0 = 20, 50, 3.7
    rng = S.rng_states(np.random.SeedSequence(4).spawn(1))
    zs = _stream_normals(rng.copy(), n, k)
    g = np.random.default_rng(8)
    lo, hi = (max(v, -0.3) if i == 0 else min(v, 0.3) for i, v in enumerate(system.x_bounds))
    xs, ys = g.uniform(lo, hi, n), g.normal(0.0, speed, n)
    ref = steps_given(system, dt, xs, ys, zs, target="cuda", t0=t0)
    p, ip = S.step_params(system, dt, 64)
    x, y = xs.copy(), ys.copy()
    mom, imp = np.zeros((1, K.NM)), np.zeros((1, 2))
    xext, e = np.tile([np.inf, -np.inf], (1, 1)), np.zeros((1, 0))
    K.advance(x, y, rng, S.block_starts(n, 1), k, 0, 0, p, ip, mom, imp, xext, e, e, e,
              np.zeros((1, 0, 0)), threads=1, law=S.wall_laws(system), t0=t0)
    np.testing.assert_allclose(x, ref[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(y, ref[1], rtol=1e-12, atol=1e-12)
    assert imp[0, 0] == ref[4][:, [0, 4]].sum() > 0


def _ens_run(system, p, ip, seed=9):
    n, nb = 12, 3
    g = np.random.default_rng(1)
    xs, ys = g.uniform(-0.2, 0.2, n), g.normal(0, 1.0, n)
    mom, imp = np.zeros((nb, K.NM)), np.zeros((nb, 2))
    xext, walls = np.tile([np.inf, -np.inf], (nb, 1)), np.zeros((nb, 2, 4))
    e = np.zeros((nb, 0))
    with np.errstate(over="ignore"):
        Ensemble(system, xs, ys, seed).advance(xs, ys, None, None, 40, 0, 3, p, ip, mom, imp,
                                               xext, e, e, e, np.zeros((nb, 0, 0)),
                                               walls=walls, t0=1.5)
    return np.concatenate([xs, ys, mom.ravel(), imp.ravel(), walls.ravel()])


def test_gpu_zero_force_is_the_unforced_kernel_bit_for_bit():
    system = VibroImpactSystem.paper(r=0.8)
    p, ip = S.step_params(system, 0.05, 64)
    a = _ens_run(system, p, ip)
    b = _ens_run(system, p._replace(f_amp=0.0, f_omega=0.9, f_phase=0.3),
                 ip._replace(forced=1))
    assert np.array_equal(a, b)
    f = Harmonic(0.3, 0.9)
    c = _ens_run(system.replace(forcing=f), *S.step_params(system.replace(forcing=f), 0.05, 64))
    assert not np.array_equal(a, c)


@pytest.fixture
def sim_device(monkeypatch):
    """device = "cuda" resolved to the simulator (numba-cuda's simulator may answer
    is_available() False when numba was configured before this module ran)."""
    from fpk_vibro.montecarlo import _device
    monkeypatch.setattr(_device, "available", lambda: (True, ""))
    monkeypatch.setattr(_device, "describe", lambda: {"gpu": "CUDA simulator"})


def test_tiny_forced_periodic_run_agrees_with_cpu(sim_device):
    """The linear oscillator near resonance (exact mean amplitude F/sqrt((1−Ω²)² + c²Ω²))
    on the simulator and on the CPU: each within its SE of the exact answer and of the
    other; the average's E[x²] and the impact-free wall sums alike."""
    c, F, W, D1 = 0.2, 0.1, 0.9, 0.004
    s = VibroImpactSystem(a=1.0, b=0.0, c=c, D1=D1, barriers="none", forcing=Harmonic(F, W))
    A = F / math.hypot(1 - W * W, c * W)
    kw = dict(seed=2, n_paths=64, n_batches=8, n_periods=6, progress=False, dt=0.2,
              phase_bin=0.0)
    with np.errstate(over="ignore"):
        gpu = mc.periodic(s, [0.0, math.pi], device="cuda", **kw)
    cpu = mc.periodic(s, [0.0, math.pi], **kw)
    assert gpu.info["burn_periods"] == cpu.info["burn_periods"] > 0
    assert gpu.average().info["device"] != "cpu"
    for r in (gpu, cpu):
        assert abs(r.amplitude - A) < 3 * r.info["amplitude_se"] + 2e-3 * A
    se = math.hypot(gpu.info["amplitude_se"], cpu.info["amplitude_se"])
    assert abs(gpu.amplitude - cpu.amplitude) < 3 * se
    for i in range(2):
        a, b = gpu.at(i), cpu.at(i)
        d = math.hypot(a.moments_se()["E_x2"], b.moments_se()["E_x2"])
        assert abs(a.moments()["E_x2"] - b.moments()["E_x2"]) < 3 * d
        assert a.moments()["E_x2"] > D1 / c          # the forced mean adds A² cos² ...
    ga, ca = gpu.average().moments(), cpu.average().moments()
    assert abs(ga["E_x2"] - (D1 / c + A * A / 2)) < 3 * gpu.average().moments_se()["E_x2"] \
        + 3e-3 * ga["E_x2"]
    assert ga["E_x2"] > 0 and ca["E_x2"] > 0


def test_forced_transient_on_the_gpu_follows_the_mean(sim_device):
    """From rest the mean of the linear oscillator solves x'' + c x' + x = F cos Ωt."""
    from scipy.integrate import solve_ivp
    c, F, W = 0.1, 0.1, 0.9
    s = VibroImpactSystem(a=1.0, b=0.0, c=c, D1=0.001, barriers="none",
                          forcing=Harmonic(F, W))
    t = np.array([3.0, 6.0])
    with np.errstate(over="ignore"):
        run = mc.transient(s, initial={"mean": (0.0, 0.0), "std": (0.0, 0.0)}, times=t,
                           n_paths=64, n_batches=8, seed=2, dt=0.1, progress=False,
                           device="cuda")
    ref = solve_ivp(lambda t_, u: [u[1], F * math.cos(W * t_) - c * u[1] - u[0]],
                    (0, 6), [0, 0], t_eval=t, rtol=1e-10, atol=1e-12).y[0]
    for sol, x in zip(run, ref):
        assert abs(sol.mean_x() - x) < 3 * sol.mean_x_se() + 2e-3 * abs(x)
        assert sol.info["device"] != "cpu"
