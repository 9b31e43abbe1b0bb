"""Monte Carlo engine (issue 3): accuracy against the exact Gibbs density, time-step
convergence, robustness, reproducibility, persistence and input validation."""
from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy import integrate, special, stats

from fpk_vibro import Solution, VibroImpactSystem
from fpk_vibro import montecarlo as mc


# -- exact Gibbs reference (r = 1, D2 = 0: p ∝ exp(-(c/D1) H) on the strip) -----------
class Gibbs:
    def __init__(self, s: VibroImpactSystem) -> None:
        self.s = s
        self.beta = s.c / s.D1
        lo, hi = s.x_bounds
        # beyond |x| = 12/sqrt(beta a)... the weight exp(-beta G) is negligible
        X = 10.0
        self.lo, self.hi = max(lo, -X), min(hi, X)
        self.Zx = self.ix(lambda x: 1.0)

    def w(self, x):
        return math.exp(-self.beta * float(self.s.potential(x)))

    def ix(self, f, lo=None, hi=None):
        lo = self.lo if lo is None else lo
        hi = self.hi if hi is None else hi
        return integrate.quad(lambda x: f(x) * self.w(x), lo, hi, limit=200,
                              epsabs=1e-14, epsrel=1e-11)[0]

    def moments(self) -> dict[str, float]:
        b, G = self.beta, lambda x: float(self.s.potential(x))
        out = {"E_x2": self.ix(lambda x: x * x) / self.Zx,
               "E_x4": self.ix(lambda x: x ** 4) / self.Zx,
               "E_y2": 1.0 / b, "E_y4": 3.0 / b ** 2}
        out["E_H"] = 0.5 / b + self.ix(G) / self.Zx
        if self.s.has_barrier:
            gd = self.s.barrier_energy
            out["P_impact"] = self.ix(
                lambda x: special.erfc(math.sqrt(max(b * (gd - G(x)), 0.0)))) / self.Zx
        return out

    def x_bin_probs(self, edges):
        return np.array([self.ix(lambda x: 1.0, e0, e1) for e0, e1 in
                         zip(edges[:-1], edges[1:])]) / self.Zx

    def y_bin_probs(self, edges):
        return np.diff(special.ndtr(edges * math.sqrt(self.beta)))


def chi2_ok(dens, se, edges, probs, min_prob=2e-3):
    """Chi-square of histogram densities against exact bin probabilities."""
    width = np.diff(edges)
    exact = probs / width
    use = probs > min_prob
    z = (dens[use] - exact[use]) / se[use]
    k = int(use.sum())
    chi2 = float(np.sum(z * z))
    # batch standard errors from 32 batches: t(31)² has mean 31/29 -> 1.15 margin
    return chi2, k, chi2 < 1.15 * stats.chi2.ppf(0.999, k)


GIBBS = {
    "both": VibroImpactSystem(a=1.0, b=0.2, c=0.2, D1=0.1, delta=0.6, r=1.0),
    "right": VibroImpactSystem(a=1.0, b=0.5, c=0.2, D1=0.1, delta=0.3, r=1.0,
                               barriers="right"),
    "none": VibroImpactSystem(a=1.0, b=0.5, c=0.2, D1=0.1, barriers="none"),
}


@pytest.mark.parametrize("kind", ["both", "right", "none"])
def test_gibbs_exact_moments_and_histograms(kind):
    s = GIBBS[kind]
    sol = mc.stationary(s, n_paths=1024, t_sample=600.0, seed=11, bins=40)
    ref = Gibbs(s).moments()
    m, se = sol.moments(), sol.moments_se()
    assert set(m) == set(ref)
    for k in ref:
        assert abs(m[k] - ref[k]) < 4 * se[k], (k, m[k], ref[k], se[k])
        assert se[k] < 0.02 * abs(ref[k]) + 1e-4       # the test has power
    g = Gibbs(s)
    edges, dens, hse = sol.histogram("x")
    chi2, k, ok = chi2_ok(dens, hse, edges, g.x_bin_probs(edges))
    assert ok, ("x", chi2, k)
    edges, dens, hse = sol.histogram("y")
    chi2, k, ok = chi2_ok(dens, hse, edges, g.y_bin_probs(edges))
    assert ok, ("y", chi2, k)
    # densities integrate to 1 (up to the reported overflow) and vanish off the strip
    for q, f in (("x", sol.pdf_x), ("y", sol.pdf_y), ("energy", sol.pdf_energy)):
        e = sol.histogram(q)[0]
        mass = np.sum(f(0.5 * (e[1:] + e[:-1])) * np.diff(e))
        assert mass == pytest.approx(1.0 - sol.overflow[q], abs=1e-12)
    if kind != "none":
        assert np.all(sol.pdf_x(np.array([s.delta * 1.0001, 2 * s.delta])) == 0)
        assert np.all(sol.pdf_joint(s.delta * 1.01, np.array([-0.1, 0.0, 0.1])) == 0)


def test_gibbs_chi2_detects_a_wrong_density():
    """The chi-square check has power: a 5 % wrong temperature fails it."""
    s = GIBBS["both"]
    sol = mc.stationary(s, n_paths=1024, t_sample=600.0, seed=11, bins=40,
                        quantities=("y",))
    wrong = Gibbs(s.replace(D1=0.105))
    edges, dens, hse = sol.histogram("y")
    assert not chi2_ok(dens, hse, edges, wrong.y_bin_probs(edges))[2]


def test_dt_halving_paper_r092():
    """Halving the default dt moves E[H] by less than 3 combined standard errors."""
    s = VibroImpactSystem.paper(r=0.92)
    a = mc.stationary(s, seed=5, target_rse=0.0015, quantities=())
    b = mc.stationary(s, seed=6, dt=a.dt / 2, target_rse=0.0015, quantities=())
    d = a.moments()["E_H"] - b.moments()["E_H"]
    comb = math.hypot(a.moments_se()["E_H"], b.moments_se()["E_H"])
    assert comb < 0.003 * b.moments()["E_H"]
    assert abs(d) < 3 * comb, (a.dt, d, comb)


def _strip_ok(s, sol):
    lo, hi = s.x_bounds
    assert lo <= sol.x_seen[0] <= sol.x_seen[1] <= hi
    m = sol.moments()
    assert all(math.isfinite(v) for v in m.values())
    for q in sol.quantities:
        assert np.all(np.isfinite(sol.histogram(q)[-2]))
    if s.barriers == "both":
        assert sol.overflow["x"] == 0.0
    assert math.isfinite(sol.impact_rate)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(r=st.floats(0.0, 1.0), delta=st.floats(0.02, 2.0), D1=st.floats(1e-4, 1.0),
       D2=st.one_of(st.just(0.0), st.floats(1e-4, 1.0)),
       c=st.one_of(st.just(0.0), st.floats(0.01, 1.0)),
       barriers=st.sampled_from(["both", "both", "right", "none"]),
       seed=st.integers(0, 2**32))
def test_paths_never_leave_the_strip(r, delta, D1, D2, c, barriers, seed):
    assume(c > 0 or (r < 0.999 and barriers != "none"))
    s = VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, delta=delta, r=r,
                          barriers=barriers)
    sol = mc.stationary(s, n_paths=64, n_batches=4, t_burn=2.0, t_sample=6.0,
                        seed=seed, sample_every=1, bins=10)
    _strip_ok(s, sol)


@pytest.mark.parametrize("r", [0.0, 0.05, 0.15])
def test_chattering_small_r_small_noise(r):
    """Inelastic collapse regime near (±Δ, 0): bounded work, stays in the strip."""
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.002, D2=0.01, delta=0.05, r=r)
    sol = mc.stationary(s, n_paths=128, n_batches=8, t_burn=10.0, t_sample=50.0, seed=3,
                        sample_every=1)
    _strip_ok(s, sol)
    assert sol.impact_rate > 0


@pytest.mark.parametrize("r", [0.0, 0.1])
def test_sticking_on_barrier_double_well(r):
    """Double well a < 0 < b with the barrier inside the well: the force pushes the
    path onto the barrier, where it comes to rest (x = Δ exactly, y = 0 for r = 0)
    — counted in the last histogram bin, never outside the strip."""
    s = VibroImpactSystem(a=-1.0, b=1.0, c=0.1, D1=1e-4, delta=0.5, r=r)
    sol = mc.stationary(s, n_paths=64, n_batches=4, t_burn=50.0, t_sample=50.0, seed=4,
                        sample_every=1)
    _strip_ok(s, sol)
    edges, dens, _ = sol.histogram("x")
    # nearly all mass within one bin of the barriers
    w = edges[1] - edges[0]
    assert (dens[0] + dens[-1]) * w > 0.9
    if r == 0.0:
        assert sol.x_seen == (-0.5, 0.5)        # at rest exactly on the barriers


def test_seed_reproducible_across_thread_counts():
    s = VibroImpactSystem.paper(r=0.5)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = mc.stationary(s, n_paths=256, t_burn=20.0, t_sample=40.0, seed=42, n_batches=8)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        b = mc.stationary(s, n_paths=256, t_burn=20.0, t_sample=40.0, seed=42, n_batches=8)
    finally:
        numba.set_num_threads(old)
    # the explicit threads= argument (thread pool over blocks), more workers than cores
    d = mc.stationary(s, n_paths=256, t_burn=20.0, t_sample=40.0, seed=42, n_batches=8,
                      threads=3)
    ma, mb = a._state(), b._state()
    assert ma[0] == mb[0]
    for other in (mb, d._state()):
        for k in ma[1]:
            assert np.array_equal(ma[1][k], other[1][k]), k
    c = mc.stationary(s, n_paths=256, t_burn=20.0, t_sample=40.0, seed=43, n_batches=8)
    assert c.moments()["E_H"] != a.moments()["E_H"]


def test_save_load_roundtrip(tmp_path):
    s = VibroImpactSystem.paper(r=0.92)
    sol = mc.stationary(s, n_paths=128, t_burn=10.0, t_sample=20.0, seed=1, n_batches=8)
    path = sol.save(tmp_path / "mc")
    back = Solution.load(path)
    assert isinstance(back, mc.MonteCarloSolution)
    assert back.system == s and back.partial is False
    assert back.moments() == sol.moments() and back.moments_se() == sol.moments_se()
    x = np.linspace(-0.7, 0.7, 23)[:, None]
    y = np.linspace(-1, 1, 19)[None, :]
    assert np.array_equal(back.pdf_joint(x, y), sol.pdf_joint(x, y))
    assert np.array_equal(back.pdf_x(x), sol.pdf_x(x))
    assert np.array_equal(back.pdf_y(y), sol.pdf_y(y))
    H = np.linspace(0, 1, 31)
    assert np.array_equal(back.pdf_energy(H), sol.pdf_energy(H))
    for k in ("dt", "n_paths", "t_sample", "impact_rate", "impact_rate_se", "overflow"):
        assert getattr(back, k) == getattr(sol, k), k
    for k, v in sol.histograms.items():
        for u, w in zip(v, back.histograms[k]):
            assert np.array_equal(u, w)


def test_only_requested_quantities():
    s = VibroImpactSystem.paper(r=0.92)
    sol = mc.stationary(s, n_paths=64, t_burn=5.0, t_sample=10.0, seed=1, n_batches=4,
                        quantities=("energy",))
    assert set(sol.histograms) == {"energy"}
    assert sol.pdf_energy(0.1) > 0
    with pytest.raises(ValueError, match="'x' histogram was not accumulated"):
        sol.pdf_x(0.0)


def test_interrupt_returns_partial(monkeypatch):
    from fpk_vibro.montecarlo import _kernel

    real = _kernel.advance
    calls = {"n": 0}

    def flaky(*args, **kwargs):
        real(*args, **kwargs)
        calls["n"] += 1
        if args[6] > 0 and calls["n"] >= 3:      # during sampling
            raise KeyboardInterrupt

    monkeypatch.setattr(_kernel, "advance", flaky)
    monkeypatch.setattr(mc._setup, "CHUNK_PATH_STEPS", 64 * 20)
    s = VibroImpactSystem.paper(r=0.92)
    sol = mc.stationary(s, n_paths=64, n_batches=4, t_burn=1.0, t_sample=50.0, seed=1)
    assert sol.partial is True
    assert 0 < sol.t_sample < 50.0
    assert math.isfinite(sol.moments()["E_H"])


def test_transient_start_and_relaxation():
    s = GIBBS["both"]
    run = mc.transient(s, initial={"mean": (0.2, 0.0), "std": (0.0, 0.0)},
                       times=[0.0, 0.5, 40.0], n_paths=4096, seed=2)
    assert isinstance(run, list) and len(run) == 3 and not run.partial
    m0 = run[0].moments()
    assert m0["E_x2"] == pytest.approx(0.04, rel=1e-12)
    assert m0["E_y2"] == 0.0 and run[0].time == 0.0
    assert run[1].moments()["E_y2"] > 0 and run[1].time == 0.5
    ref = Gibbs(s).moments()
    last = run[2]
    for k in ("E_H", "E_x2", "E_y2"):
        assert abs(last.moments()[k] - ref[k]) < 4 * last.moments_se()[k], k
    # a user sampler is accepted and reproducible
    def sampler(n, rng):
        return np.column_stack([rng.uniform(-0.5, 0.5, n), rng.normal(0, 0.1, n)])
    r1 = mc.transient(s, initial=sampler, times=[1.0], n_paths=256, seed=9, n_batches=4)
    r2 = mc.transient(s, initial=sampler, times=[1.0], n_paths=256, seed=9, n_batches=4)
    assert r1[0].moments() == r2[0].moments()


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_paths=1), "n_paths must be an integer in \\[2"),
    (dict(n_paths=2.5), "n_paths"),
    (dict(dt=-0.1), "dt must be a finite number > 0"),
    (dict(dt=5.0), "dt must be in \\(0"),
    (dict(dt=float("nan")), "dt"),
    (dict(t_burn=-1.0), "t_burn"),
    (dict(t_sample=0.0), "t_sample"),
    (dict(t_sample=0.01), "t_sample must be >= one sampling interval"),
    (dict(seed=-3), "seed"),
    (dict(seed="x"), "seed"),
    (dict(quantities=("energy", "velocity")), "quantities"),
    (dict(bins=1), "bins"),
    (dict(bins={"x": [0, 1, 3]}), "equally spaced"),
    (dict(bins={"z": 3}), "bins keys"),
    (dict(n_batches=1), "n_batches"),
    (dict(target_rse=0.0), "target_rse"),
    (dict(max_impacts=0), "max_impacts"),
    (dict(threads=0), "threads must be an integer in \\[1, 1024\\]"),
])
def test_bad_inputs_raise_before_work(kwargs, match, monkeypatch):
    from fpk_vibro.montecarlo import _kernel

    def boom(*a, **kw):
        raise AssertionError("kernel ran before validation")

    monkeypatch.setattr(_kernel, "advance", boom)
    with pytest.raises(ValueError, match=match):
        mc.stationary(VibroImpactSystem.paper(), **kwargs)


def test_bad_transient_inputs():
    s = VibroImpactSystem.paper()
    ok = {"mean": (0.0, 0.0), "std": (0.1, 0.1)}
    with pytest.raises(ValueError, match="times"):
        mc.transient(s, initial=ok, times=[1.0, 0.5])
    with pytest.raises(ValueError, match="times"):
        mc.transient(s, initial=ok, times=[-1.0])
    with pytest.raises(ValueError, match=r"mean\[0\] \(x0\) must be in the strip"):
        mc.transient(s, initial={"mean": (0.7, 0.0), "std": (0.1, 0.1)}, times=[1.0])
    with pytest.raises(ValueError, match="std must be"):
        mc.transient(s, initial={"mean": (0.0, 0.0), "std": (-0.1, 0.1)}, times=[1.0])
    with pytest.raises(ValueError, match="system"):
        mc.stationary("paper")


def _shared_gibbs_cases():
    try:
        from conftest import gibbs_cases
    except ImportError:      # pragma: no cover - conftest not importable
        return {}
    return gibbs_cases()


@pytest.mark.parametrize("name", sorted(_shared_gibbs_cases()))
def test_gibbs_cases_against_exact_module(name):
    """Every shared exact case (softening, quartic, wide, unilateral, no barrier)
    against fpk_vibro.exact.GibbsSolution: each moment within 4 standard errors."""
    exact = pytest.importorskip("fpk_vibro.exact")
    s = _shared_gibbs_cases()[name]
    sol = mc.stationary(s, n_paths=1024, seed=21, target_rse=0.005, quantities=())
    ref = exact.GibbsSolution(s).moments()
    m, se = sol.moments(), sol.moments_se()
    assert set(m) == set(ref)
    for k in ref:
        # a probability never observed (se = 0) is consistent with p < ~5/n_samples
        floor = 5.0 / sol.n_samples if k == "P_impact" else 0.0
        assert abs(m[k] - ref[k]) <= 4 * se[k] + floor, (k, m[k], ref[k], se[k])


def test_random_source_is_standard_normal():
    """The kernels' ziggurat normals: KS test, moments and the tail beyond R."""
    from numba import njit

    from fpk_vibro.montecarlo import _rng

    @njit
    def draw(state, n):
        s0, s1, s2, s3 = state[0], state[1], state[2], state[3]
        out = np.empty(n)
        for k in range(n):
            z, s0, s1, s2, s3 = _rng._normal(s0, s1, s2, s3)
            out[k] = z
        return out

    st_ = mc._setup.rng_states(np.random.SeedSequence(5).spawn(1))[0]
    z = draw(st_, 400_000)
    assert stats.kstest(z, "norm").pvalue > 1e-4
    n = z.size
    assert abs(z.mean()) < 5 / math.sqrt(n)
    assert abs(z.var() - 1) < 5 * math.sqrt(2 / n)
    assert abs(stats.skew(z)) < 5 * math.sqrt(6 / n)
    assert abs(stats.kurtosis(z)) < 5 * math.sqrt(24 / n)
    p_tail = 2 * special.ndtr(-_rng._ZR_TAIL)
    k = int(np.sum(np.abs(z) > _rng._ZR_TAIL))
    assert abs(k - n * p_tail) < 5 * math.sqrt(n * p_tail)


def test_default_dt_follows_a_tight_target():
    """Below target_rse = 1e-3 the default dt shrinks as sqrt(target) (the O(dt²)
    bias kept near 0.4 × the target); a fixed t_sample keeps T0/120."""
    s = VibroImpactSystem.paper(r=0.92)
    dt0 = mc._setup.default_dt(s)
    kw = dict(n_paths=64, n_batches=4, t_burn=0.0, seed=1, quantities=(), progress=False)
    assert mc.stationary(s, target_rse=1e-3, max_t_sample=20.0, **kw).dt == dt0
    tight = mc.stationary(s, target_rse=2.5e-4, max_t_sample=20.0, **kw)
    assert tight.dt == pytest.approx(dt0 / 2, rel=1e-12)
    assert mc.stationary(s, target_rse=2.5e-4, t_sample=20.0, **kw).dt == dt0
