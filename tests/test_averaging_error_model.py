"""Averaging's indicator error model (issue 25): ``error_estimate(by="indicators")``
against a resolved FE reference on held-out systems (a hypothesis draw, not the
calibration's seeded one), its small-parameter limit, and that it solves no FE."""
from __future__ import annotations

import math
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fpk_vibro import VibroImpactSystem, averaging
from fpk_vibro.averaging.calibrate import reference
from fpk_vibro.keys import JUDGED, moment_scale
from fpk_vibro.model import Wall


@st.composite
def held_out_systems(draw):
    """Single wells as in the calibration, drawn differently (continuous hypothesis
    floats): hardening, linear, softening; symmetric, one-sided, asymmetric walls."""
    c = draw(st.floats(0.01, 0.4))
    D2 = draw(st.floats(0.0, 0.7)) * c
    r = draw(st.floats(0.2, 1.0))
    sx = draw(st.floats(0.05, 0.8))
    u = draw(st.floats(0.3, 3.0))
    b = draw(st.sampled_from([0.5, 0.0, -0.3]))
    kind = draw(st.sampled_from(["symmetric", "one-sided", "asymmetric"]))
    x_w = min(u * sx, 1.4)                  # inside the softening well (max at 1.83)
    base = dict(a=1.0, b=b, c=c, D1=c * sx * sx, D2=D2)
    if kind == "symmetric" or b < 0:
        return VibroImpactSystem(**base, delta=x_w, r=r)
    if kind == "one-sided":
        return VibroImpactSystem(**base, delta=x_w, r=r, barriers="right")
    return VibroImpactSystem(**base, left=Wall(-x_w, r), right=Wall(0.6 * x_w, min(1.0, r + 0.3)))


def test_indicator_estimate_within_3x_on_held_out_systems():
    """Claimed (error_model docstring, docs/measurements.md): where the true error
    exceeds 0.2 %, within 3× for E[H], E[y²], P_impact on ≥ 90 % of the moments and
    for E[x²] on ≥ 60 % (its sign changes with the geometry: the signed model is
    within 3× on 91 % of the calibration's held-out draw but on 6 of these 8, under
    by ~4× on two), never off by more than 20×; where it is below 0.2 %, the
    estimate is below 1 %."""
    seen: list[tuple[str, float, float, VibroImpactSystem]] = []

    @settings(max_examples=8, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(held_out_systems())
    def draw_and_measure(s):
        sol = averaging.stationary(s)
        est = sol.error_estimate(by="indicators")
        m, ref = sol.moments(), reference(s).moments()
        for k in JUDGED:
            if k in m:
                seen.append((k, abs(m[k] - ref[k]) / moment_scale(k, ref[k]), est[k], s))

    draw_and_measure()
    big = [(k, t, e) for k, t, e, _ in seen if t > 2e-3]
    small = [(k, t, e) for k, t, e, _ in seen if t <= 2e-3]
    assert all(e < 1e-2 for _, _, e in small), small
    main = [t / 3 <= e <= 3 * t for k, t, e in big if k != "E_x2"]
    x2 = [t / 3 <= e <= 3 * t for k, t, e in big if k == "E_x2"]
    assert sum(main) >= 0.9 * len(main), big
    assert sum(x2) >= 0.6 * len(x2), big
    assert all(t / 20 <= e <= 20 * t for _, t, e in big), big
    assert len(big) >= 8                     # the draw has impacts that matter


def test_small_parameter_limit_goes_to_zero():
    """r = 1: Gibbs-like; as c → 0 (noise scaled with c, D2 = 0.4 c) the estimate
    falls like c and vanishes for D2 = 0."""
    ests = []
    for c in (0.1, 0.01, 0.001):
        s = VibroImpactSystem.paper(r=1.0, c=c, D1=0.4 * c, D2=0.4 * c)
        ests.append(max(averaging.stationary(s).error_estimate(by="indicators")[k]
                        for k in JUDGED))
    assert ests[0] > ests[1] > ests[2] and ests[2] < 1e-4, ests
    assert ests[1] / ests[2] == pytest.approx(10, rel=0.2)
    gibbs = averaging.stationary(VibroImpactSystem.paper(r=1.0, D2=0.0))
    assert all(v == 0.0 for k, v in gibbs.error_estimate(by="indicators").items()
               if k in JUDGED)


def test_by_is_checked_in_one_line():
    sol = averaging.stationary(VibroImpactSystem.paper())
    with pytest.raises(ValueError) as exc:
        sol.error_estimate(by="fe")
    msg = str(exc.value)
    assert "\n" not in msg and "by" in msg and '"fem"' in msg and '"indicators"' in msg


def test_indicators_solve_no_fe(monkeypatch):
    """by="indicators" (and validity(), which quotes it) never call the FE reference
    nor import fpk_vibro.fem."""
    import fpk_vibro.references

    def refuse(*a, **k):
        raise AssertionError("an FE reference was solved")
    monkeypatch.setattr(fpk_vibro.references, "reference", refuse)
    sol = averaging.stationary(VibroImpactSystem.paper(r=0.7))
    est = sol.error_estimate(by="indicators")
    assert est["seconds"] < 0.5 and "indicator" in est["reference"] and "L1" not in est
    v = sol.validity()
    worst = max(est[k] for k in JUDGED)
    assert v["estimated_error"] == worst and v["estimated_key"] in JUDGED
    assert f"~{100 * worst:.2g} %" in v["verdict"]
    code = ("import sys\nfrom fpk_vibro import VibroImpactSystem, averaging\n"
            "sol = averaging.stationary(VibroImpactSystem.paper(r=0.7))\n"
            "sol.error_estimate(by='indicators'); sol.validity()\n"
            "assert 'fpk_vibro.fem' not in sys.modules, 'fem imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True)
    assert math.isfinite(worst)


def test_verdict_follows_the_estimate_and_names_the_larger_term():
    """Averaging is exact at r = 1, D2 = 0 whatever the damping; strong impacts are
    named as impacts, damping only together with parametric noise."""
    from fpk_vibro import VibroImpactSystem, averaging
    gibbs = averaging.stationary(VibroImpactSystem.paper(r=1.0, D2=0.0, c=0.3)).validity()
    assert gibbs["estimated_error"] == 0.0 and gibbs["verdict"].startswith("averaging applies")
    hard = averaging.stationary(VibroImpactSystem.paper(r=0.5)).validity()
    assert hard["estimated_error"] > 0.05 and hard["verdict"].startswith("averaging is off")
    assert hard["weakest"].startswith("impacts take") and hard["weakest"] in hard["verdict"]
    para = averaging.stationary(VibroImpactSystem.paper(r=1.0, c=0.2, D2=0.1)).validity()
    assert para["weakest"].startswith("damping with parametric noise")


@pytest.mark.parametrize("system", [
    VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.0036, delta=0.066, r=0.66),
    VibroImpactSystem(a=1.0, b=-0.5, c=0.05, D1=0.02, delta=0.8, r=0.46),
    VibroImpactSystem(a=1.0, b=0.2, c=0.23, D1=0.05, D2=0.15, delta=0.6, r=0.9),
], ids=["walls close in, r 0.66", "softening, r 0.46", "c 0.23, D2 0.65 c"])
def test_the_kinds_of_system_where_averaging_was_silently_off(system):
    """The kinds behind the report of averaging 25–51 % off without a hint (measured
    true errors of E[y²] 42 %, 23 %, 2.3 % here): the FE check within 1.2× and the
    indicator model within 3× of the true error on every key above 0.2 %, and the
    verdict says averaging is off."""
    from fpk_vibro import fem
    sol = averaging.stationary(system)
    ref = fem.stationary(system, degree=4, nx=48, wall_grading=2.0, positivity=False).moments()
    by_fem, by_ind = sol.error_estimate(), sol.error_estimate(by="indicators")
    m = sol.moments()
    for k in ("E_H", "E_x2", "E_y2", "P_impact"):
        true = abs(m[k] - ref[k]) / max(abs(ref[k]), 1e-3 if k == "P_impact" else 0.0)
        if true > 2e-3:
            assert true / 1.2 <= by_fem[k] <= 1.2 * true + 1e-4, (k, true, by_fem[k])
            assert true / 3 <= by_ind[k] <= 3 * true, (k, true, by_ind[k])
    assert sol.validity()["verdict"].startswith("averaging is off")
