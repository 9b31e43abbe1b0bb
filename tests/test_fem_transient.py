"""The FE transient (docs/theory.md, §Transients): conservation, stability at large
dt, order, limits, MC."""
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, fem, montecarlo
from fpk_vibro.fem.transient import discretise, relaxation_time, transient

SMOOTH = {"mean": (0.1, 0.3), "std": (0.15, 0.3)}


@pytest.fixture(scope="module")
def paper92():
    return VibroImpactSystem.paper(r=0.92)


@pytest.fixture(scope="module")
def coarse(paper92):
    return discretise(paper92, nx=24, ny=48, degree=1)


def l1(disc, p, q):
    return float(disc.unit @ np.abs(p - q))


def test_mass_over_ten_thousand_steps(paper92, coarse):
    sols = transient(paper92, initial=SMOOTH, times=[10.0, 100.0], dt=0.01, discretisation=coarse)
    assert sols[-1].info["steps"] == 10_000
    for s in sols:
        assert abs(s.mass - 1) < 1e-12


@pytest.mark.parametrize("scheme", ["bdf2", "theta"])
def test_stable_at_hundred_times_cfl(paper92, coarse, scheme):
    x, y = coarse.points
    hx = np.ptp(x) / 24
    cfl = hx / np.max(np.abs(y))
    st = fem.stationary(paper92, nx=24, ny=48)
    kw = dict(theta=1.0) if scheme == "theta" else {}
    sols = transient(paper92, initial=SMOOTH, times=np.arange(1, 41) * 100 * cfl,
                     dt=100 * cfl, scheme=scheme, discretisation=coarse, **kw)
    dist = [l1(coarse, s.dofs, st.dofs) for s in sols]
    for s in sols:
        assert np.all(np.isfinite(s.dofs))
        assert s.min_density >= -1e-3 * s.dofs.max()
        assert abs(s.mass - 1) < 1e-12
    assert dist[-1] < dist[0] and max(dist) <= dist[0] * 1.05   # no growth


def test_bdf2_is_second_order_in_time(paper92, coarse):
    ref = transient(paper92, initial=SMOOTH, times=[2.0], dt=2.0 / 2048, discretisation=coarse)[0].dofs
    errs = [l1(coarse, transient(paper92, initial=SMOOTH, times=[2.0], dt=2.0 / n,
                                 discretisation=coarse)[0].dofs, ref) for n in (16, 32, 64, 128, 256)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders[1:] >= 1.9), orders


def test_long_time_limit_is_the_stationary_solution(paper92, coarse):
    st = fem.stationary(paper92, nx=24, ny=48)
    end = transient(paper92, initial=SMOOTH, times=[4000.0], dt=20.0, discretisation=coarse)[0]
    assert l1(coarse, end.dofs, st.dofs) < 1e-6


def test_relaxation_time_matches_the_transient_decay(paper92, coarse):
    rel = relaxation_time(paper92, discretisation=coarse)
    st = fem.stationary(paper92, nx=24, ny=48)
    t = np.array([60.0, 90.0])
    d = [l1(coarse, s.dofs, st.dofs) for s in
         transient(paper92, initial=SMOOTH, times=t, dt=0.25, discretisation=coarse)]
    observed = np.log(d[0] / d[1]) / (t[1] - t[0])
    assert observed == pytest.approx(rel["rate"], rel=0.05)
    assert rel["time"] == pytest.approx(np.log(1e3) / rel["rate"])


def test_bad_input(paper92, coarse):
    for kw, name in [(dict(times=[1.0, 0.5]), "times"), (dict(times=[-1.0]), "times"),
                     (dict(times=[1.0], dt=0.0), "dt"), (dict(times=[1.0], scheme="rk4"), "scheme"),
                     (dict(times=[1.0], theta=0.3), "theta"),
                     (dict(times=[1.0], initial={"mean": (0, 0)}), "std")]:
        args = {"initial": SMOOTH, **kw}
        with pytest.raises(ValueError, match=name):
            transient(paper92, discretisation=coarse, **args)


PACKET = {"mean": (0.0, 1.0), "std": (0.0, 0.05)}
TIMES = [1.0, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0]


def _fe_run(system, nx, dt_early):
    """The packet moves at speed ~1 and is 0.05 wide: small steps until t = 10, then
    larger ones (restart from the t = 10 solution)."""
    early = transient(system, initial=PACKET, times=TIMES[:4], dt=dt_early, nx=nx, ny=4 * nx,
                      y_max=2.2)
    late = transient(system, initial=early[-1], times=[t - 10.0 for t in TIMES[4:]],
                     dt=8 * dt_early, nx=nx, ny=4 * nx, y_max=2.2)
    return early + late


def test_agrees_with_monte_carlo_transient(paper92):
    """E[H](t), E[x²](t), E[y²](t): |FE − MC| ≤ 3 SE_MC + FE error, estimated from a
    coarse (mesh, dt) and a fine (mesh/2, dt/2) run."""
    coarse = _fe_run(paper92, 32, 0.025)
    fine = _fe_run(paper92, 64, 0.0125)
    mc = montecarlo.transient(paper92, initial=PACKET, times=TIMES, n_paths=16384, seed=5,
                              quantities=("energy",), progress=False)
    for t, coarse_s, fine_s, m in zip(TIMES, coarse, fine, mc):
        assert m.time == t
        a, b = coarse_s.moments(), fine_s.moments()
        mm, se = m.moments(), m.moments_se()
        for k in ("E_H", "E_x2", "E_y2"):
            tol = 3 * se[k] + abs(b[k] - a[k])
            assert abs(b[k] - mm[k]) <= tol, (t, k, b[k], mm[k], se[k], abs(b[k] - a[k]))


def test_adaptive_steps_follow_the_tolerance(paper92, coarse):
    times = [1.0, 5.0, 20.0]
    ref = transient(paper92, initial=SMOOTH, times=times, dt=0.0025, discretisation=coarse)
    errs = []
    for tol in (1e-4, 1e-6):
        run = transient(paper92, initial=SMOOTH, times=times, dt=5.0, tol=tol,
                        discretisation=coarse)
        assert [s.time for s in run] == times and all(abs(s.mass - 1) < 1e-12 for s in run)
        errs.append(max(l1(coarse, a.dofs, b.dofs) for a, b in zip(run, ref)))
    assert errs[0] < 2e-2 and errs[1] < 1e-3 and errs[1] < errs[0] / 10
    with pytest.raises(ValueError, match="tol"):
        transient(paper92, initial=SMOOTH, times=times, tol=1e-4, scheme="theta",
                  discretisation=coarse)


# -- positivity (implicit Euler with the positive generator) ---------------------------
NARROW = {"mean": (0.0, 1.0), "std": (0.05, 0.05)}


@pytest.fixture(scope="module")
def positive_coarse(paper92):
    return {pos: discretise(paper92, nx=24, ny=48, positivity=pos)
            for pos in ("first-order", True)}


@pytest.mark.parametrize("pos", ["first-order", True])
@pytest.mark.parametrize("dt", [0.05, 2.0])
def test_positive_transient_is_nonnegative_and_conservative(paper92, coarse, positive_coarse,
                                                            pos, dt):
    """An unresolved narrow packet: Galerkin undershoots, the positive scheme never
    does, at any dt, and keeps the mass."""
    times = [1.0, 2.0, 6.0] if dt < 1 else [2.0, 6.0, 40.0]
    sols = transient(paper92, initial=NARROW, times=times, dt=dt,
                     discretisation=positive_coarse[pos])
    for s in sols:
        assert s.info["positivity"] == pos
        assert s.min_density >= -1e-14 * s.dofs.max()
        assert abs(s.mass - 1) < 1e-12
    galerkin = transient(paper92, initial=NARROW, times=[1.0], dt=0.05, discretisation=coarse)
    assert galerkin[0].min_density < -0.05 * galerkin[0].dofs.max()


def test_positive_transient_converges(paper92):
    """E[x²] of a smooth packet against a fine Galerkin reference: the limited positive
    scheme's error halves with h and dt (first order in time; measured 2.2–2.6×
    from nx = 24 to 48)."""
    times = [1.0, 5.0]
    ref = transient(paper92, initial=SMOOTH, times=times, nx=48, tol=1e-6)
    errs = []
    for nx, dt in ((16, 0.04), (32, 0.02)):
        sols = transient(paper92, initial=SMOOTH, times=times, nx=nx, dt=dt, positivity=True)
        errs.append([abs(s.moments()["E_x2"] - r.moments()["E_x2"]) for s, r in zip(sols, ref)])
    errs = np.array(errs)
    assert np.all(errs[1] < errs[0] / 1.6), errs
    assert np.all(errs[1] < 0.03 * np.array([r.moments()["E_x2"] for r in ref])), errs


def test_positive_transient_long_time_limit(paper92, positive_coarse):
    """Large implicit-Euler steps relax to the first-order positive stationary density."""
    st = fem.stationary(paper92, nx=24, ny=48, positivity="first-order")
    disc = positive_coarse["first-order"]
    sol = transient(paper92, initial=SMOOTH, times=[400.0], dt=4.0, discretisation=disc)[0]
    assert l1(disc, sol.dofs, st.dofs) < 1e-6


@pytest.mark.parametrize("kw, match", [
    (dict(positivity=True, scheme="bdf2"), "euler"),
    (dict(positivity=True, scheme="theta", theta=0.5), "euler"),
    (dict(positivity=True, tol=1e-4), "tol"),
    (dict(positivity=True, degree=2), "degree = 1"),
    (dict(positivity="upwind"), "positivity"),
    (dict(positivity="sometimes"), "positivity"),
])
def test_positive_transient_bad_input(paper92, kw, match):
    with pytest.raises(ValueError, match=match):
        transient(paper92, initial=SMOOTH, times=[1.0], nx=8, **kw)


def test_auto_positivity_in_a_transient_is_galerkin(paper92, coarse):
    a = transient(paper92, initial=SMOOTH, times=[1.0], dt=0.1, nx=24, ny=48, degree=1,
                  positivity="auto")[0]
    b = transient(paper92, initial=SMOOTH, times=[1.0], dt=0.1, discretisation=coarse)[0]
    assert a.info["scheme"] == b.info["scheme"] == "bdf2"
    assert np.array_equal(a.dofs, b.dofs)
