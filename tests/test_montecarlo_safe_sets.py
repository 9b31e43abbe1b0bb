"""Monte Carlo first passage out of a displacement or impact-speed safe set: against an
independent fine Euler simulation, the first impact against reaching the wall, the
error estimate's bias run, and one-line refusals of bad thresholds."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, Wall
from fpk_vibro._checks import InputError
from fpk_vibro import montecarlo as mc

LIN = VibroImpactSystem(a=1.0, b=0.0, c=0.2, D1=0.05, barriers="none")
ONE = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.02, right=Wall(0.3, r=0.6))


def euler_reference(b, n=8192, dt=1e-3, seed=0):
    """Mean time for |x| to reach b from (0, 0), by plain Euler-Maruyama in numpy (an
    independent code; exits seen at step ends, late by O(sqrt(dt)) in y, O(dt) in x)."""
    rng = np.random.default_rng(seed)
    x, y = np.zeros(n), np.zeros(n)
    T = np.full(n, np.nan)
    alive = np.arange(n)
    t = 0.0
    s = LIN
    while alive.size:
        t += dt
        xa, ya = x[alive], y[alive]
        xa, ya = xa + dt * ya, ya - dt * (s.c * ya + s.a * xa) + \
            math.sqrt(2 * s.D1 * dt) * rng.standard_normal(alive.size)
        x[alive], y[alive] = xa, ya
        out = np.abs(xa) >= b
        T[alive[out]] = t
        alive = alive[~out]
    return T.mean(), T.std(ddof=1) / math.sqrt(n)


def test_displacement_first_passage_against_an_independent_simulation():
    fp = mc.first_passage(LIN, displacement=0.5, n_paths=8192, seed=4, progress=False)
    ref, ref_se = euler_reference(0.5)
    assert fp.safe_set.kind == "displacement" and fp.energy is None
    assert abs(fp.mean - ref) <= 3 * math.hypot(fp.mean_se, ref_se) + 0.005 * ref, \
        (fp.mean, fp.mean_se, ref, ref_se)
    # and against its own step at a quarter: the crossing is located on the path
    fine = mc.first_passage(LIN, displacement=0.5, n_paths=8192, seed=5, progress=False,
                            dt=fp.info["dt"] / 4)
    assert abs(fp.mean - fine.mean) <= 3 * math.hypot(fp.mean_se, fine.mean_se)
    est = fp.error_estimate()
    assert est["step"] == "2 dt" and math.isfinite(est["bias"]) and est["mean_time"] > 0


def test_the_first_impact_is_reaching_the_wall():
    """impact_speed = tiny exits at the first impact; a displacement bound just short of
    the wall at the first arrival there: the same paths (same seed), the same step."""
    kw = dict(n_paths=2048, seed=9, progress=False)
    first = mc.first_passage(ONE, impact_speed=1e-9, **kw)
    reach = mc.first_passage(ONE, displacement=(-50.0, 0.3 - 1e-9), **kw)
    assert first.safe_set.kind == "impact_speed"
    assert abs(first.mean - reach.mean) <= first.info["dt"], (first.mean, reach.mean)
    # a higher threshold is left later
    later = mc.first_passage(ONE, impact_speed=0.3, **kw)
    assert later.mean > first.mean + 3 * later.mean_se
    assert later.error_estimate()["mean_time"] > 0


@pytest.mark.parametrize("safe, words", [
    ({"impact_speed": -1.0}, "impact_speed"),
    ({"impact_speed": math.inf}, "impact_speed"),
    ({"displacement": (0.5, 0.2)}, "displacement"),
    ({"displacement": 5.0}, "beyond the walls"),
    ({}, "exactly one"),
    ({"energy": 0.3, "displacement": 0.2}, "exactly one"),
])
def test_bad_thresholds_are_refused_in_one_line(safe, words):
    system = VibroImpactSystem.paper(r=0.8)
    with pytest.raises(InputError, match=words) as err:
        mc.first_passage(system, n_paths=64, seed=1, progress=False, **safe)
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="impact_speed"):
        mc.first_passage(LIN, impact_speed=0.5, n_paths=64, progress=False)
    with pytest.raises(InputError, match="start"):
        mc.first_passage(system, displacement=0.2, start=(0.3, 0.0), n_paths=64,
                         progress=False)
