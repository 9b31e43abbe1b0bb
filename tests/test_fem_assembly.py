"""FEM assembly: mass conservation (zero column sums), Kronecker = general assembly,
the impact coupling, and input validation (docs/theory.md, §Impact coupling)."""
import numpy as np
import pytest
import skfem

from fpk_vibro import VibroImpactSystem
from fpk_vibro.fem import assemble, assemble_tensor, domain, stationary, structured_mesh
from fpk_vibro.fem.generator import element_for, tensor_to_basis
from fpk_vibro.fem.impact import coupling_matrix


def _basis(mesh, degree):
    return skfem.CellBasis(mesh, element_for(mesh, degree), intorder=2 * degree + 3)


@pytest.mark.parametrize("r", [0.0, 0.3, 0.92, 1.0])
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("kind", ["quad", "tri"])
def test_column_sums_vanish(r, degree, kind):
    """1ᵀ L = 0: probability is conserved by the discrete generator for every r."""
    s = VibroImpactSystem.paper(r=r)
    m, _, _ = structured_mesh(domain(s), 6, 10, kind=kind)
    L, M = assemble(s, _basis(m, degree))
    scale = abs(L).max()
    assert np.max(np.abs(L.sum(axis=0))) < 1e-13 * scale
    assert abs(M.sum() - 2 * 0.6 * 2 * domain(s).y_max) < 1e-12 * M.sum()


@pytest.mark.parametrize("r", [0.0, 0.3, 0.92, 1.0])
@pytest.mark.parametrize("degree", [1, 2])
def test_kronecker_assembly_equals_general(r, degree):
    s = VibroImpactSystem.paper(r=r, D2=0.05)
    d = domain(s)
    m, xs, ys = structured_mesh(d, 6, 8)
    b = _basis(m, degree)
    L, M = assemble(s, b)
    op = assemble_tensor(s, xs, ys, degree, d)
    k = tensor_to_basis(op, b)
    assert np.max(np.abs(op.L.sum(axis=0))) < 1e-13 * abs(op.L).max()
    assert abs(L - op.L[k][:, k]).max() < 1e-12 * abs(L).max()
    assert abs(M - op.M[k][:, k]).max() < 1e-14
    assert np.allclose(op.unit[k], np.asarray(M.sum(axis=0)).ravel(), rtol=1e-13, atol=0)


@pytest.mark.parametrize("barriers", ["right", "none"])
def test_truncated_sides_conserve_mass(barriers):
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, delta=0.6, r=0.5, barriers=barriers)
    d = domain(s)
    assert d.walls[0].r == 1.0 and d.x0 < -0.6
    m, xs, ys = structured_mesh(d, 8, 10)
    L, _ = assemble(s, _basis(m, 1))
    assert np.max(np.abs(L.sum(axis=0))) < 1e-13 * abs(L).max()


def test_coupling_reinjects_at_mapped_points():
    """B(p, q) = ∫ v p(Δ,v)[q(Δ,v) − q(Δ,−r v)] dv with p ≡ 1 and q(x, y) = y:
    ∫₀^Y v (v + r v) dv = (1 + r) Y³/3, evaluated off the nodes (r = 0.37)."""
    r = 0.37
    s = VibroImpactSystem.paper(r=r)
    d = domain(s, y_max=2.0)
    m, _, _ = structured_mesh(d, 4, 6)
    b = _basis(m, 1)
    B = coupling_matrix(b, d.walls[1], d.y_max, 3)
    q = b.doflocs[1]           # y is in the Q1 space
    one = np.ones(b.N)
    assert abs(q @ (B @ one) - (1 + r) * 8.0 / 3.0) < 1e-12
    assert abs(one @ (B @ one)) < 1e-14        # q ≡ 1: no net flux


def test_only_active_terms():
    s = VibroImpactSystem.paper(r=1.0, D2=0.0)
    d = domain(s)
    m, xs, ys = structured_mesh(d, 4, 6)
    s2 = s.replace(D2=1e-300)
    L1 = assemble_tensor(s, xs, ys, 1, d).L
    L2 = assemble_tensor(s2, xs, ys, 1, d).L
    assert abs(L1 - L2).max() < 1e-14


@pytest.mark.parametrize("kwargs, name", [
    (dict(degree=5), "degree"), (dict(solver="lu"), "solver"), (dict(nx=0), "nx"),
    (dict(ny=7), "ny"), (dict(y_max=-1.0), "y_max"), (dict(y_max=float("nan")), "y_max"),
    (dict(element="hex"), "element"), (dict(grading=-1.0), "grading"),
    (dict(positivity="yes"), "positivity"), (dict(positivity=True, degree=2), "positivity"),
    (dict(mesh=42), "mesh"), (dict(mesh="/no/such/file.msh"), "mesh"),
    (dict(assembly="fast"), "assembly"),
])
def test_bad_input_names_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        stationary(VibroImpactSystem.paper(), **kwargs)


def test_bad_system():
    with pytest.raises(ValueError, match="system"):
        stationary({"a": 1.0})
