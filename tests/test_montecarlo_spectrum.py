"""Monte Carlo spectra and correlations (issue 36): ``montecarlo.spectrum``.

Exact references: the linear oscillator without walls, white or coloured (the
closed forms of :func:`fpk_vibro.linear.spectrum`; its R(τ) = (e^{Aτ} Σ)_qq computed
here at the lags themselves), and the Gibbs variances with walls (r = 1, D2 = 0:
E[y²] = D1/c exactly, E[x²] from the density).  Identities: ∫ S dω over the band =
the sample variance; R(0) = the variance.  Each comparison is within a few standard
errors (fixed seeds) plus a stated small tolerance; the standard errors themselves
are checked (Σ z² / n near 1).
"""
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
from fpk_vibro._checks import InputError  # noqa: E402
from fpk_vibro.exact import gibbs  # noqa: E402
from fpk_vibro.forcing import Harmonic  # noqa: E402
from fpk_vibro.linear import drift_and_noise, stationary_covariance  # noqa: E402
from fpk_vibro.linear import spectrum as exact_spectrum  # noqa: E402
from fpk_vibro.montecarlo import spectrum  # noqa: E402
from fpk_vibro.montecarlo._device import simulator  # noqa: E402
from fpk_vibro.restitution import Restitution  # noqa: E402
from fpk_vibro.spectrum import Spectrum  # noqa: E402

SIM = simulator() and ("numba.cuda" not in sys.modules
                       or sys.modules["numba.cuda"].config.ENABLE_CUDASIM)
needs_sim = pytest.mark.skipif(not SIM, reason="numba.cuda was imported before this module "
                               "could switch on the CUDA simulator")
LINEAR = VibroImpactSystem(a=1.0, b=0.0, c=0.2, D1=0.02, barriers="none")
W = np.linspace(0.0, 2.5, 51)
#: Welch resolution at T = 500 s and c = 0.2: (16π²/3)/(cT)² = 5e-3 of the peak at most;
#: with the bias estimate added to the tolerance below.
RUN = dict(seed=21, n_paths=128, n_batches=16, t_sample=6000.0, segment=500.0,
           progress=False)


def exact_R(system, of, tau):
    A, _ = drift_and_noise(system)
    Sig = stationary_covariance(system)
    q = {"x": 0, "y": 1}[of]
    return np.array([(expm(A * t) @ Sig)[q, q] for t in np.atleast_1d(tau)])


@pytest.fixture(scope="module")
def linear_x():
    return spectrum(LINEAR, W, "x", **RUN)


@pytest.mark.parametrize("of", ["x", "y"])
def test_linear_spectrum_is_the_exact_one(of, linear_x):
    """S_xx and S_yy within 3.5 SE + |the resolution bias estimate| + 1e-3 max S of the
    closed form at 51 frequencies through the peak; Σ z²/n near 1 (honest SEs)."""
    sp = linear_x if of == "x" else spectrum(LINEAR, W, of, **RUN)
    ex = exact_spectrum(LINEAR, W, of).density
    err = np.abs(sp.density - ex)
    res = np.abs(sp.info["resolution_bias"])
    assert np.all(err <= 3.5 * sp.se + res + 1e-3 * ex.max()), np.max((err - res) / sp.se)
    z = (sp.density - ex)[W > 0] / sp.se[W > 0]
    assert 0.4 < np.mean(z ** 2) < 2.0
    k = int(np.argmax(ex))
    assert sp.se[k] < 0.03 * ex[k]                                # the test has teeth
    peak = math.sqrt(LINEAR.a - LINEAR.c ** 2 / 2) if of == "x" else math.sqrt(LINEAR.a)
    assert sp.info["peak_frequency"] == pytest.approx(
        peak, abs=4 * sp.info["peak_frequency_se"] + 2e-3)


def test_integral_is_the_variance_and_r0():
    """Over a band to 4 ω0 the integral of S is the sample variance (up to the tail,
    2e-4 here) and R(0) is the variance; both within 3 SE of the exact D1/(a c)."""
    sp = spectrum(LINEAR, np.linspace(0.0, 4.0, 801), "x", **RUN)
    assert sp.integral() == pytest.approx(sp.variance, rel=3e-3)
    assert float(sp.correlation(0.0)) == pytest.approx(sp.variance,
                                                       abs=sp.info["variance_se"])
    var = LINEAR.D1 / (LINEAR.a * LINEAR.c)
    assert abs(sp.variance - var) <= 3.0 * sp.info["variance_se"]
    assert sp.info["variance_se"] < 0.02 * var


@pytest.mark.parametrize("of", ["x", "y"])
def test_linear_correlation_is_the_exact_one(of, linear_x):
    sp = linear_x if of == "x" else spectrum(LINEAR, W, of, **RUN)
    tau = np.array([0.0, 0.7, 1.6, 3.1, 6.0, 15.0])
    R = sp.correlation(tau)
    ex = exact_R(LINEAR, of, tau)
    lags = sp.lags
    se = np.interp(tau, lags, sp.info["correlation_se"])
    assert np.all(np.abs(R - ex) <= 3.5 * se + 2e-3 * ex[0])
    assert lags[-1] >= 0.5 * sp.info["segment"] * 0.99


def test_coloured_noise_spectrum():
    """OU external noise (τ = 0.5): the exact coloured S_xx (3 × 3 transfer function)."""
    system = LINEAR.replace(external=OrnsteinUhlenbeck(tau=0.5))
    w = np.linspace(0.2, 2.0, 19)
    sp = spectrum(system, w, "x", **{**RUN, "t_sample": 3000.0})
    ex = exact_spectrum(system, w, "x").density
    assert np.all(np.abs(sp.density - ex) <= 3.5 * sp.se + 2e-3 * ex.max())
    assert sp.variance == pytest.approx(stationary_covariance(system)[0, 0],
                                        abs=3.5 * sp.info["variance_se"])


def test_gibbs_walls_variances_and_error_estimate():
    """Walls with r = 1, D2 = 0: Var y = D1/c and Var x = E[x²] of the Gibbs density
    within 3.5 SE; the error estimate has every key, is at least 2 SE, and its
    time-step part comes from a run at 2 dt."""
    system = VibroImpactSystem.paper(r=1.0, D2=0.0)
    g = gibbs(system)
    w = np.linspace(0.0, 2.5, 26)
    kw = dict(seed=3, n_paths=128, n_batches=16, t_sample=2000.0, segment=500.0,
              progress=False)
    sx = spectrum(system, w, "x", **kw)
    sy = spectrum(system, w, "y", **kw)
    assert abs(sy.variance - system.D1 / system.c) <= 3.5 * sy.info["variance_se"]
    assert abs(sx.variance - g.moments()["E_x2"]) <= 3.5 * sx.info["variance_se"]
    assert sx.mean == 0.0 and sy.mean == 0.0
    e = sx.error_estimate()
    for key in ("density", "relative", "variance", "correlation", "assumes", "time_step"):
        assert key in e
    assert np.all(e["density"] >= 2.0 * sx.se)
    assert "2 dt" in e["assumes"] and 0 < e["relative"] < 0.5


def test_laws_and_parametric_noise_run_and_keep_the_identities():
    """A speed-dependent restitution and D2 > 0: ∫ S = Var x, R(0) = Var x (the
    window's weighting apart: within the SE of Var x), S ≥ 0."""
    system = VibroImpactSystem.paper(r=Restitution.tanh(0.95, 0.3, 0.4))
    w = np.linspace(0.0, 4.0, 401)
    sp = spectrum(system, w, "x", seed=4, n_paths=64, n_batches=8, t_sample=1500.0,
                  segment=300.0, progress=False)
    assert np.all(sp.density >= 0) and np.all(np.isfinite(sp.se))
    assert sp.integral() == pytest.approx(sp.variance, rel=0.01)
    assert float(sp.correlation(0.0)) == pytest.approx(sp.variance,
                                                       abs=sp.info["variance_se"])
    assert 1.0 < sp.peak_frequency() < 1.3


def test_same_seed_same_spectrum_and_the_file_round_trip(tmp_path):
    kw = dict(seed=8, n_paths=32, n_batches=4, t_sample=400.0, segment=100.0,
              progress=False)
    w = np.linspace(0.0, 2.0, 21)
    a = spectrum(LINEAR, w, "y", **kw)
    b = spectrum(LINEAR, w, "y", threads=1, **kw)
    c = spectrum(LINEAR, w, "y", **{**kw, "seed": 9})
    assert np.array_equal(a.density, b.density) and np.array_equal(a.lags, b.lags)
    assert np.array_equal(a.correlation(a.lags), b.correlation(b.lags))
    assert not np.array_equal(a.density, c.density)
    a.error_estimate()
    back = Spectrum.load(a.save(tmp_path / "s"))
    assert np.array_equal(back.density, a.density) and np.array_equal(back.se, a.se)
    assert back.of == "y" and back.method == "montecarlo" and back.system == LINEAR
    assert np.array_equal(back.error_estimate()["density"], a.error_estimate()["density"])


@pytest.mark.parametrize("kw, name", [
    (dict(omega=[-1.0, 1.0]), "omega"), (dict(omega=[1.0, 0.5]), "omega"),
    (dict(omega=[0.0, math.nan]), "omega"), (dict(omega=None), "omega"),
    (dict(omega=[0.0, 5.0], sample_interval=1.0), "omega"), (dict(of="z"), "of"),
    (dict(seed=-2), "seed"), (dict(seed=1.5), "seed"), (dict(n_paths=1), "n_paths"),
    (dict(segment=-3.0), "segment"), (dict(sample_interval=0.0), "sample_interval"),
    (dict(dt=10.0), "dt"), (dict(device="tpu"), "device"), (dict(n_batches=1), "n_batches")])
def test_bad_inputs_are_one_line(kw, name):
    args = {"omega": [0.0, 1.0], **kw}
    omega = args.pop("omega")
    with pytest.raises(InputError) as e:
        spectrum(LINEAR, omega, **args)
    assert e.value.name == name and "\n" not in str(e.value)
    assert str(e.value).startswith("montecarlo.spectrum")


def test_a_forced_system_is_refused():
    forced = LINEAR.replace(forcing=Harmonic(amplitude=0.1, frequency=1.0))
    with pytest.raises(InputError, match="montecarlo.spectrum: does not handle harmonic"):
        spectrum(forced, [0.0, 1.0])


@needs_sim
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_gpu_simulator_spectrum_agrees_with_the_cpu():
    """A tiny run on the simulator: the same Welch machinery on the GPU's samples;
    Var x within 4 combined SE of a CPU run, and ∫ S = Var x on the GPU's paths."""
    system = VibroImpactSystem.paper(r=0.9)
    w = np.linspace(0.0, 4.0, 81)
    kw = dict(seed=2, segment=40.0, progress=False)
    gpu = spectrum(system, w, "x", device="cuda", n_paths=8, n_batches=4, t_sample=80.0,
                   t_burn=60.0, **kw)
    cpu = spectrum(system, w, "x", n_paths=128, n_batches=8, t_sample=400.0, **kw)
    assert gpu.info["device"] != "cpu"
    assert np.all(np.isfinite(gpu.density)) and np.all(gpu.se > 0)
    se = math.hypot(gpu.info["variance_se"], cpu.info["variance_se"])
    assert abs(gpu.variance - cpu.variance) <= 4.0 * se
    assert gpu.integral() == pytest.approx(gpu.variance, rel=0.03)
