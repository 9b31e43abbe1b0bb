"""Issue 31: an FE ``rtol`` bounds the estimated L1 error of the density as well as
the relative moments, and the estimates stay honest.

References are finer than the answers they judge: Galerkin Q4 on the answer's
wall-graded mesh with three times its nx and ny (cached per system and mesh, so
rtol = 1e-3 and 1e-4 share them), or the exact Gibbs density.  Effectivity = true
error / estimate must lie in [1/30, 2] where the true error is above FLOOR.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fpk_vibro import VibroImpactSystem, Wall, exact, fem
from fpk_vibro._checks import InputError
from fpk_vibro.fem.compare import AIMED, JUDGED, decided_by, difference
from fpk_vibro.quadrature import gauss_grid

#: Below this the true errors are those of the references: the exact density's
#: mass beyond the truncation (< 1e-8) moves E[H] by up to ~1e-7 relative
#: (measured 9e-8 against an estimate of 1.9e-8 on the peer's double well).
FLOOR = 2e-7
#: The path-integration peer's exact test: p ∝ exp(−(c/D1) H) = exp(−2H).
PEER = VibroImpactSystem(a=-1.0, b=0.25, c=1.0, D1=0.5, D2=0.0, barriers="none")


def _exact_errors(sol, system) -> dict:
    """L1 error and relative moment errors of ``sol`` against the Gibbs density (L1 by
    a tensor Gauss rule on the answer's own cells)."""
    ref = exact.gibbs(system)
    xs, ys = sol._tensor
    xq, wx = gauss_grid(np.asarray(xs), sol.degree + 3)
    yq, wy = gauss_grid(np.asarray(ys), sol.degree + 3)
    X, Y = np.meshgrid(xq, yq, indexing="ij")
    out = {"L1": float(wx @ np.abs(sol.pdf_joint(X, Y) - ref.pdf_joint(X, Y)) @ wy)}
    m, r = sol.moments(), ref.moments()
    out.update({k: abs(m[k] - r[k]) / abs(r[k]) for k in JUDGED if k in r and k in m})
    return out


def _effective(true: dict, est: dict) -> None:
    for k in AIMED:
        if k in true:
            assert true[k] <= 2 * est[k] + FLOOR, (k, true[k], est[k])
            if true[k] > FLOOR:
                assert true[k] >= est[k] / 30, (k, true[k], est[k])


@pytest.mark.parametrize("rtol", [1e-4, 1e-5])
def test_rtol_bounds_the_density_on_the_exact_double_well(rtol):
    """rtol = 1e-5 returned Q3, nx = 16 with an L1 error of 6.1e-3 (the moments met
    it; the L1 error was only reported), the same as rtol = 1e-4."""
    sol = fem.stationary(PEER, rtol=rtol)
    est = sol.error_estimate()
    true = _exact_errors(sol, PEER)
    assert true["L1"] <= rtol and max(true.values()) <= rtol, true
    assert max(est[k] for k in AIMED if k in est) <= rtol
    assert sol.info["rtol_decided_by"] == "L1" == decided_by(est)
    assert sol.info["under_resolved"] is False
    _effective(true, est)


def test_info_names_the_quantity_that_decided():
    """Every rtol answer says which quantity its level was decided by: the one whose
    estimate came nearest to rtol, the L1 error included."""
    sol = fem.stationary(VibroImpactSystem.paper(), rtol=1e-3)
    est = sol.error_estimate()
    key = sol.info["rtol_decided_by"]
    assert key in AIMED and est[key] == max(est[k] for k in AIMED if k in est)
    assert max(est[k] for k in AIMED if k in est) <= 1e-3
    assert f"({key})" in sol.info["adapt_levels"]


@functools.lru_cache(maxsize=16)
def _reference(system, nx: int, ny: int, y_max: float):
    """Q4 on the wall-graded mesh with three times the cells both ways."""
    return fem.stationary(system, degree=4, nx=3 * nx, ny=3 * ny, y_max=y_max,
                          wall_grading=2.0, positivity=False)


@st.composite
def systems(draw):
    """Double wells (damping down to 0.02), softening springs, one-sided and
    asymmetric walls, r down to 0.3, strong parametric noise (D2 up to 0.8 c)."""
    kind = draw(st.sampled_from(["double well", "softening", "one-sided", "asymmetric"]))
    c = draw(st.sampled_from([0.02, 0.1, 0.3]))
    D1 = draw(st.sampled_from([0.01, 0.05]))
    D2 = c * draw(st.sampled_from([0.0, 0.1, 0.8]))
    r = draw(st.sampled_from([1.0, 0.6, 0.3]))
    if kind == "double well":
        return VibroImpactSystem(a=-1.0, b=1.0, c=c, D1=5 * D1, D2=D2, delta=1.6, r=r)
    if kind == "softening":
        return VibroImpactSystem(a=1.0, b=-0.5, c=c, D1=D1, D2=D2, delta=0.8, r=r)
    if kind == "one-sided":
        return VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, delta=0.2, r=r,
                                 barriers="right")
    return VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, left=Wall(-0.3, r),
                             right=Wall(0.5, min(1.0, r + 0.3)))


@pytest.mark.long
@pytest.mark.slow
@settings(max_examples=5, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(systems())
def test_rtol_meets_the_density_and_the_moments_against_a_finer_reference(s):
    """rtol = 1e-3 and 1e-4: the L1 error and the moment errors against Q4 at three
    times the answer's nx and ny are within rtol, and the estimate is honest and not
    vacuous; or the solve is refused in one line naming rtol (the corners of r < 1
    walls: the L1 error converges at order 0.1–2 in nx there)."""
    for rtol in (1e-3, 1e-4):
        try:
            sol = fem.stationary(s, rtol=rtol)
        except InputError as exc:
            assert exc.name == "rtol" and "\n" not in str(exc)
            assert "is not reached" in str(exc)
            continue
        est = sol.error_estimate()
        assert max(est[k] for k in AIMED if k in est) <= rtol
        xs, ys = sol._tensor
        ref = _reference(s, xs.size - 1, ys.size - 1, float(ys[-1]))
        true = difference(sol, ref)
        assert max(true[k] for k in AIMED if k in true) <= rtol, (true, est)
        _effective(true, est)


@pytest.mark.slow
def test_references_agree_two_ways_at_the_hard_corner():
    """The hard corner r = 0.05 at D1 = 0.002: wall-graded Q4 at nx = 48 and 96, and
    wall-graded Q2 at nx = 256, agree (two discretisations, two levels); the uniform
    Q2 mesh at nx = 192, the old kind of reference, is 6.9e-3 off in P_impact
    (measured; the issue found up to 2e-3 at r <= 0.25), so it judges nothing."""
    s = VibroImpactSystem.paper(r=0.05, D1=0.002, D2=0.0)

    def solve(**kw):
        return fem.stationary(s, positivity=False, **kw)

    q4 = solve(degree=4, nx=96, wall_grading=2.0)
    coarse = difference(solve(degree=4, nx=48, wall_grading=2.0), q4)
    q2 = difference(solve(degree=2, nx=256, wall_grading=2.0), q4)
    uniform = difference(solve(degree=2, nx=192), q4)
    # measured: 1.6e-4, E_* <= 4.1e-6, P 3.8e-4 | 3.2e-5, E_* <= 6.3e-8, P 1.4e-5
    assert coarse["L1"] < 5e-4 and max(coarse[k] for k in JUDGED[:3]) < 2e-5
    assert coarse["P_impact"] < 1e-3
    assert q2["L1"] < 1e-4 and max(q2[k] for k in JUDGED[:3]) < 1e-6
    assert q2["P_impact"] < 5e-5
    assert uniform["P_impact"] > 2e-3 and uniform["L1"] > 10 * q2["L1"]
