"""The on-demand estimate of an FE transient solved without rtol
(fpk_vibro.fem.transient_estimate, issue 25): one richer transient, richer in space
and time, shared by every output time.

Effectivity = true error / estimate of Q2 on nx = 24 with the default BDF2 steps
(tol 3e-4), the true error against Q4 on nx = 32 with tol 1e-6.  Measured on the
three systems below at times 0.5 and 2: 0.21-1.24 over 30 figures,
the largest P_impact of the r = 0.3 wall at t = 2 (1.42 against Q4, nx = 40,
tol 1e-8: the degree + 1 on the same mesh and the coarse run's own space and time
errors partly cancel).  Asserted: effectivity <= 1.5 and >= 1/10 where the true
error is above FLOOR (the reference's own error is ~1e-8-1e-5)."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from fpk_vibro import fem
from fpk_vibro._checks import InputError
from fpk_vibro.fem.estimate import KEYS, difference
from fpk_vibro.model import VibroImpactSystem

FLOOR = 1e-6
PACKET = {"mean": (0.0, 0.5), "std": (0.1, 0.1)}
SYSTEMS = {
    "paper": (VibroImpactSystem.paper(), PACKET),
    "wall r=0.3": (VibroImpactSystem.paper(r=0.3), PACKET),
    "double well, parametric noise": (
        VibroImpactSystem(a=-1, b=1, c=0.1, D1=0.05, D2=0.05, delta=2.0, r=0.9),
        {"mean": (1.0, 0.0), "std": (0.2, 0.2)}),
}
TIMES = [0.5, 2.0]


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.long) if n == "paper" else n
                                  for n in sorted(SYSTEMS)])
def test_effectivity_against_a_much_finer_transient(name):
    s, init = SYSTEMS[name]
    sols = fem.transient(s, initial=init, times=TIMES, nx=24, progress=False)
    ref = fem.transient(s, initial=init, times=TIMES, degree=4, nx=32, tol=1e-6,
                        progress=False)
    for a, b in zip(sols, ref):
        est = a.error_estimate()
        assert set(KEYS) <= set(est) and "in time" in est["assumes"]
        assert "degree 3" in est["richer"] and est["seconds"] > 0
        true = difference(a, b)
        for k in KEYS:
            assert true[k] <= 1.5 * est[k] or true[k] < FLOOR, (name, a.time, k, true[k],
                                                                 est[k])
            assert true[k] >= est[k] / 10 or true[k] < FLOOR, (name, a.time, k, true[k],
                                                               est[k])
        worst = max(est[k] for k in ("E_H", "E_x2", "E_y2", "P_impact"))
        assert a.info["error_estimate"] == worst
        if worst > 1e-3:     # RESOLUTION_TOL, no rtol given: flagged, saying why
            assert a.info["under_resolved"] is True
            assert "error estimate" in a.info["under_resolved_reason"]


def _counting(monkeypatch) -> list:
    """Count the transients run through fem.transient.transient (the richer run is)."""
    tr = importlib.import_module("fpk_vibro.fem.transient")   # (fem.transient: the function)
    calls: list = []
    original = tr.transient

    def counted(*args, **kw):
        calls.append(kw)
        return original(*args, **kw)

    monkeypatch.setattr(tr, "transient", counted)
    return calls


def test_one_richer_run_serves_the_whole_list(monkeypatch):
    calls = _counting(monkeypatch)
    sols = fem.transient(VibroImpactSystem.paper(), initial=PACKET, times=[0.25, 0.5, 1.0],
                         nx=8, dt=0.05, progress=False)
    assert calls == []
    first = sols[1].error_estimate()
    assert len(calls) == 1
    # fixed BDF2 steps: each split in 2 by outputs at the interval midpoints
    assert calls[0]["dt"] == 0.025 and calls[0]["degree"] == 3 and calls[0]["tol"] is None
    np.testing.assert_allclose(calls[0]["times"], [0.125, 0.25, 0.375, 0.5, 0.75, 1.0])
    ests = [s.error_estimate() for s in sols] + [sols[1].error_estimate()]
    assert len(calls) == 1 and ests[1] == first
    assert len({e["seconds"] for e in ests}) == 1 and "split in 2" in first["assumes"]
    assert all(np.isfinite(e["L1"]) and e["L1"] > 0 for e in ests)
    assert all("error_estimate" in s.info for s in sols)


def test_a_richer_run_beyond_the_budget_is_refused_in_one_line(monkeypatch):
    import fpk_vibro.budget as budget
    calls = _counting(monkeypatch)
    sols = fem.transient(VibroImpactSystem.paper(), initial=PACKET, times=[0.5], nx=8,
                         progress=False)
    monkeypatch.setattr(budget, "available_memory", lambda: 1e6)
    with pytest.raises(InputError) as exc:
        sols[0].error_estimate()
    assert "fem.error_estimate" in str(exc.value) and "\n" not in str(exc.value)
    assert calls == [] and sols[0]._estimate is None


def test_a_callable_initial_is_rerun_as_given(monkeypatch):
    """The richer run calls p0 at its own nodes; p0 the Gaussian of a dict spec wider
    than the node spacing (0.11 at nx = 8: no widening) gives the dict's estimate to
    round-off."""
    s = VibroImpactSystem.paper()
    sizes: list = []

    def p0(x, y):
        sizes.append(x.size)
        return np.exp(-0.5 * (x / 0.15) ** 2 - 0.5 * ((y - 0.5) / 0.15) ** 2)

    kw = dict(times=[0.5, 1.0], nx=8, dt=0.05, scheme="theta", theta=1.0, progress=False)
    by_callable = fem.transient(s, initial=p0, **kw)
    by_dict = fem.transient(s, initial={"mean": (0.0, 0.5), "std": (0.15, 0.15)}, **kw)
    est = by_callable[-1].error_estimate()
    assert len(sizes) == 2 and sizes[1] > sizes[0]      # the richer nodes (degree 3)
    assert "split in 4" in est["assumes"]               # implicit Euler: first order
    ref = by_dict[-1].error_estimate()
    for k in KEYS:
        assert est[k] == pytest.approx(ref[k], rel=1e-8, abs=1e-14), k


def test_a_density_read_from_a_file_says_it_has_no_estimate(tmp_path):
    sol = fem.transient(VibroImpactSystem.paper(), initial=PACKET, times=[0.5], nx=8,
                        dt=0.1, progress=False)[0]
    back = fem.FEMSolution.load(sol.save(tmp_path / "t.npz"))
    with pytest.raises(ValueError, match="read from a file") as exc:
        back.error_estimate()
    assert "\n" not in str(exc.value)
