"""The stationary FE error estimate (sol.error_estimate()) and the accuracy-driven
solve (fem.stationary(system, rtol=...)): fpk_vibro.fem.estimate, issue 23 §1–2.

Effectivity = true error / estimate must lie in [1/30, 2] where the error is above
the estimate's floor (the truncation at y_max, ~1e-7 relative: below it both are
round-off and tail mass)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fpk_vibro import exact, fem
from fpk_vibro._checks import InputError
from fpk_vibro.fem.estimate import AIMED, JUDGED, KEYS, _gauss_grid, difference
from fpk_vibro.model import VibroImpactSystem, Wall

FLOOR = 1e-6


def _true(sol, ref) -> dict:
    """Errors of ``sol`` against an exact density (L1 by a tensor Gauss rule)."""
    xs, ys = sol._tensor
    xq, wx = _gauss_grid(np.asarray(xs), sol.degree + 3)
    yq, wy = _gauss_grid(np.asarray(ys), sol.degree + 3)
    X, Y = np.meshgrid(xq, yq, indexing="ij")
    out = {"L1": float(wx @ np.abs(sol.pdf_joint(X, Y) - ref.pdf_joint(X, Y)) @ wy)}
    m, r = sol.moments(), ref.moments()
    for k in JUDGED:
        if k in r:
            scale = max(abs(r[k]), 1e-3) if k == "P_impact" else abs(r[k])
            out[k] = abs(m[k] - r[k]) / scale
    return out


def _effective(true: dict, est: dict, floor: float = 0.0) -> None:
    for k in KEYS:
        if k not in true:
            continue
        assert true[k] <= 2 * est[k] + floor, (k, true[k], est[k])
        if true[k] > FLOOR:
            assert true[k] >= est[k] / 30, (k, true[k], est[k])


EXACT = {"paper r=1": VibroImpactSystem.paper(r=1.0, D2=0.0),
         "double well": VibroImpactSystem(a=-1, b=1, c=0.1, D1=0.05, delta=2.0, r=1.0),
         "softening": VibroImpactSystem(a=1, b=-0.5, c=0.05, D1=0.02, delta=1.0, r=1.0)}


@pytest.mark.parametrize("name", sorted(EXACT))
@pytest.mark.parametrize("degree,nx", [(1, 16), (2, 8), (2, 48), (3, 8), (4, 8), (4, 16)])
def test_effectivity_on_the_exact_case(name, degree, nx):
    s = EXACT[name]
    sol = fem.stationary(s, degree=degree, nx=nx, positivity=False)
    est = sol.error_estimate()
    assert set(KEYS) <= set(est) and "h/2" in est["assumes"]
    _effective(_true(sol, exact.gibbs(s)), est)


def test_rtol_meets_itself_on_the_exact_case():
    s = EXACT["double well"]
    for rtol in (1e-3, 1e-4):
        sol = fem.stationary(s, rtol=rtol)
        est = sol.error_estimate()
        assert max(est[k] for k in JUDGED) <= rtol
        assert sol.info["under_resolved"] is False and sol.info["rtol"] == rtol
        true = _true(sol, exact.gibbs(s))
        _effective(true, est)
        assert max(true[k] for k in JUDGED) <= 2 * rtol


@st.composite
def systems(draw):
    kind = draw(st.sampled_from(["double well", "softening", "one-sided", "asymmetric"]))
    c = draw(st.sampled_from([0.05, 0.1, 0.3]))
    D1 = draw(st.sampled_from([0.01, 0.05]))
    D2 = draw(st.sampled_from([0.0, 0.01, 0.1]))
    r = draw(st.sampled_from([1.0, 0.9, 0.6, 0.3]))
    if kind == "double well":
        return VibroImpactSystem(a=-1.0, b=1.0, c=c, D1=5 * D1, D2=D2, delta=2.0, r=r)
    if kind == "softening":
        return VibroImpactSystem(a=1.0, b=-0.5, c=c, D1=D1, D2=D2, delta=0.8, r=r)
    if kind == "one-sided":
        return VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, delta=0.2, r=r,
                                 barriers="right")
    return VibroImpactSystem(a=1.0, b=0.2, c=c, D1=D1, D2=D2, left=Wall(-0.8, r),
                             right=Wall(0.4, min(1.0, r + 0.3)))


@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(systems())
def test_rtol_against_a_fine_reference(s):
    """The adaptive solve at rtol = 1e-3 against degree 4 at twice its nx: the
    estimate is honest (true ≤ 2 est) and not vacuous, or the solve is refused in
    one line naming rtol."""
    try:
        sol = fem.stationary(s, rtol=1e-3)
    except InputError as exc:
        assert exc.name == "rtol" and "\n" not in str(exc)
        return
    est = sol.error_estimate()
    xs, ys = sol._tensor
    ref = fem.stationary(s, degree=4, nx=2 * (xs.size - 1), ny=2 * (ys.size - 1),
                         y_max=float(ys[-1]), positivity=False)
    _effective(difference(sol, ref), est)


PAPER = VibroImpactSystem.paper()
DOUBLE_WELL = VibroImpactSystem(a=-1.0, b=1.0, c=0.025, D1=0.05, D2=0.01, delta=2.0, r=0.92)


@pytest.mark.parametrize("s,kw", [(PAPER, {"nx": 16}), (DOUBLE_WELL, {"nx": 48}),
                                  (PAPER, {"nx": 2}),
                                  (VibroImpactSystem.paper(c=1e6), {}),
                                  (VibroImpactSystem.paper(D1=1e-12), {})],
                         ids=["nx16", "double-well", "nx2", "c=1e6", "D1=1e-12"])
def test_wrong_answers_meet_their_estimate(s, kw):
    """The issue's 'wrong answers flagged as resolved': the estimate covers the
    true error (reference: Q4 at nx = 64; nx = 32 was 5.6e-6 off it at D1 = 1e-12,
    whose strip now ends where its density does and whose default is within 1e-8.
    c = 1e6 is overdamped: no FE level is a reference there (Q4 at nx = 32, 64, 128:
    E[H] 1.02e-8, 1.41e-8, 1.13e-8), the Gibbs density is, its walls and D2 x²
    (1e-8 relative) being out of reach)."""
    sol = fem.stationary(s, **kw)
    est = sol.error_estimate()
    ref = (exact.gibbs(s.replace(D2=0.0, r=1.0)).moments() if s.c >= 1e6
           else fem.stationary(s, degree=4, nx=64, positivity=False).moments())
    m = sol.moments()
    true = {k: abs(m[k] - ref[k]) / (max(abs(ref[k]), 1e-3) if k == "P_impact" else abs(ref[k]))
            for k in JUDGED}
    for k in JUDGED:
        assert true[k] <= 2 * est[k], (k, true[k], est[k])
    if max(true.values()) > 1e-3:
        assert sol.info["under_resolved"] is True
        assert "error estimate" in sol.info["under_resolved_reason"]


def test_rtol_is_declared_once_and_checked():
    assert "rtol" in fem.Options.for_mode("stationary")
    assert "rtol" in fem.Options.for_mode("transient")       # space and time
    for kw in ({"nx": 16}, {"degree": 3}, {"positivity": "quick"}):
        with pytest.raises(InputError) as exc:
            fem.stationary(PAPER, rtol=1e-3, **kw)
        assert "\n" not in str(exc.value) and "rtol" in str(exc.value)
    with pytest.raises(InputError, match="rtol must be"):
        fem.stationary(PAPER, rtol=0.0)


def test_a_y_max_beyond_the_density_is_refused_naming_it():
    """y_max = 1e6 (E[H] 3.3e8 off before; its richer level made SuperLU stall)."""
    with pytest.raises(InputError) as exc:
        fem.stationary(PAPER, y_max=1e6)
    assert exc.value.name == "y_max" and "\n" not in str(exc.value)


@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(systems())
def test_default_against_a_fine_reference(s):
    """The default solve (rtol = 1e-4, best effort, non-negative) against Q4 at twice
    its nx on the same graded mesh: p >= 0, and the estimate, correction included, is
    honest and not vacuous; where rtol was not reached the answer says so."""
    sol = fem.stationary(s)
    assert sol.dofs.min() >= 0 and abs(sol.mass - 1) < 1e-12
    est = sol.error_estimate()
    if not np.isfinite(max(est[k] for k in JUDGED if k in est)):
        assert sol.info["under_resolved"] is True
        return
    if max(est[k] for k in JUDGED if k in est) > 1e-4:
        assert sol.info["under_resolved"] is True and "rtol_not_reached" in sol.info
    xs, ys = sol._tensor
    ref = fem.stationary(s, degree=4, nx=2 * (xs.size - 1), ny=2 * (ys.size - 1),
                         y_max=float(ys[-1]), wall_grading=sol._options.wall_grading,
                         positivity=False)
    _effective(difference(sol, ref), est)


@pytest.mark.long
def test_transient_rtol_estimates_space_and_time():
    """fem.transient(..., rtol=0.1) on the paper packet: at each output time the
    estimates of the moments and of the L1 error (what rtol bounds since issue 31)
    meet rtol, and the true error (against Q4, nx = 32, BDF2 tolerance 1e-7) is
    below twice the estimate (and 1e-3 rtol) and within 30× of it.  (rtol = 1e-2 met
    the moments at Q3, nx = 16; its L1 estimate is 1.1e-2 at Q4, nx = 16, and the
    next level takes ~60 s: refused in one line, as 5e-2 is.)  The 1e-3 rtol: E[H]
    at t = 1 is 1.9e-5 off, its estimate 8.8e-6, where E[x²] and E[y²] are 3e-3 and
    6e-3 off: their errors cancel in E[H] = E[y²]/2 + E[G], and in its difference
    to the richer level alike (the reference is within 2.5e-8 of Q4, nx = 48)."""
    s = PAPER
    init = {"mean": (0.0, 0.5), "std": (0.1, 0.1)}
    sols = fem.transient(s, initial=init, times=[1.0, 5.0], rtol=0.1, progress=False)
    ref = fem.transient(s, initial=init, times=[1.0, 5.0], degree=4, nx=32, tol=1e-7,
                        progress=False)
    for a, b in zip(sols, ref):
        est = a.error_estimate()
        assert max(est[k] for k in AIMED if k in est) <= 0.1 and a.info["rtol"] == 0.1
        assert a.info["rtol_decided_by"] in AIMED
        _effective(difference(a, b), est, floor=1e-4)


def test_transient_rtol_refuses_mesh_options_naming_them():
    init = {"mean": (0.0, 0.5), "std": (0.1, 0.1)}
    for kw, name in (({"nx": 16}, "nx"), ({"degree": 2}, "degree"), ({"dt": 0.1}, "dt")):
        with pytest.raises(InputError) as exc:
            fem.transient(PAPER, initial=init, times=[1.0], rtol=1e-2, **kw)
        assert exc.value.name == name and "\n" not in str(exc.value)
    # without rtol the estimate is made on demand (fem.transient_estimate), not refused
    sol = fem.transient(PAPER, initial=init, times=[0.5], nx=8, progress=False)[0]
    est = sol.error_estimate()
    assert set(KEYS) <= set(est) and "in time" in est["assumes"]
    assert "degree 3" in est["richer"] and "error_estimate" in sol.info


def test_a_richer_level_beyond_the_budget_is_refused_in_one_line(monkeypatch):
    """The estimate's richer solve (2-4x the DOFs) is checked against the budget
    first: one line naming it, not an out-of-memory crash."""
    import fpk_vibro.budget as budget
    sol = fem.stationary(PAPER, nx=16)
    monkeypatch.setattr(budget, "available_memory", lambda: 1e6)
    with pytest.raises(InputError) as exc:
        sol.error_estimate()
    assert "fem.error_estimate" in str(exc.value) and "\n" not in str(exc.value)
