"""Stochastic averaging (docs/theory.md, §Averaging): quadrature accuracy, exact
limits, densities."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from fpk_vibro import Solution, VibroImpactSystem, averaging, exact
from fpk_vibro.orbits import energy_loss

from conftest import averaging_cases, gauss_total, gibbs_cases, quad_total

AVG = averaging_cases()


def reference_coefficients(system, H):
    """T, m, σ² by adaptive quadrature in x (independent of the θ substitution)."""
    G = system.potential
    lo, hi = system.x_bounds
    A = float(system.amplitude(H)) if np.isfinite(system.amplitude(H)) else math.inf
    xl, xr = max(lo, -A), min(hi, A)

    def gap(x):
        return 2.0 * H - 2.0 * float(G(x))

    def integral(g):
        # ∫ g/sqrt(gap): at a turning point ±A the factor (A ∓ x) of
        # gap = (A − x)(A + x)(a + b(A² + x²)/2) becomes quad's algebraic weight
        al = -0.5 if xl == -A else 0.0
        ar = -0.5 if xr == A else 0.0
        kw = dict(epsabs=0.0, epsrel=1e-13, limit=500)
        if not (al or ar):
            return quad(lambda x: g(x) / math.sqrt(gap(x)), xl, xr, **kw)[0]

        def f(x):
            rest = system.a + 0.5 * system.b * (A * A + x * x)
            if not al:
                rest *= A + x
            if not ar:
                rest *= A - x
            return g(x) / math.sqrt(rest)
        return quad(f, xl, xr, weight="alg", wvar=(al, ar), **kw)[0]

    T = 2 * integral(lambda x: 1.0)
    J1 = integral(lambda x: gap(x))
    K = integral(lambda x: system.D1 + system.D2 * x * x)
    J2 = integral(lambda x: gap(x) * (2 * system.D1 + 2 * system.D2 * x * x))
    m = 2 / T * (K - system.c * J1) - float(energy_loss(system, H)) / T
    return T, m, 2 / T * J2


@pytest.mark.parametrize("name", ["paper_0.92", "unilateral", "no_barrier_D2", "softening_above_max", "quartic"])
def test_coefficients_against_quad(name):
    system = AVG[name]
    Hb = system.barrier_energy if system.has_barrier else 0.3
    H = np.array([1e-4, 0.05, 0.5 * Hb, 0.999 * Hb, 1.001 * Hb, 1.5 * Hb, 4 * Hb, 20 * Hb])
    T, m, s2 = averaging.coefficients(system, H)
    for i, h in enumerate(H):
        Tr, mr, s2r = reference_coefficients(system, h)
        assert T[i] == pytest.approx(Tr, rel=1e-9, abs=0)
        assert m[i] == pytest.approx(mr, rel=1e-9, abs=0)
        assert s2[i] == pytest.approx(s2r, rel=1e-9, abs=0)


def test_linear_period_below_barrier():
    system = VibroImpactSystem(a=2.5, b=0.0, c=0.02, D1=0.01, delta=0.8, r=0.7)
    H = np.linspace(1e-6, 0.999 * system.barrier_energy, 9)
    T, _, _ = averaging.coefficients(system, H)
    assert np.allclose(T, 2 * np.pi / np.sqrt(2.5), rtol=1e-13, atol=0)
    # above the barrier energy the orbit is cut: shorter
    T_hi, _, _ = averaging.coefficients(system, np.array([1.5 * system.barrier_energy]))
    assert T_hi[0] < 2 * np.pi / np.sqrt(2.5)


def test_drift_limit_at_zero_energy():
    """m(0) = D1 and σ²(0) = 0: energy is injected by external noise at rest."""
    T, m, s2 = averaging.coefficients(AVG["paper_0.92"], np.array([0.0]))
    assert m[0] == pytest.approx(0.01, rel=1e-13)
    assert s2[0] == 0.0


def test_closed_form_solves_the_paper_formula():
    """p(H) σ²(H) ∝ exp(∫ 2m/σ²) (paper Eq. 24): d log(p σ²)/dH = 2m/σ²."""
    system = AVG["paper_0.92"]
    sol = averaging.stationary(system)
    Hb = system.barrier_energy
    for H0 in (0.02, 0.1, 0.5 * Hb, 1.3 * Hb, 3 * Hb):
        h = 1e-5 * H0
        Hs = H0 + h * np.array([-2, -1, 1, 2])
        _, _, s2 = averaging.coefficients(system, Hs)
        g = np.log(sol.pdf_energy(Hs) * s2)
        deriv = (g[0] - 8 * g[1] + 8 * g[2] - g[3]) / (12 * h)
        _, m0, s20 = averaging.coefficients(system, np.array([H0]))
        assert deriv == pytest.approx(2 * m0[0] / s20[0], rel=1e-7)


@pytest.mark.parametrize("name", list(gibbs_cases()))
def test_exact_gibbs_recovered(name):
    system = gibbs_cases()[name]
    if name == "wide":  # Δ = 3: the barrier is beyond the density's reach
        pass
    avg, ex = averaging.stationary(system), exact.gibbs(system)
    ma, me = avg.moments(), ex.moments()
    assert set(ma) == set(me)
    for k in me:
        assert ma[k] == pytest.approx(me[k], rel=1e-8, abs=1e-300 if me[k] else 1e-20), k
    x = np.linspace(-0.59, 0.59, 13)
    y = np.linspace(-1.0, 1.0, 13)
    X, Y = np.meshgrid(x, y)
    assert np.allclose(avg.pdf_joint(X, Y), ex.pdf_joint(X, Y), rtol=1e-10, atol=0)
    assert np.allclose(avg.pdf_x(x), ex.pdf_x(x), rtol=1e-10, atol=0)
    assert np.allclose(avg.pdf_y(y), ex.pdf_y(y), rtol=1e-10, atol=0)
    H = np.linspace(1e-3, 1.0, 17)
    assert np.allclose(avg.pdf_energy(H), ex.pdf_energy(H), rtol=1e-10, atol=0)


def test_linear_oscillator_without_barrier():
    c, D1 = 0.04, 0.01
    sol = averaging.stationary(VibroImpactSystem(a=1.7, b=0.0, c=c, D1=D1, barriers="none"))
    H = np.linspace(0, 2, 41)
    assert np.allclose(sol.pdf_energy(H), c / D1 * np.exp(-c * H / D1), rtol=1e-12, atol=0)
    assert "P_impact" not in sol.moments()


@pytest.mark.parametrize("name", list(AVG))
def test_every_pdf_integrates_to_one(name):
    system = AVG[name]
    sol = averaging.stationary(system)
    Hb = system.barrier_energy if system.has_barrier else sol.H_end
    lo, hi = system.x_bounds
    x_end = float(system.amplitude(sol.H_end))
    lo, hi = max(lo, -x_end), min(hi, x_end)
    y_end = math.sqrt(2 * sol.H_end)
    yb = math.sqrt(2 * Hb)
    assert quad_total(sol.pdf_energy, 0, sol.H_end, [Hb]) == pytest.approx(1, abs=1e-8)
    xb = [lo, 0.0, hi] + [d for d in (-system.delta, system.delta) if lo < d < hi]
    assert gauss_total(sol.pdf_x, xb) == pytest.approx(1, abs=1e-8)
    assert gauss_total(sol.pdf_y, [-y_end, -yb, 0.0, yb, y_end]) == pytest.approx(1, abs=1e-8)
    # joint, by an independent tensor Gauss rule: ∫ dx 2[∫₀^{y*} + ∫_{y*}^{y_end}] dy,
    # y* where the orbit starts to impact, the second piece in y = y* + u²
    t, w = np.polynomial.legendre.leggauss(300)
    xs = np.concatenate([lo / 2 * (1 - t), hi / 2 * (t + 1)])
    wx = np.concatenate([-lo / 2 * w, hi / 2 * w])[:, None]
    ys = np.sqrt(2 * np.maximum(Hb - system.potential(xs), 0.0))[:, None]
    y1, w1 = ys / 2 * (t + 1), ys / 2 * w
    um = np.sqrt(y_end - ys)
    u = um / 2 * (t + 1)
    y2, w2 = ys + u * u, um / 2 * w * 2 * u
    X = xs[:, None]
    total = np.sum(wx * 2 * (w1 * sol.pdf_joint(X, y1) + w2 * sol.pdf_joint(X, y2)))
    assert total == pytest.approx(1, abs=1e-8)


@pytest.mark.parametrize("name", ["paper_0.92", "r0", "unilateral", "quartic"])
def test_joint_continuous_across_barrier_energy(name):
    system = AVG[name]
    sol = averaging.stationary(system)
    Hb = system.barrier_energy
    x = np.linspace(-0.9, 0.9, 7) * system.delta
    scale = sol.pdf_joint(0.0, 0.0)
    for eps in (1e-4, 1e-6, 1e-8):
        y_lo = np.sqrt(2 * (Hb - eps - system.potential(x)))
        y_hi = np.sqrt(2 * (Hb + eps - system.potential(x)))
        jump = np.abs(sol.pdf_joint(x, y_hi) - sol.pdf_joint(x, y_lo)) / scale
        assert np.all(jump < 50 * eps)  # Lipschitz: the jump shrinks with eps
    # while p(H) itself has the kink: slope jumps at G(Δ)
    h = 1e-6
    p = sol.pdf_energy(np.array([Hb - 2 * h, Hb - h, Hb + h, Hb + 2 * h]))
    assert abs((p[3] - p[2]) / h - (p[1] - p[0]) / h) > 1.0


@pytest.mark.parametrize("name", ["paper_0.92", "unilateral", "softening_above_max"])
def test_pdf_x_vanishes_outside_strip(name):
    system = AVG[name]
    sol = averaging.stationary(system)
    lo, hi = system.x_bounds
    outside = np.array([hi + 1e-12, hi + 0.1, hi + 5.0] + ([lo - 1e-12, lo - 0.3] if math.isfinite(lo) else []))
    assert np.all(sol.pdf_x(outside) == 0.0)
    assert np.all(sol.pdf_joint(outside, 0.1 * np.ones_like(outside)) == 0.0)
    assert sol.pdf_x(np.array([hi])) > 0


def test_densities_vectorised_and_finite():
    sol = averaging.stationary(AVG["paper_0.92"])
    x = np.linspace(-1, 1, 12).reshape(3, 4)
    for f in (sol.pdf_x, sol.pdf_y, sol.pdf_energy):
        v = f(x)
        assert v.shape == x.shape and np.all(np.isfinite(v)) and np.all(v >= 0)
    assert sol.pdf_joint(x, x.T[:3, :1]).shape == (3, 4)
    assert sol.pdf_energy(np.array([-1.0]))[0] == 0.0


def test_restitution_trend():
    """Smaller r: more energy lost, lower E[H], fewer impacts (paper Fig. 3)."""
    E = [averaging.stationary(VibroImpactSystem.paper(r=r)).moments() for r in (1.0, 0.98, 0.92, 0.5)]
    assert all(E[i]["E_H"] > E[i + 1]["E_H"] for i in range(3))
    assert all(E[i]["P_impact"] > E[i + 1]["P_impact"] for i in range(3))


@pytest.mark.parametrize("system", [
    VibroImpactSystem(a=-1.0, b=1.0, c=0.05, D1=0.05, delta=2.0),    # double well
    VibroImpactSystem(a=1.0, b=-2.0, c=0.05, D1=0.05, delta=1.0),    # barrier beyond the hilltop
])
def test_non_monotone_potential_rejected(system):
    with pytest.raises(ValueError, match="increasing"):
        averaging.stationary(system)
    with pytest.raises(ValueError, match="increasing"):
        averaging.coefficients(system, np.array([0.1]))


@pytest.mark.parametrize("kw, name", [(dict(n_theta=2), "n_theta"), (dict(n_panel=0), "n_panel"),
                                      (dict(phi_cut=1.0), "phi_cut"), (dict(n_theta=3.5), "n_theta")])
def test_bad_numerics(kw, name):
    with pytest.raises(ValueError, match=name):
        averaging.stationary(VibroImpactSystem.paper(), **kw)


def test_heavy_tail_is_an_error_not_a_number():
    """Linear oscillator, strong parametric noise, no barrier: p(H) ~ H^-k is not normalisable."""
    system = VibroImpactSystem(a=1.0, b=0.0, c=0.01, D1=0.01, D2=0.05, barriers="none")
    with pytest.raises(ValueError, match="does not converge|normalised"):
        averaging.stationary(system)


@pytest.mark.parametrize("name", ["paper_0.92", "unilateral", "no_barrier_D2"])
def test_save_load_round_trip(tmp_path, name):
    sol = averaging.stationary(AVG[name])
    path = sol.save(tmp_path / "avg")
    back = Solution.load(path)
    assert isinstance(back, averaging.AveragedSolution) and back.system == sol.system
    assert back.moments() == sol.moments()
    z = np.linspace(-1, 1, 21)
    for f in ("pdf_x", "pdf_y", "pdf_energy"):
        assert np.array_equal(getattr(back, f)(np.abs(z)), getattr(sol, f)(np.abs(z)))
    assert np.array_equal(back.pdf_joint(z, z[::-1]), sol.pdf_joint(z, z[::-1]))
