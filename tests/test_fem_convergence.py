"""Convergence on the exact case r = 1, D2 = 0: p ∝ exp(−(c/D1) H) on the strip
(docs/theory.md, §Assembly and solve, §Exact solution).  Paper a, b, c, D1, Δ.
Separate rate tests, as in scikit-fem."""
import numpy as np
import pytest
from skfem import Functional, asm

from fpk_vibro import VibroImpactSystem
from fpk_vibro.fem import stationary
from fpk_vibro.benchmarks.fem_scale import exact_errors

SYSTEM = VibroImpactSystem.paper(r=1.0, D2=0.0)
BETA = SYSTEM.c / SYSTEM.D1


def rates(levels, **kw):
    errs = []
    for i, n in enumerate(levels):
        sol = stationary(SYSTEM, nx=n, ny=4 * n, **kw)
        assert np.all(np.isfinite(sol.dofs))
        assert abs(sol.mass - 1.0) < 1e-12
        if i == len(levels) - 1:          # finest level: no undershoot
            assert sol.min_density >= -1e-6 * sol.dofs.max()
        assert sol.residual < 1e-10
        errs.append(exact_errors(sol))
    errs = np.array(errs)
    orders = np.log2(errs[:-1] / errs[1:])
    return errs, orders


def test_q1_quad_rate():
    errs, orders = rates([8, 16, 32, 64], degree=1, element="quad")
    assert np.all(orders[:, 0] >= 1.8), (errs, orders)     # L1
    assert np.all(orders[1:, 1] >= 1.8), (errs, orders)    # max norm
    assert errs[-1, 0] < 2e-4


def test_p1_tri_rate():
    errs, orders = rates([8, 16, 32, 64], degree=1, element="tri")
    assert np.all(orders[:, 0] >= 1.8), (errs, orders)
    assert np.all(orders[1:, 1] >= 1.8), (errs, orders)


def test_q1_general_assembly_same_solution():
    a = stationary(SYSTEM, nx=12, ny=40, assembly="tensor")
    b = stationary(SYSTEM, nx=12, ny=40, assembly="general")
    assert np.max(np.abs(a.dofs - b.dofs)) < 1e-10 * a.dofs.max()


def test_q2_rate():
    """Q2/P2: order 2 in L1 with the largest error at (0, 0) (see the FEM notes)."""
    errs, orders = rates([4, 8, 16, 32], degree=2, element="quad")
    assert np.all(orders[1:, 0] >= 1.8), (errs, orders)
    assert errs[-1, 0] < 2.5e-5


def test_p2_tri_rate():
    errs, orders = rates([4, 8, 16, 32], degree=2, element="tri")
    assert np.all(orders[1:, 0] >= 1.8), (errs, orders)


def test_pinned_row_does_not_change_solution():
    """The replaced row is implied by the others (1ᵀL = 0): any pin, same p."""
    from fpk_vibro.fem import assemble_tensor, domain
    from fpk_vibro.fem.mesh import axis_nodes
    from fpk_vibro.fem.solve import solve_stationary
    d = domain(SYSTEM)
    op = assemble_tensor(SYSTEM, axis_nodes(d.x0, d.x1, 8),
                         axis_nodes(-d.y_max, d.y_max, 24, centre=0.0), 2, d)
    p1, _ = solve_stationary(op.L, op.unit, solver="direct", pin=0)
    p2, _ = solve_stationary(op.L, op.unit, solver="direct", pin=int(np.argmax(op.unit)))
    assert np.max(np.abs(p1 - p2)) < 1e-10 * p1.max()


def test_q2_error_at_origin_is_set_by_x_resolution():
    """The Q2 finding: the largest error sits at (0, 0) and falls as h_x² whatever
    h_y (and quadrature, pin and coupling do not change it: see FEM notes).
    Galerkin loses one order for the pure transport y ∂p/∂x (no x-diffusion)."""
    def err0(nx, ny):
        sol = stationary(SYSTEM, nx=nx, ny=ny, degree=2)
        X = sol.basis.doflocs
        k = np.argmin(X[0] ** 2 + X[1] ** 2)
        Z = asm(Functional(lambda w: np.exp(-BETA * SYSTEM.energy(w.x[0], w.x[1]))), sol.basis)
        return abs(sol.dofs[k] - 1.0 / Z)
    e_a, e_b, e_c = err0(16, 256), err0(32, 256), err0(16, 512)
    assert 3.6 < e_a / e_b < 4.4                      # order 2 in h_x
    assert abs(e_c / e_a - 1) < 0.05                  # independent of h_y


def test_q2_error_not_from_quadrature(monkeypatch):
    import fpk_vibro.fem.generator as gen
    a = stationary(SYSTEM, nx=16, ny=64, degree=2)
    monkeypatch.setattr(gen, "quadrature_order", lambda d: 2 * d + 9)
    b = stationary(SYSTEM, nx=16, ny=64, degree=2)
    ea, eb = exact_errors(a), exact_errors(b)
    assert abs(ea[1] - eb[1]) < 1e-3 * ea[1]          # same max error (at (0, 0))
