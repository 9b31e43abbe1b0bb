"""Monte Carlo's default time step follows the system's fastest scale (issue 22, §1).

The step used to be T0/120 whatever the system; on fast scales the power balance
closed, the standard errors were tight, and the moments were wrong by up to a
factor 40 (or NaN).  Each row of the issue's table is a test here: the default step
gives the converged answer within 3 SE + 1 %, or the run is refused with one line
naming the scale and the cost.  The runs keep the default dt and shorten only the
burn-in and sampled time (these systems relax within a fraction of it: impacts at
the fast scale remove the energy), so the file runs in seconds.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem
from fpk_vibro import montecarlo as mc
from fpk_vibro._checks import InputError
from fpk_vibro.montecarlo import _setup as S

PAPER92 = VibroImpactSystem.paper(r=0.92)


def _within(sol, key, ref):
    """|estimate − ref| ≤ 3 SE + 1 % of ref (the issue's acceptance)."""
    m, se = sol.moments()[key], sol.moments_se()[key]
    assert np.isfinite(m) and np.isfinite(se)
    assert abs(m - ref) <= 3.0 * se + 0.01 * abs(ref), (key, m, se, ref, sol.dt)


# -- the table ---------------------------------------------------------------------------
def test_strong_additive_noise_paper_system():
    """Paper system, D1 = 10⁶: E[y²] = 4.60·10⁴ (FE); T0/120 gave 3.50·10⁴ ± 0.014·10⁴.
    The crossing time of the strip at the typical speed (~5 ms) sets the step."""
    s = VibroImpactSystem.paper(r=0.92, D1=1e6)
    sol = mc.stationary(s, seed=11, n_paths=512, t_burn=2.0, t_sample=5.0)
    _within(sol, "E_y2", 4.60e4)
    assert S.binding_scale(s)[0] == "crossing time L/v"


def test_strong_parametric_noise_paper_system():
    """Paper system, D2 = 10⁶: E[y²] = 1.12·10⁴ (FE); T0/120 gave 9.7·10³."""
    s = VibroImpactSystem.paper(r=0.92, D2=1e6)
    sol = mc.stationary(s, seed=12, n_paths=512, t_burn=2.0, t_sample=5.0)
    _within(sol, "E_y2", 1.12e4)


def test_chattering_narrow_strip_r0():
    """Δ = 10⁻³, r = 0: E[y²] ≈ 5.56·10⁻⁴ (FE Q2 and MC at dt/512 converge to
    5.50–5.56·10⁻⁴); T0/120 gave 3.9·10⁻⁴ and T0/1920 still 5.3·10⁻⁴."""
    s = VibroImpactSystem.paper(delta=1e-3, r=0.0)
    sol = mc.stationary(s, seed=13, n_paths=512, t_burn=2.0, t_sample=10.0)
    _within(sol, "E_y2", 5.56e-4)


def test_tiny_gap_r092():
    """Δ = 10⁻⁶, r = 0.92: E[y²] = 3.0·10⁻⁵ (FE; averaging 3.3·10⁻⁵); T0/120 gave
    7.2·10⁻⁷.  The energy relaxes in ~2 ms here (impacts), so 0.2 s burns in."""
    s = VibroImpactSystem.paper(delta=1e-6, r=0.92)
    sol = mc.stationary(s, seed=14, n_paths=512, t_burn=0.2, t_sample=2.0)
    _within(sol, "E_y2", 3.0e-5)


def test_tiny_gap_elastic_exact():
    """Δ = 10⁻⁶, r = 1, D2 = 0: x is uniform on the strip, E[x²] = Δ²/3 exactly;
    T0/120 gave Δ² (every path stopped on a wall after max_impacts impacts per step)."""
    d = 1e-6
    s = VibroImpactSystem.paper(delta=d, r=1.0, D2=0.0)
    sol = mc.stationary(s, seed=15, n_paths=64, t_burn=0.0, t_sample=2.0)
    _within(sol, "E_x2", d * d / 3.0)


def test_overdamped_is_refused_with_one_line():
    """c = 10⁶: every moment came out NaN without an error (no sample in the 6/c
    burn-in and 10⁴/c sampling).  The damping time 1/c sets the step and the
    position relaxes over c/a = 10⁶ s: refused, naming the scale and the cost."""
    s = VibroImpactSystem.paper(c=1e6)
    with pytest.raises(InputError) as exc:
        mc.stationary(s, seed=16)
    msg = str(exc.value)
    assert "\n" not in msg and exc.value.name == "dt"
    assert "damping time 1/c" in msg and "path-steps" in msg and "limit" in msg, msg
    with pytest.raises(InputError, match="damping time 1/c"):
        mc.transient(s, initial={"mean": (0.0, 0.0), "std": (0.0, 0.0)}, times=[1e3])


def test_overdamped_given_step_velocity_is_right():
    """c = 10⁶ with a step that resolves 1/c: E[y²] = D1/c = 10⁻⁸ (the velocity
    relaxes in 1 µs), finite, never NaN."""
    s = VibroImpactSystem.paper(c=1e6, D2=0.0)
    sol = mc.stationary(s, dt=1e-7, seed=17, n_paths=256, t_burn=1e-5, t_sample=2e-5,
                        sample_every=1)
    _within(sol, "E_y2", 1e-8)


def test_wall_the_force_pushes_into():
    """A random scene of the suite (tests/test_check_promise.py): a = −1, b = −0.3
    pushes paths onto the walls at ±0.8, where they bounce on the scale 2D/F² =
    0.011.  E[y²] = 1.038·10⁻³ (± 0.3 %, MC at dt = 2.4·10⁻⁴); T0/120 = 0.048
    gave 1.40·10⁻³ (+35 %)."""
    s = VibroImpactSystem(a=-1.0, b=-0.3, c=0.02, D1=0.005, D2=0.0, delta=0.8, r=0.8)
    sol = mc.stationary(s, seed=3, n_paths=256, t_burn=50.0, t_sample=50.0)
    _within(sol, "E_y2", 1.038e-3)
    assert S.binding_scale(s)[0] == "bounce time 2D/F²"


def test_budget_names_t_sample_when_it_is_the_cause():
    """On a fast system a t_sample beyond the budget at any step is still named."""
    s = VibroImpactSystem.paper(r=0.92, D1=1e6)
    with pytest.raises(InputError) as exc:
        mc.stationary(s, t_sample=1e12)
    assert exc.value.name == "t_sample"


# -- a given step that is too coarse is refused, naming the scale ---------------------
@pytest.mark.parametrize("system, scale", [
    (VibroImpactSystem.paper(r=0.92, D1=1e6), "crossing time L/v"),
    (VibroImpactSystem.paper(delta=1e-3, r=0.0), "crossing time L/v"),
    (VibroImpactSystem.paper(r=0.92, D2=1e6), "noise time E/D"),
    (VibroImpactSystem.paper(c=1e6), "damping time 1/c"),
], ids=["D1", "chattering", "D2", "overdamped"])
def test_coarse_given_step_is_refused(system, scale):
    dt = S.dt_limit(system) * 0.99          # stable, so only the new rule can refuse it
    dt = min(dt, 0.05)
    with pytest.raises(InputError) as exc:
        mc.stationary(system, dt=dt, n_paths=64, t_sample=10.0, t_burn=0.0)
    msg = str(exc.value)
    assert "\n" not in msg and exc.value.name == "dt" and scale in msg, msg


def test_no_nan_without_a_named_cause():
    """A run whose paths leave every bound raises, naming the step."""
    from fpk_vibro.montecarlo._engine import _check_finite
    mom = np.ones((2, 12))
    with pytest.raises(FloatingPointError, match="dt = "):
        _check_finite("stationary", mom, np.array([0.0, np.nan]), np.zeros(2), 0.1, 1)
    with pytest.raises(RuntimeError, match="no sample"):
        _check_finite("stationary", np.zeros((2, 12)), np.zeros(2), np.zeros(2), 0.1, 4)


# -- the paper's case keeps its step ------------------------------------------------------
@pytest.mark.parametrize("r", [0.92, 0.98])
def test_paper_default_step_unchanged(r):
    """The period sets the paper case's step: T0/120 and T0/4 sampling as before, so
    seeded results there are unchanged."""
    s = VibroImpactSystem.paper(r=r)
    T0 = 2.0 * math.pi / math.sqrt(1.0 + 0.2 * 0.36)
    assert S.default_dt(s) == pytest.approx(T0 / 120.0, rel=1e-12)
    assert S.default_sample_every(s, S.default_dt(s)) == 30
