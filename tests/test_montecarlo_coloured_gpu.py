"""Coloured external noise on the GPU engine (issue 35), checked on numba's CUDA
simulator (switched on here where no NVIDIA device exists, as in
tests/test_montecarlo_cuda.py): the linear oscillator against the scheme's exact
discrete covariance, the CPU and the GPU engines on one system with walls, and a
transient against the Lyapunov ODE.  The simulator runs the kernels in Python
(~3·10⁴ path-steps/s), so the runs are small and the tolerances their own SEs."""
from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
from scipy.linalg import expm

if "numba.cuda" not in sys.modules:
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

from fpk_vibro import OrnsteinUhlenbeck, VibroImpactSystem  # noqa: E402
from fpk_vibro import montecarlo as mc  # noqa: E402
from fpk_vibro.linear import drift_and_noise, stationary_covariance  # noqa: E402
from fpk_vibro.montecarlo import _kernel as K  # noqa: E402
from fpk_vibro.montecarlo import _setup as S  # noqa: E402
from fpk_vibro.montecarlo._cuda_engine import Ensemble  # noqa: E402
from fpk_vibro.montecarlo._device import simulator  # noqa: E402
from fpk_vibro.montecarlo._summary import _ratio  # noqa: E402

from test_montecarlo_coloured import (LINEAR, _linear_transient_covariance,  # noqa: E402
                                      scheme_covariance)

SIM = simulator() and ("numba.cuda" not in sys.modules
                       or sys.modules["numba.cuda"].config.ENABLE_CUDASIM)
needs_sim = pytest.mark.skipif(not SIM, reason="numba.cuda was imported before this module "
                               "could switch on the CUDA simulator")


@needs_sim
def test_gpu_linear_oscillator_is_the_schemes_gaussian():
    """Burn-in by the CPU kernel, sampling by the GPU kernel with ζ (D2 = 0: one normal
    a step, for ζ): E[x²], E[y²], E[ζ y], E[ζ²] within 3 SE + 0.5 % of the scheme's
    exact covariance at h = 0.2 (and so within its 1.2 % bias of the Lyapunov one)."""
    h, n, nb = 0.2, 128, 16
    p, ip = S.step_params(LINEAR, h, 64)
    starts = S.block_starts(n, nb)
    gen = np.random.default_rng(3)
    xs, ys = np.zeros(n), gen.normal(0.0, 0.3, n)
    zs = gen.normal(0.0, math.sqrt(LINEAR.external.variance(LINEAR.D1)), n)
    none = S.Histograms(LINEAR, (), S.check_bins("bins", 10, None), nb, 1.0)
    junk = (np.zeros((nb, K.NM)), np.zeros((nb, 2)), np.tile([np.inf, -np.inf], (nb, 1)))
    K.advance(xs, ys, S.rng_states(np.random.SeedSequence(4).spawn(nb)), starts, 400, 0, 0,
              p, ip, *junk, none.hH, none.hx, none.hy, none.hj, zeta=zs)
    mom, imp = np.zeros((nb, K.NM)), np.zeros((nb, 2))
    xext = np.tile([np.inf, -np.inf], (nb, 1))
    with np.errstate(over="ignore"):
        Ensemble(LINEAR, xs, ys, 17, zs=zs).advance(
            xs, ys, None, starts, 600, 0, 2, p, ip, mom, imp, xext, none.hH, none.hx,
            none.hy, none.hj, zeta=zs)
    assert mom[:, K.M_N].sum() == n * 300 and imp[:, 1].sum() == n * 600
    est, se = _ratio(mom[:, [K.M_X2, K.M_Y2, K.M_ZY, K.M_Z2]], mom[:, K.M_N])
    est[2], se[2] = p.z_k * est[2], p.z_k * se[2]
    pred = scheme_covariance(LINEAR, h)
    assert np.all(np.abs(est - pred) <= 3 * se + 5e-3 * pred), (est, se, pred)
    assert np.all(se < 0.08 * pred)
    exact = stationary_covariance(LINEAR)
    assert abs(est[0] - exact[0, 0]) <= 3 * se[0] + 0.02 * exact[0, 0]


@needs_sim
def test_cpu_and_gpu_engines_agree_with_walls():
    """The paper system with walls, D2 = 0.01 (the GPU draws a pair of normals a step:
    one for the parametric noise, one for ζ), τ = 0.3, the same short run from the
    same start law on both devices: the moments, E[ζ y], E[ζ²] and the impact rate
    within 3.5 combined SE."""
    system = VibroImpactSystem.paper(r=0.92, external=OrnsteinUhlenbeck(tau=0.3))
    kw = dict(t_burn=20.0, t_sample=60.0, dt=0.1, n_batches=16, bins=10, progress=False)
    with np.errstate(over="ignore"):
        gpu = mc.stationary(system, n_paths=64, seed=5, device="cuda", **kw)
    cpu = mc.stationary(system, n_paths=2048, seed=5, **kw)
    assert gpu.info["device"] != "cpu" and cpu.info["device"] == "cpu"

    def figures(sol):
        m, se, c = sol.moments(), sol.moments_se(), sol.coloured_moments()
        return ({"E_H": m["E_H"], "E_x2": m["E_x2"], "E_y2": m["E_y2"],
                 "E_zeta_y": c["E_zeta_y"], "E_zeta2": c["E_zeta2"],
                 "rate": sol.impact_rate},
                {"E_H": se["E_H"], "E_x2": se["E_x2"], "E_y2": se["E_y2"],
                 "E_zeta_y": c["E_zeta_y_se"], "E_zeta2": c["E_zeta2_se"],
                 "rate": sol.impact_rate_se})
    (g, gs), (c, cs) = figures(gpu), figures(cpu)
    for k in g:
        assert abs(g[k] - c[k]) <= 3.5 * math.hypot(gs[k], cs[k]), (k, g[k], c[k], gs[k])
    assert gpu.impact_rate > 0 and gpu.power_balance()["residual_se"] > 0


@needs_sim
def test_gpu_transient_is_the_exact_gaussian():
    """From (0.3, 0) with ζ from its stationary law, on the GPU: at t = 3 the second
    moments within 3.5 SE (16 batches) + 1 % of the Lyapunov ODE's (h = 0.1: the
    scheme's bias is below 0.4 %); ζ is carried between output times."""
    times = [0.0, 1.5, 3.0]
    with np.errstate(over="ignore"):
        run = mc.transient(LINEAR, initial={"mean": (0.3, 0.0), "std": (0.0, 0.0)},
                           times=times, n_paths=256, dt=0.1, seed=8, bins=10,
                           n_batches=16, device="cuda", progress=False)
    A, _ = drift_and_noise(LINEAR)
    cov0 = np.diag([0.0, 0.0, LINEAR.external.variance(LINEAR.D1)])
    for t, sol in zip(times[1:], run[1:]):
        mean = expm(A * t) @ np.array([0.3, 0.0, 0.0])
        full = _linear_transient_covariance(LINEAR, cov0, t) + np.outer(mean, mean)
        m, se, c = sol.moments(), sol.moments_se(), sol.coloured_moments()
        for v, s, ex in ((m["E_x2"], se["E_x2"], full[0, 0]), (m["E_y2"], se["E_y2"],
                                                              full[1, 1]),
                         (c["E_zeta_y"], c["E_zeta_y_se"], full[1, 2]),
                         (c["E_zeta2"], c["E_zeta2_se"], full[2, 2])):
            assert abs(v - ex) <= 3.5 * s + 0.01 * abs(ex), (t, v, s, ex)
