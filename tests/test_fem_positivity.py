"""Positivity (DESIGN §3): the hard cases r ∈ {0, 0.1, 0.3}, D1 = 0.002, D2 = 0
go negative next to (±Δ, 0) with plain Galerkin; discrete upwinding gives a
generator (off-diagonals ≥ 0, zero column sums) whose null vector is ≥ 0."""
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem
from fpk_vibro.fem import assemble_tensor, domain, stationary
from fpk_vibro.fem.mesh import axis_nodes
from fpk_vibro.fem.positivity import discrete_upwinding

HARD = [VibroImpactSystem.paper(r=r, D1=0.002, D2=0.0) for r in (0.0, 0.1, 0.3)]
GEOM = [VibroImpactSystem.paper(r=0.5, D2=0.0, delta=d) for d in (0.1, 3.0)]


def test_plain_galerkin_goes_negative_on_hard_case():
    """The problem positivity addresses really is there (DESIGN §3 trial fact)."""
    sol = stationary(HARD[2], nx=64)
    assert sol.min_density < -0.01 * sol.dofs.max()
    assert abs(sol.mass - 1) < 1e-12


@pytest.mark.parametrize("system", HARD + GEOM, ids=lambda s: f"r{s.r}-D1{s.D1}-d{s.delta}")
def test_upwinded_operator_is_a_generator(system):
    d = domain(system)
    op = assemble_tensor(system, axis_nodes(d.x0, d.x1, 16),
                         axis_nodes(-d.y_max, d.y_max, 32, centre=0.0), 1, d)
    Lo, D = discrete_upwinding(op.L)
    off = Lo.tolil()
    off.setdiag(0)
    assert off.tocsr().min() >= 0
    scale = abs(op.L).max()
    assert np.max(np.abs(Lo.sum(axis=0))) < 1e-13 * scale
    assert abs(D - D.T).max() == 0 and np.max(np.abs(D.sum(axis=1))) < 1e-13 * scale


@pytest.mark.parametrize("system", HARD + GEOM, ids=lambda s: f"r{s.r}-D1{s.D1}-d{s.delta}")
def test_upwind_is_nonnegative(system):
    for nx, ny in ((16, 64), (32, 128)):
        sol = stationary(system, nx=nx, ny=ny, positivity="upwind")
        assert np.all(np.isfinite(sol.dofs))
        assert abs(sol.mass - 1) < 1e-12
        assert sol.min_density >= -1e-6 * sol.dofs.max()
        plain = stationary(system, nx=nx, ny=ny)
        assert abs(plain.mass - 1) < 1e-12


@pytest.mark.xfail(strict=True, reason="measured: first-order upwinding is far from "
                   "asymptotic (E[H] 3.49, 3.01, 2.29 at nx = 32, 64, 128 for Δ = 3); "
                   "the converging limited (AFC) solver is the open item")
def test_upwind_moments_converge():
    system = GEOM[1]
    EH = [stationary(system, nx=nx, positivity="upwind").moments()["E_H"] for nx in (16, 32, 64)]
    assert abs(EH[2] - EH[1]) < 0.6 * abs(EH[1] - EH[0]), EH


def test_afc_warns_when_not_converged():
    with pytest.warns(RuntimeWarning, match="AFC"):
        sol = stationary(HARD[2], nx=16, positivity=True)
    assert abs(sol.mass - 1) < 1e-12 and np.all(np.isfinite(sol.dofs))
