"""AMG paths of fpk_vibro.fem.solve: correct where they apply, never an unconverged
density, and "auto" stays direct below the crossover (fast: small grids only)."""
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from fpk_vibro import fem
from fpk_vibro.exact import gibbs
from fpk_vibro.fem import solve as fs
from fpk_vibro.fem.transient import discretise
from fpk_vibro.model import VibroImpactSystem

pytest.importorskip("pyamg")

EXACT = VibroImpactSystem.paper(r=1.0, D2=0.0)


@pytest.fixture(scope="module")
def positive():
    return discretise(EXACT, nx=24, ny=96, positivity="first-order")


@pytest.fixture(scope="module")
def galerkin():
    return discretise(EXACT, nx=16, ny=64)


def test_amg_stationary_equals_direct_on_positive_generator(positive):
    d = positive
    pd, _ = fs.solve_stationary(d.L, d.unit, solver="direct")
    pa, iamg = fs.solve_stationary(d.L, d.unit, solver="amg")
    assert iamg.solver == "amg" and iamg.iterations > 0
    assert abs(d.unit @ pa - 1) < 1e-12
    assert np.max(np.abs(pa - pd)) < 1e-7 * np.max(pd)


def test_amg_step_equals_lu_on_m_matrix(positive):
    d = positive
    K = sp.csr_matrix(d.M - 0.3 * d.L)
    assert fs.is_m_matrix_pattern(K)
    b = d.M @ np.full(K.shape[0], 1.0 / d.unit.sum())
    xa = fs.factorised(K, solver="amg")(b)
    xl = fs.factorised(K, solver="direct")(b)
    assert np.linalg.norm(K @ xa - b) <= 1e-9 * np.linalg.norm(b)
    assert np.max(np.abs(xa - xl)) < 1e-8 * np.max(np.abs(xl))


def test_amg_on_galerkin_raises_named_error(galerkin):
    d = galerkin
    with pytest.raises(fs.SolverNotConverged, match="solver="):
        fs.solve_stationary(d.L, d.unit, solver="amg", maxiter=30)
    K = sp.csr_matrix(d.M - 0.3 * d.L)
    b = d.M @ np.full(K.shape[0], 1.0 / d.unit.sum())
    with pytest.raises(RuntimeError):          # SolverNotConverged is a RuntimeError
        fs.factorised(K, solver="amg", maxiter=30)(b)


def test_public_amg_on_exact_case_is_right_or_raises():
    """The measured bug: solver="amg" returned E[H] = 4.148 (exact 0.254)."""
    exact = gibbs(EXACT).moments()["E_H"]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            sol = fem.stationary(EXACT, solver="amg", nx=24)
    except fs.SolverNotConverged as exc:
        assert exc.residual > exc.tol
        return
    assert abs(sol.moments()["E_H"] - exact) < 1e-3


def test_auto_falls_back_and_says_so(galerkin, monkeypatch):
    d = galerkin
    monkeypatch.setattr(fs, "AMG_MIN_DOFS", 10)
    monkeypatch.setattr(fs, "AMG_MIN_DOFS_STATIONARY", 10)
    monkeypatch.setattr(fs, "is_generator_pattern", lambda L: True)   # force the AMG try
    p, info = fs.solve_stationary(d.L, d.unit, solver="auto", maxiter=20)
    assert info.solver.startswith("direct (fallback")
    assert "did not converge" in info.extra["fallback"]
    pd, _ = fs.solve_stationary(d.L, d.unit, solver="direct")
    assert np.allclose(p, pd, rtol=0, atol=1e-10 * pd.max())
    K = sp.csr_matrix(d.M - 0.3 * d.L)
    monkeypatch.setattr(fs, "is_m_matrix_pattern", lambda K: True)
    monkeypatch.setattr(fs, "lu_bytes", lambda n: 1e30)               # "LU does not fit"
    f = fs.factorised(K, maxiter=20)
    assert f.kind == "amg"
    b = d.M @ np.full(K.shape[0], 1.0 / d.unit.sum())
    x = f(b)
    assert f.kind == "lu" and "SuperLU" in f.info["fallback"]
    assert np.linalg.norm(K @ x - b) <= 1e-10 * np.linalg.norm(b)


def test_auto_picks_direct_below_crossover_and_for_galerkin(positive, galerkin):
    d = positive
    assert d.L.shape[0] < fs.AMG_MIN_DOFS
    _, info = fs.solve_stationary(d.L, d.unit)
    assert info.solver == "direct"
    K = sp.csr_matrix(d.M - 0.3 * d.L)
    assert fs.factorised(K).kind == "lu"
    assert fs.factorised(K, reuse=False).kind == "lu"
    # the Galerkin matrices never get AMG by size: wrong sign pattern
    assert not fs.is_generator_pattern(galerkin.L)
    assert not fs.is_m_matrix_pattern(galerkin.M - 0.3 * galerkin.L)
    assert fs.is_generator_pattern(d.L)


def test_auto_picks_amg_above_crossover(positive, monkeypatch):
    d = positive
    monkeypatch.setattr(fs, "AMG_MIN_DOFS", 100)
    _, info = fs.solve_stationary(d.L, d.unit)
    assert info.solver == "direct"                  # stationary: never by default
    monkeypatch.setattr(fs, "AMG_MIN_DOFS_STATIONARY", 100)
    p, info = fs.solve_stationary(d.L, d.unit)
    assert info.solver == "amg" and "fallback" not in info.extra
    pd, _ = fs.solve_stationary(d.L, d.unit, solver="direct")
    assert np.max(np.abs(p - pd)) < 1e-7 * pd.max()
    K = sp.csr_matrix(d.M - 0.3 * d.L)
    assert fs.factorised(K).kind == "lu"            # the LU fits: reused over many steps
    assert fs.factorised(K, reuse=False).kind == "amg"     # one solve: by size
    monkeypatch.setattr(fs, "lu_bytes", lambda n: 1e30)
    f = fs.factorised(K)
    assert f.kind == "amg"
    b = d.M @ np.full(K.shape[0], 1.0 / d.unit.sum())
    assert np.linalg.norm(K @ f(b) - b) <= 1e-9 * np.linalg.norm(b)
