"""fem.periodic: the periodic FE state by harmonic balance (issue 34)."""
import math

import numpy as np
import pytest

from fpk_vibro import Harmonic, VibroImpactSystem, fem
from fpk_vibro._checks import InputError
from fpk_vibro.quadrature import gauss_grid

F, W, C = 0.1, 0.9, 0.1
PHASES = np.arange(4) * np.pi / 2


@pytest.fixture(scope="module")
def linear():
    s = VibroImpactSystem(a=1.0, b=0.0, c=C, D1=0.01, barriers="none",
                          forcing=Harmonic(F, W))
    return fem.periodic(s, PHASES, degree=3, nx=12, ny=12, harmonics=8)


@pytest.fixture(scope="module")
def paper():
    s = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(0.05, 0.9))
    return fem.periodic(s, np.arange(8) * np.pi / 4, degree=2, nx=8, harmonics=4)


def _exact_mean(phi):
    A = F / math.hypot(1.0 - W * W, C * W)
    th = math.atan2(C * W, 1.0 - W * W)
    return A, th, A * math.cos(phi - th), -A * W * math.sin(phi - th)


def test_linear_oscillator_is_the_shifted_gaussian(linear):
    A, th, _, _ = _exact_mean(0.0)
    est = linear.error_estimate()
    assert abs(linear.amplitude - A) <= est["amplitude"]
    assert abs(linear.lag - th) <= est["lag"]
    m = linear.moments_vs_phase()
    for i, phi in enumerate(linear.phases):
        _, _, mx, my = _exact_mean(phi)
        e = est["phases"][i]
        assert abs(m["E_x"][i] - mx) <= e["E_x"]
        assert abs(m["E_x2"][i] / (0.1 + mx * mx) - 1) <= e["E_x2"]
        assert abs(m["E_y2"][i] / (0.1 + my * my) - 1) <= e["E_y2"]
        sol = linear.at(i)
        xq, wx = gauss_grid(np.linspace(sol._x0, sol._x1, 97), 4)
        yq, wy = gauss_grid(np.linspace(-sol.y_max, sol.y_max, 97), 4)
        X, Y = np.meshgrid(xq, yq, indexing="ij")
        g = np.exp(-((X - mx) ** 2 + (Y - my) ** 2) / 0.2) / (2 * np.pi * 0.1)
        l1 = float(wx @ np.abs(sol.pdf_joint(X, Y) - g) @ wy)
        assert l1 <= e["L1"], (phi, l1, e["L1"])
    assert linear.mean_x == pytest.approx(0.0, abs=1e-12)


def test_no_forcing_recovers_stationary():
    s0 = VibroImpactSystem.paper(r=0.8)
    s = s0.replace(forcing=Harmonic(1e-9, 0.9))
    r = fem.periodic(s, [0.0, 2.0], degree=2, nx=8, ny=16, harmonics=2, y_max=1.8,
                     wall_grading=1.0)
    st = fem.stationary(s0, degree=2, nx=8, ny=16, y_max=1.8)
    ms, ma = st.moments(), r.average().moments()
    for i in range(2):
        m = r.at(i).moments()
        for k in ("E_H", "E_x2", "E_y2", "P_impact"):
            assert m[k] == pytest.approx(ms[k], rel=1e-7) and ma[k] == pytest.approx(
                ms[k], rel=1e-7)
    assert r.amplitude < 1e-7


def test_period_averaged_power_balance(paper):
    s, avg = paper.system, paper.average()
    m, imp = avg.moments(), avg.impacts()
    # the forcing work F <cos φ E[y](φ)>, by the rectangle rule over the 8 phases
    # (exact for the trigonometric polynomial of degree K + 1 < 8)
    y = np.linspace(-avg.y_max, avg.y_max, 2001)
    Ey = [np.trapezoid(y * paper.at(i).pdf_y(y), y) for i in range(8)]
    work = 0.05 * float(np.mean(np.cos(paper.phases) * Ey))
    assert work == pytest.approx(paper.info["forcing_work"], rel=2e-3)
    noise = s.D1 + s.D2 * m["E_x2"] + work
    out = s.c * m["E_y2"] + sum(v["energy_rate"] for v in imp.values())
    assert abs(noise - out) / noise < 2e-3
    assert work > 0


def test_estimate_against_finer_reference(paper):
    ref = fem.periodic(paper.system, paper.phases, degree=3, nx=16, harmonics=6)
    est = paper.error_estimate()
    ratios = [abs(paper.amplitude - ref.amplitude) / est["amplitude"]]
    m, mr = paper.moments_vs_phase(), ref.moments_vs_phase()
    for i in range(len(paper)):
        for k in ("E_x2", "E_y2", "E_H"):
            ratios.append(abs(m[k][i] / mr[k][i] - 1) / est["phases"][i][k])
    ratios = np.array(ratios)
    assert np.all(ratios <= 2.0) and np.median(ratios) >= 1 / 30, ratios


@pytest.mark.parametrize("phases, match", [([7.0], "phases"), ([], "phases"),
                                           ("a", "phases"), ([-0.1], "phases")])
def test_refuses_bad_phases(phases, match):
    s = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(0.05, 0.9))
    with pytest.raises(InputError, match=f"fem.periodic: {match}"):
        fem.periodic(s, phases)


def test_refusals():
    s = VibroImpactSystem.paper(r=0.8)
    with pytest.raises(InputError, match="fem.periodic: system must be a system with "
                                         "forcing"):
        fem.periodic(s, [0.0])
    f = s.replace(forcing=Harmonic(0.05, 0.9))
    with pytest.raises(InputError, match="fem.periodic: nx must be"):
        fem.periodic(f, [0.0], nx=1)
    with pytest.raises(InputError, match="fem.periodic: harmonics must be"):
        fem.periodic(f, [0.0], harmonics=0)
    with pytest.raises(InputError, match="fem.periodic: nx must not be given with rtol"):
        fem.periodic(f, [0.0], rtol=1e-3, nx=8)


def test_options_declared_once_for_periodic():
    """fem.Options for "periodic" lists exactly fem.periodic's keywords; a reduced
    scene run is capped (Q2, nx 8, K 4, no rtol); the check sizes it."""
    import inspect
    keys = set(inspect.signature(fem.periodic).parameters) - {"system", "phases"}
    assert set(fem.Options.for_mode("periodic")) == keys
    assert fem.Options.reduce("periodic", {"rtol": 1e-3, "nx": 32}) == {
        "nx": 8, "ny": 16, "degree": 2, "harmonics": 4}
    assert "periodic" in fem.Options.FORCED_MODES and "transient" in fem.Options.FORCED_MODES
    s = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(0.05, 0.9))
    small = fem.Options.from_call("periodic", {"degree": 2, "nx": 8, "harmonics": 3})
    big = fem.Options.from_call("periodic", {"degree": 4, "nx": 64, "harmonics": 12})
    a, b = small.estimate(s, "periodic"), big.estimate(s, "periodic")
    assert 0 < a.seconds < b.seconds and a.memory < b.memory
    with pytest.raises(InputError, match="fem.harmonics: only used by periodic"):
        fem.Options.from_scene("stationary", {"harmonics": 3})


def test_sweeps_solve_the_same_system(paper):
    """The Gauss–Seidel sweep and the block-diagonal preconditioner give the same
    coefficients (to GMRES's tolerance), the sweep in fewer iterations; raising K
    reuses the factors and starts from the last solution."""
    from fpk_vibro.fem.harmonic import HarmonicSystem
    import sys
    P = sys.modules["fpk_vibro.fem.periodic"]
    s = paper.system
    lev = P._Level(s, P.forced_domain(s, None), 2, 8, paper.info["ny"], 2.0)
    f = s.forcing
    out = {}
    for sweep in ("jacobi", "gs", "sgs"):
        hs = HarmonicSystem(lev.L0, lev.M, lev.L1, lev.unit, f.amplitude, f.frequency,
                            sweep=sweep)
        out[sweep] = (hs.solve(4), hs)
    ref = out["jacobi"][0]
    for sweep in ("gs", "sgs"):
        assert np.abs(out[sweep][0].coef - ref.coef).max() <= 1e-9 * np.abs(ref.coef).max()
    assert out["gs"][0].iterations < ref.iterations
    hs = out["gs"][1]
    h6 = hs.solve(6, start=out["gs"][0])
    assert set(hs._lu) == set(range(7)) and h6.iterations >= 1
    # (K = 6 changes the K = 4 coefficients by the truncation only: ≪ p_1)
    assert np.abs(h6.coef[:5] - ref.coef).max() <= 0.01 * np.abs(ref.coef[1]).max()
