"""FEMSolution: the Solution interface, save/load, meshio output, moments
(docs/theory.md, §FPK on the strip)."""
import numpy as np
import pytest
from scipy import integrate

from fpk_vibro import Solution, VibroImpactSystem
from fpk_vibro.fem import FEMSolution, default_y_max, stationary

SYSTEM = VibroImpactSystem.paper(r=1.0, D2=0.0)
T = SYSTEM.D1 / SYSTEM.c


@pytest.fixture(scope="module")
def sol():
    return stationary(SYSTEM, nx=48, ny=160, degree=2)


def gibbs_Z():
    Y = default_y_max(SYSTEM)
    zx = integrate.quad(lambda x: np.exp(-SYSTEM.potential(x) / T), -0.6, 0.6)[0]
    zy = integrate.quad(lambda y: np.exp(-0.5 * y * y / T), -Y, Y)[0]
    return zx, zy, Y


def test_attributes(sol):
    assert isinstance(sol, Solution) and sol.kind == "fem"
    assert abs(sol.mass - 1) < 1e-12
    assert sol.residual < 1e-10
    assert sol.dofs.shape == (sol.basis.N,)
    assert sol.min_density >= -1e-6 * sol.dofs.max()


def test_default_y_max_tail_rule():
    """Gibbs: the exact mass above the cut energy H_t = Y²/2 is just below 1e-8."""
    from scipy.special import erfc
    Y = default_y_max(SYSTEM)
    H_t = 0.5 * Y * Y
    w = lambda x: np.exp(-SYSTEM.potential(x) / T)
    tail = integrate.quad(lambda x: w(x) * erfc(np.sqrt((H_t - SYSTEM.potential(x)) / T)),
                          -0.6, 0.6)[0] / integrate.quad(w, -0.6, 0.6)[0]
    assert 0.8e-8 < tail <= 1e-8


def test_marginals_match_exact(sol):
    zx, zy, Y = gibbs_Z()
    x = np.linspace(-0.6, 0.6, 13)
    px = np.exp(-SYSTEM.potential(x) / T) / zx
    assert np.max(np.abs(sol.pdf_x(x) - px)) < 1e-4
    y = np.linspace(-2, 2, 11)
    py = np.exp(-0.5 * y * y / T) / zy
    assert np.max(np.abs(sol.pdf_y(y) - py)) < 1e-4
    assert sol.pdf_x(np.array([0.7]))[0] == 0.0
    assert sol.pdf_y(np.array([Y + 1]))[0] == 0.0
    assert sol.pdf_joint(np.array([0.61]), np.array([0.0]))[0] == 0.0


def test_pdf_energy_matches_exact(sol):
    """p(H) = exp(−H/T) T(H) / Z with T(H) = 2∫ dx/√(2H − 2G) over the strip."""
    zx, zy, _ = gibbs_Z()
    s = SYSTEM
    Hb = s.barrier_energy
    for H in (0.05, 0.15, 0.3, 0.6):
        A = float(s.amplitude(H))
        if A <= 0.6:     # Jacobi weight handles the turning points exactly
            per = integrate.quad(lambda x: 1 / np.sqrt(s.a + 0.5 * s.b * (A * A + x * x)),
                                 -A, A, weight="alg", wvar=(-0.5, -0.5))[0]
        else:
            per = integrate.quad(lambda x: 1 / np.sqrt(2 * H - 2 * s.potential(x)), -0.6, 0.6)[0]
        exact = 2 * per * np.exp(-H / T) / (zx * zy)
        assert abs(sol.pdf_energy(np.array([H]))[0] - exact) < 2e-4 * exact + 1e-6, (H, Hb)
    H = np.linspace(1e-6, 6.0, 4001)
    assert abs(np.trapezoid(sol.pdf_energy(H), H) - 1) < 2e-3


def test_moments_match_exact(sol):
    zx, zy, Y = gibbs_Z()
    Ex2 = integrate.quad(lambda x: x * x * np.exp(-SYSTEM.potential(x) / T), -0.6, 0.6)[0] / zx
    Ey2 = integrate.quad(lambda y: y * y * np.exp(-0.5 * y * y / T), -Y, Y)[0] / zy
    m = sol.moments()
    assert set(m) == {"E_H", "E_x2", "E_y2", "E_x4", "E_y4", "P_impact"}
    assert abs(m["E_x2"] - Ex2) < 1e-5 and abs(m["E_y2"] - Ey2) < 1e-5
    # P(H < G(Δ)) from the energy density of the exact Gibbs measure
    Hb = SYSTEM.barrier_energy
    inner = integrate.dblquad(lambda y, x: np.exp(-SYSTEM.energy(x, y) / T),
                              -0.6, 0.6, lambda x: -np.sqrt(max(2 * (Hb - SYSTEM.potential(x)), 0)),
                              lambda x: np.sqrt(max(2 * (Hb - SYSTEM.potential(x)), 0)))[0] / (zx * zy)
    assert abs(m["P_impact"] - (1 - inner)) < 1e-4


def test_no_barrier_has_no_p_impact():
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, barriers="none")
    sol = stationary(s, nx=24, ny=48)
    assert "P_impact" not in sol.moments()
    assert abs(sol.mass - 1) < 1e-12


def test_save_load_round_trip(sol, tmp_path):
    path = sol.save(tmp_path / "fem")
    back = Solution.load(path)
    assert isinstance(back, FEMSolution)
    x = np.linspace(-0.6, 0.6, 7)[:, None]
    y = np.linspace(-2, 2, 5)[None, :]
    assert np.array_equal(back.pdf_joint(x, y), sol.pdf_joint(x, y))
    assert np.array_equal(back.pdf_x(x.ravel()), sol.pdf_x(x.ravel()))
    assert np.array_equal(back.pdf_y(y.ravel()), sol.pdf_y(y.ravel()))
    assert np.array_equal(back.pdf_energy(np.array([0.1, 0.5])), sol.pdf_energy(np.array([0.1, 0.5])))
    assert back.moments() == sol.moments()
    assert back.residual == sol.residual


def test_save_vtu_readable(sol, tmp_path):
    import meshio
    p = sol.save_vtu(tmp_path / "p.vtu")
    m = meshio.read(p)
    assert m.points.shape[0] == sol.mesh.p.shape[1]
    assert np.allclose(m.point_data["p"], sol.dofs[sol.basis.nodal_dofs[0]])


def test_loaded_mesh_and_triangles(tmp_path):
    from fpk_vibro.fem import domain, structured_mesh
    m, _, _ = structured_mesh(domain(SYSTEM), 16, 40, kind="tri")
    m.save(str(tmp_path / "strip.msh"))
    a = stationary(SYSTEM, mesh=str(tmp_path / "strip.msh"))
    b = stationary(SYSTEM, nx=16, ny=40, element="tri")
    assert np.max(np.abs(np.sort(a.dofs) - np.sort(b.dofs))) < 1e-10


def test_tensor_evaluation_equals_basis_probes(sol):
    rng = np.random.default_rng(1)
    x = rng.uniform(-0.6, 0.6, 50)
    y = rng.uniform(-3, 3, 50)
    ref = sol.basis.probes(np.vstack([x, y])) @ sol.dofs
    assert np.max(np.abs(sol.pdf_joint(x, y) - ref)) < 1e-13


def test_shipped_meshes_load_and_solve():
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent / "meshes"
    files = sorted(root.glob("*.msh"))
    assert len(files) >= 3
    for f in files:
        delta = 1.0 if "d1.0" in f.name else 0.6
        s = VibroImpactSystem.paper(r=0.92, delta=delta)
        sol = stationary(s, mesh=f)
        assert abs(sol.mass - 1) < 1e-12 and sol.residual < 1e-10
        assert sol.min_density >= -1e-3 * sol.dofs.max()


def test_unilateral_barrier():
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, delta=0.6, r=0.8, barriers="right")
    sol = stationary(s, nx=48)
    assert abs(sol.mass - 1) < 1e-12
    m = sol.moments()
    assert 0 < m["P_impact"] < 1
    H = np.linspace(1e-6, 3.0, 3001)
    assert abs(np.trapezoid(sol.pdf_energy(H), H) - 1) < 5e-3


def test_grading_option_consistent():
    a = stationary(SYSTEM, nx=32, ny=96, degree=2, grading=1.5)
    b = stationary(SYSTEM, nx=32, ny=96, degree=2)
    assert abs(a.mass - 1) < 1e-12
    ma, mb = a.moments(), b.moments()
    assert abs(ma["E_H"] - mb["E_H"]) < 1e-4


def test_double_well_between_barriers():
    s = VibroImpactSystem(a=-1.0, b=1.0, c=0.1, D1=0.05, delta=1.5, r=0.8)
    sol = stationary(s, nx=48)
    assert abs(sol.mass - 1) < 1e-12
    x = np.linspace(-1.5, 1.5, 31)
    px = sol.pdf_x(x)
    assert px[15] < px[5] and px[15] < px[25]      # minimum at the hump x = 0
    P_impact = sol.moments()["P_impact"]
    assert 0 < P_impact < 1
    # p(H) of every level set (issue 31): above G(Δ) it carries P_impact, computed on
    # the mesh without it
    H = np.linspace(s.barrier_energy, 0.5 * sol.y_max ** 2, 4001)
    assert abs(np.trapezoid(sol.pdf_energy(H), H) - P_impact) < 1e-4 * P_impact
