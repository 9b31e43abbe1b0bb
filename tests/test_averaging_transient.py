"""The averaged FPK in time (docs/theory.md, §Averaged transient): conservation,
equilibrium, convergence."""
import numpy as np
import pytest

from fpk_vibro import Solution, VibroImpactSystem, averaging
from fpk_vibro.averaging.transient import averaged_operator, energy_faces, initial_cell_masses
from fpk_vibro.initial import parse_initial
from fpk_vibro.orbits import orbit_nodes

PACKET = {"mean": (0.0, 1.0), "std": (0.0, 0.05)}


@pytest.fixture(scope="module")
def paper92():
    return VibroImpactSystem.paper(r=0.92)


def test_operator_conserves_mass_and_keeps_stationary_density(paper92):
    st = averaging.stationary(paper92)
    faces = energy_faces(paper92, 3.0, 300)
    A = averaged_operator(paper92, faces, st)
    h = np.diff(faces)
    assert np.max(np.abs(h @ A)) < 1e-12 * np.max(np.abs(A.data))   # column sums · h vanish
    offdiag = A - np.diag(A.diagonal())
    assert np.all(np.asarray(offdiag[offdiag != 0]) > 0)              # generator: positivity
    c = 0.5 * (faces[1:] + faces[:-1])
    ps = orbit_nodes(paper92, c).period * np.exp(-st.phi(c))
    assert np.max(np.abs(A @ ps)) < 1e-12 * np.max(np.abs(A.diagonal() * ps))


def test_mass_and_positivity_over_time(paper92):
    sols = averaging.transient(paper92, initial=PACKET, times=[0, 1, 5, 40, 500])
    for s in sols:
        assert abs(s.mass - 1) < 1e-10   # Radau: Newton tolerance, not exact solves
        assert s.min_density >= -1e-14 * s.density.max()
    assert [s.time for s in sols] == [0, 1, 5, 40, 500]


def test_initial_energy_distribution(paper92):
    sol = averaging.transient(paper92, initial=PACKET, times=[0.0])[0]
    # H = y²/2 with y ~ N(1, 0.05²): E[H] = (1 + 0.05²)/2, E[H²] = E[y⁴]/4
    assert sol.moments()["E_H"] == pytest.approx(0.5 * (1 + 0.05**2), rel=1e-4)
    # a general Gaussian against a sampled histogram of the same spec
    spec = {"mean": (0.2, 0.4), "std": (0.1, 0.2)}
    faces = energy_faces(paper92, 2.0, 64)
    exact = initial_cell_masses(parse_initial(spec, paper92), faces)
    init = parse_initial(spec, paper92)
    x, y = init.sample(400_000, np.random.default_rng(1))
    hist, _ = np.histogram(paper92.energy(x, y), bins=faces)
    hist = hist / 400_000
    se = np.sqrt(exact * (1 - exact) / 400_000) + 1e-12
    assert np.max(np.abs(hist - exact) / se) < 5


def test_long_time_limit_and_second_order(paper92):
    st = averaging.stationary(paper92).moments()
    errs = []
    for n in (200, 400, 800):
        m = averaging.transient(paper92, initial=PACKET, times=[4000.0], n_cells=n)[0].moments()
        errs.append(max(abs(m[k] / st[k] - 1) for k in ("E_H", "E_x2", "E_y2", "P_impact")))
    assert errs[-1] < 1e-5
    order = np.log2(errs[0] / errs[2]) / 2
    assert order > 1.8


def test_relaxation_is_monotone_in_L1(paper92):
    st = averaging.stationary(paper92)
    sols = averaging.transient(paper92, initial=PACKET, times=[5, 20, 80, 320])
    H = np.linspace(0, sols[0].faces[-1], 4001)
    d = [np.trapezoid(np.abs(s.pdf_energy(H) - st.pdf_energy(H)), H) for s in sols]
    assert all(d[i] > d[i + 1] for i in range(3)) and d[-1] < 0.01


def test_marginals_integrate_to_one(paper92):
    """The piecewise-linear p(H) differs from the cell masses by O(h²)."""
    x = np.linspace(-0.6, 0.6, 4001)
    y = np.linspace(-3, 3, 8001)
    dev = []
    for n in (400, 800):
        s = averaging.transient(paper92, initial=PACKET, times=[10.0], n_cells=n)[0]
        dx, dy = np.trapezoid(s.pdf_x(x), x) - 1, np.trapezoid(s.pdf_y(y), y) - 1
        assert dx == pytest.approx(dy, abs=1e-6)   # both are the mass of the same p(x, y)
        dev.append(abs(dx))
    assert dev[0] < 5e-4 and dev[1] < dev[0] / 3


def test_round_trip(tmp_path, paper92):
    s = averaging.transient(paper92, initial=PACKET, times=[3.0])[0]
    back = Solution.load(s.save(tmp_path / "t3"))
    assert back.time == 3.0 and back.moments() == s.moments()
    z = np.linspace(0, 1, 9)
    assert np.array_equal(back.pdf_y(z), s.pdf_y(z))


@pytest.mark.parametrize("kw, name", [
    (dict(times=[-1.0]), "times"), (dict(times=[]), "times"), (dict(times=[np.nan]), "times"),
    (dict(n_cells=3), "n_cells"), (dict(H_max=-2.0), "H_max"), (dict(rtol=1.0), "rtol"),
    (dict(initial={"mean": (0, 1)}), "std"), (dict(initial={"mean": (2.0, 0), "std": (0, 0)}), "x0"),
])
def test_bad_input(paper92, kw, name):
    args = {**dict(initial=PACKET, times=[1.0]), **kw}
    with pytest.raises(ValueError, match=name):
        averaging.transient(paper92, **args)
