"""First passage under hostile inputs (issue 22, section 5 and the pickling and
mean_time items of section 8): every case failed before the fix."""
from __future__ import annotations

import math
import pickle
import time

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, Wall, averaging, fem
from fpk_vibro import montecarlo as mc
from fpk_vibro._checks import InputError

PAPER = VibroImpactSystem.paper(r=0.92)
#: A double well between walls; H_c = -0.1 is below the hump G(0) = 0: two wells.
WELLS = VibroImpactSystem(a=-1.0, b=1.0, c=0.1, D1=0.05, D2=0.0,
                          left=Wall(-1.5, 0.9), right=Wall(1.5, 0.9))
#: A softening spring between walls at ±1.2 (G = 0.4608 there, hump 0.5 beyond).
SOFT = VibroImpactSystem(a=1.0, b=-0.5, c=0.1, D1=0.05, D2=0.0,
                         left=Wall(-1.2, 0.9), right=Wall(1.2, 0.9))


def one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


# -- a mean time is positive and finite, or the call says why not ------------------

@pytest.mark.parametrize("energy", [100.0, 1e6])
def test_unresolvable_mean_time_is_refused_with_its_magnitude(energy):
    """energy = 100 gave τ = −2.7e15 (1e6: −2e12): rounding, not a mean time.  The
    averaged τ there is ~10^796 (10^8e6): beyond any double-precision solve."""
    with pytest.raises(InputError) as exc:
        fem.first_passage(PAPER, energy=energy)
    text = one_line(exc)
    assert exc.value.name == "energy" and "10^" in text and "resolve" in text
    with pytest.raises(InputError) as exc:
        averaging.first_passage(PAPER, energy=energy)
    assert exc.value.name == "energy" and "10^" in one_line(exc)


def test_large_but_resolvable_mean_time_is_positive_and_finite():
    """H_c = 2.5: τ ≈ 1.6e10 (averaging 7.7e9); the rounding estimate ~1e-4."""
    fp = fem.first_passage(PAPER, energy=2.5)
    assert 1e9 < fp.mean < 1e12 and fp.info["rounding_error"] < 1e-3
    assert fp.reliability(fp.mean) == pytest.approx(math.exp(-1.0), rel=1e-3)
    av = averaging.first_passage(PAPER, energy=2.5)
    assert 1e9 < av.mean < 1e11
    assert av.reliability(av.mean) == pytest.approx(math.exp(-1.0), rel=1e-2)
    with pytest.raises(InputError, match="energy"):
        fem.first_passage(PAPER, energy=5.0)      # gave 1.7e16 (averaging: 9e26)


# -- the budget -----------------------------------------------------------------

def test_mesh_beyond_the_machine_is_refused_before_any_work():
    """nx = 4096 took all 24 GB and was killed; now the stationary cost model refuses."""
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        fem.first_passage(PAPER, energy=0.5, nx=4096)
    assert exc.value.name == "nx" and "nx needs an estimated" in one_line(exc)
    assert time.perf_counter() - t0 < 10.0


# -- each part of the safe set ----------------------------------------------------

def test_double_well_below_its_hump_solves_the_start_well():
    """Two separate wells: skfem raised "Zero Jacobian determinant"."""
    right = fem.first_passage(WELLS, energy=-0.1, start=(1.0, 0.0))
    left = fem.first_passage(WELLS, energy=-0.1, start=(-1.0, 0.0))
    assert right.info["parts"] == 1 and 0 < right.mean < math.inf
    assert left.mean == pytest.approx(right.mean, rel=1e-9)
    assert right.mean_time(1.1, 0.1) > 0 and right.mean_time(0.0, 0.0) == 0.0  # outside
    with pytest.raises(ValueError, match="another one"):
        right.mean_time(-1.0, 0.0)
    m = mc.first_passage(WELLS, energy=-0.1, start=(1.0, 0.0), n_paths=4096, seed=5,
                         progress=False)
    assert abs(m.mean - right.mean) < 3 * m.mean_se + 0.02 * right.mean
    both = fem.first_passage(WELLS, energy=-0.1, start="stationary")
    assert both.info["parts"] == 2 and 0 < both.mean < right.mean


def test_softening_spring_below_its_wall_energies():
    """H_c = 0.3 < G(wall) = 0.46: the error was about walls the system has."""
    f = fem.first_passage(SOFT, energy=0.3)
    a = averaging.first_passage(SOFT, energy=0.3)
    assert f.mean == pytest.approx(a.mean, rel=0.03)


# -- times -------------------------------------------------------------------------

ENGINES = {
    "fem": lambda **kw: fem.first_passage(PAPER, energy=0.5, **kw),
    "averaging": lambda **kw: averaging.first_passage(PAPER, energy=0.5, **kw),
    "montecarlo": lambda **kw: mc.first_passage(PAPER, energy=0.5, n_paths=4096, seed=1,
                                               progress=False, **kw),
}
BAD_TIMES = [[5.0, -1.0], [float("nan")], [float("inf")], "abc", [], [True, 2.0],
             ["1"], {"t": 1.0}, 3.0, np.array([[1.0, 2.0]]), [10 ** 400]]


@pytest.mark.parametrize("engine", sorted(ENGINES))
@pytest.mark.parametrize("times", BAD_TIMES, ids=range(len(BAD_TIMES)))
def test_bad_times_are_refused_in_one_line(engine, times):
    with pytest.raises(InputError) as exc:
        ENGINES[engine](times=times)
    assert exc.value.name == "times" and "finite numbers >= 0" in one_line(exc)


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_a_huge_requested_time_leaves_the_grid_alone(engine):
    """times=[1e12] made the grid 0..1e12 in 200-800 steps: R(100) = 1.0, not 0.28."""
    plain = ENGINES[engine]()
    far = ENGINES[engine](times=[1e12])
    assert 0.2 < plain.reliability(100.0) < 0.35
    assert far.reliability(100.0) == pytest.approx(plain.reliability(100.0), abs=1e-3)
    assert far.reliability(1e12) < 1e-6
    assert far.times[-1] == 1e12 and np.all(np.diff(far.times) > 0)
    assert plain.times[-1] < 1e5          # the solver's own grid
    mixed = ENGINES[engine](times=[1e12, 100.0, 50.0, 100.0])     # any order, repeats
    for t in (50.0, 100.0):
        assert t in mixed.times
        assert mixed.reliability(t) == pytest.approx(plain.reliability(t), abs=1e-3)


# -- FirstPassage itself -------------------------------------------------------------

@pytest.mark.parametrize("engine", ["fem", "averaging"])
def test_first_passage_pickles(engine):
    fp = ENGINES[engine]()
    back = pickle.loads(pickle.dumps(fp))
    assert back.mean_time(0.2, 0.1) == pytest.approx(fp.mean_time(0.2, 0.1), rel=1e-12)


@pytest.mark.parametrize("x0, y0, name", [
    (float("nan"), 0.0, "x0"), (0.0, float("nan"), "y0"), (None, 0.0, "x0"),
    (0.0, None, "y0"), (float("inf"), 0.0, "x0"), ("a", 0.0, "x0"),
    (np.array([0.0, np.nan]), 0.0, "x0")])
def test_mean_time_refuses_missing_or_non_finite_points(x0, y0, name):
    """mean_time(nan, 0) and mean_time(None, 0) gave 0.0."""
    fp = ENGINES["fem"]()
    with pytest.raises(InputError) as exc:
        fp.mean_time(x0, y0)
    assert exc.value.name == name and one_line(exc).startswith("fem.first_passage: " + name)
