"""Scenes of impact physics (issue 32): restitution laws and sweeps of their
parameters, the safe sets of [first_passage], the quantities inter_impact and
impact_energy in results.json, densities.npz, netCDF and figures."""
import copy
import json
import tomllib

import numpy as np
import pytest

from fpk_vibro import Restitution, VibroImpactSystem
from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import SceneError, check_scene, parse_scene
from fpk_vibro.registry import methods, register, replace

TANH = {"law": "tanh", "r0": 0.9, "r1": 0.2, "u0": 1.0}
SCENE = tomllib.loads("""
[system]
a = 1.0
b = 0.2
c = 0.025
D1 = 0.01
D2 = 0.01

[barriers.left]
position = -0.6
r = {law = "tanh", r0 = 0.9, r1 = 0.2, u0 = 1.0}

[barriers.right]
position = 0.6
r = {law = "tanh", r0 = 0.9, r1 = 0.2, u0 = 1.0}

[study]
methods = ["averaging"]
quantities = ["energy", "moments", "inter_impact", "impact_energy", "first_passage"]

[first_passage]
displacement = 0.5

[output]
formats = ["json", "npz", "png", "nc"]
""")


def scene(**tables):
    d = copy.deepcopy(SCENE)
    for k, v in tables.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


def test_a_tanh_law_on_both_walls_runs_and_writes_every_impact_quantity(tmp_path):
    sc = parse_scene(scene())
    law = Restitution.tanh(0.9, 0.2, 1.0)
    assert sc.system.left.r == law and sc.system.right.r == law
    doc = run_scene(sc, out=tmp_path, workers=1, log=lambda s: None)
    point = doc["points"][0]
    assert point["status"] == "done", point.get("error")
    # results.json round-trips the law (the system stored as its scene tables)
    saved = json.loads((tmp_path / "results.json").read_text())["points"][0]["system"]
    assert saved["left"]["r"] == TANH and saved["right"]["r"] == TANH
    assert VibroImpactSystem.from_dict(saved) == sc.system
    e = point["methods"]["averaging"]
    gaps = e["inter_impact"]
    # averaging builds its mean from its rates: the identity mean = 1/ν to round-off
    assert gaps["mean"] == pytest.approx(gaps["one_over_rate"], rel=1e-12)
    assert gaps["identity"] < 1e-12
    assert "not_computed" in gaps["error_estimate"]        # no FE in the scene: said so
    for side in ("left", "right"):
        rec = e["impact_energy"][side]
        # mean of the density (a quadrature of the speed density) = energy_rate / rate
        assert rec["mean"] == pytest.approx(rec["from_rates"], rel=1e-4)
    fp = e["first_passage"]
    assert fp["safe_set"] == {"kind": "displacement", "value": [-0.5, 0.5]}
    assert fp["mean"] > 0 and fp["survival"][0] == pytest.approx(1.0)
    for name in ("p0_inter_impact.png", "p0_impact_energy.png", "p0_reliability.png"):
        assert name in point["figures"] and (tmp_path / name).stat().st_size > 5_000
    with np.load(tmp_path / "densities.npz") as npz:
        t, f = npz["p0.averaging.inter_impact.grid"], npz["p0.averaging.inter_impact.pdf"]
        g, p = (npz["p0.averaging.impact_energy_left.grid"],
                npz["p0.averaging.impact_energy_left.pdf"])
    assert np.all(f >= 0) and np.all(p >= 0)
    # the densities are the ones of the means: mass and mean on the grids (the grids end
    # at 6 mean gaps and 8 mean energies; the tails beyond hold < 3 % and < 0.1 %)
    mass_t = np.trapezoid(f, t)
    assert 0.95 < mass_t <= 1.0 + 1e-3
    assert np.trapezoid(p, g) == pytest.approx(1.0, abs=2e-3)
    assert np.trapezoid(g * p, g) == pytest.approx(e["impact_energy"]["left"]["mean"], rel=0.02)
    import xarray as xr
    with xr.open_dataset(tmp_path / "results.nc", engine="h5netcdf") as ds:
        assert list(ds["method"].values) == ["averaging"]
        assert list(ds["wall"].values) == ["left", "right"]
        assert ds["inter_impact_mean"].values[0, 0] == gaps["mean"]
        assert ds["impact_energy_mean"].values[0, 0, 0] == e["impact_energy"]["left"]["mean"]
        assert ds["pdf_inter_impact"].shape == (1, 1, t.size)
        assert ds["first_passage_mean"].values[0, 0] == fp["mean"]
        assert np.array_equal(ds["reliability"].values[0, 0], fp["survival"])
        assert json.loads(ds.attrs["safe_set"])["kind"] == "displacement"


def test_only_what_the_scene_asks_for_is_computed(tmp_path):
    sc = parse_scene(scene(study={"methods": ["averaging"], "quantities": ["moments"]},
                           first_passage=None, output={"formats": ["json"]}))
    e = run_scene(sc, out=tmp_path, workers=1, log=lambda s: None)["points"][0]["methods"]
    assert not {"inter_impact", "impact_energy", "first_passage"} & set(e["averaging"])


def test_a_law_sweep_builds_each_point_with_its_parameter():
    d = scene(barriers={"delta": 0.6, "r": dict(TANH)}, first_passage=None)
    d["study"]["quantities"] = ["moments"]
    d["sweep"] = {"r": {"r1": [0.1, 0.2, 0.3]}}                    # TOML: r.r1 = [...]
    points = parse_scene(d).points()
    assert [p for p, _ in points] == [{"r.r1": v} for v in (0.1, 0.2, 0.3)]
    for (params, s), v in zip(points, (0.1, 0.2, 0.3)):
        assert s.left.r == s.right.r == Restitution.tanh(0.9, v, 1.0)
    assert len({s for _, s in points}) == 3
    # two parameters of one law make one law per point; a wall's law by its own key
    d["sweep"] = {"r.r0": [0.9, 0.95], "r.u0": [0.5, 2.0]}
    laws = {s.left.r for _, s in parse_scene(d).points()}
    assert laws == {Restitution.tanh(r0, 0.2, u0) for r0 in (0.9, 0.95) for u0 in (0.5, 2.0)}
    d = scene(first_passage=None)
    d["study"]["quantities"] = ["moments"]
    d["sweep"] = {"left.r.u0": [0.5, 2.0]}
    pts = parse_scene(d).points()
    assert [s.left.r.u0 for _, s in pts] == [0.5, 2.0]
    assert all(s.right.r == Restitution.tanh(0.9, 0.2, 1.0) for _, s in pts)


def _bad(d):
    with pytest.raises(SceneError) as info:
        check_scene(parse_scene(d))
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(info.value.name), msg
    return info.value


@pytest.mark.parametrize("where, law, key, says", [
    ("barriers", {"speeds": [0.0, 1.0], "values": [0.9, 0.2]}, "barriers.r",
     "u·r(u) must increase strictly"),
    ("barriers", {"law": "tanh", "r0": 0.9, "r1": 0.95, "u0": 1.0}, "barriers.r",
     "barriers.r.r1: r0 − r1"),
    ("barriers", {"law": "tanh", "r0": 0.9, "r1": 0.2, "u0": -1.0}, "barriers.r",
     "barriers.r.u0 must be a finite number > 0"),
    ("barriers", {"law": "exp"}, "barriers.r", "barriers.r.law must be one of"),
    ("left", {"speeds": [0.0, 1.0], "values": [0.9, 1.2]}, "barriers.left.r",
     "barriers.left.r.values must be restitutions in [0, 1]"),
])
def test_a_bad_law_is_one_line_naming_its_key(where, law, key, says):
    if where == "barriers":
        d = scene(barriers={"delta": 0.6, "r": law})
    else:
        d = scene()
        d["barriers"]["left"]["r"] = law
    err = _bad(d)
    assert err.name == key and says in str(err)


@pytest.mark.parametrize("sweep, key, says", [
    ({"r.r1": [0.1, 0.95]}, "sweep.r.r1", "r0 − r1 (r at high speed) must lie in [0, 1]; "
     "got -0.05 (at r.r1 = 0.95)"),
    ({"r.r1": [1.5]}, "sweep.r.r1", "must be a finite number in [-1, 1]"),
    ({"r.u0": [1.0], "r": [0.5]}, "sweep.r.u0", "must not be swept with sweep.r"),
])
def test_a_swept_law_parameter_that_breaks_the_law_is_refused(sweep, key, says):
    d = scene(barriers={"delta": 0.6, "r": dict(TANH)})
    d["sweep"] = sweep
    err = _bad(d)
    assert err.name == key and says in str(err)


def test_a_swept_parameter_of_a_law_the_scene_does_not_have():
    d = scene()
    d["barriers"]["right"]["r"] = 0.8
    d["sweep"] = {"right.r.u0": [0.5]}
    err = _bad(d)
    assert err.name == "sweep.right.r.u0" and "which is the number 0.8" in str(err)


@pytest.mark.parametrize("fp, key, says", [
    ({"displacement": 0.3, "energy": 0.2}, "first_passage.displacement",
     "exactly one safe set"),
    ({}, "first_passage.energy", "exactly one safe set"),
    ({"displacement": -0.3}, "first_passage.displacement", "must be a finite number > 0"),
    ({"displacement": [0.3, 0.1]}, "first_passage.displacement", "x_lo = 0.3 >= x_hi = 0.1"),
    ({"displacement": [0.7, 0.9]}, "first_passage.displacement", "does not meet the strip"),
    ({"impact_speed": 0}, "first_passage.impact_speed", "must be a finite number > 0"),
    ({"displacement": 0.3, "start": [0.4, 0.0]}, "first_passage.start",
     "inside the safe set -0.3 < x < 0.3"),
])
def test_a_bad_safe_set_is_one_line_naming_its_key(fp, key, says):
    err = _bad(scene(first_passage=fp))
    assert err.name == key and says in str(err)


def test_impact_quantities_need_a_wall_and_a_stationary_scene():
    d = scene(barriers={"sides": "none"}, first_passage=None)
    d["study"]["quantities"] = ["inter_impact"]
    assert "need a wall" in str(_bad(d))
    d = scene(first_passage=None, initial={"mean": [0.0, 0.5], "std": [0.1, 0.1]})
    d["study"].update(quantities=["impact_energy"], times=[1.0])
    assert "stationary only" in str(_bad(d))


@pytest.fixture
def averaging_energy_only():
    """averaging registered as if it left energy sets only (restored after)."""
    original = methods()["averaging"]
    register(replace(original, safe_sets=("energy",)))
    yield
    register(original)


def test_a_method_that_cannot_leave_the_safe_set_is_refused_naming_those_that_can(
        averaging_energy_only):
    err = _bad(scene(first_passage={"impact_speed": 0.3}))
    assert err.name == "first_passage.impact_speed"
    assert "averaging.first_passage: does not compute first passage out of a safe set " \
           "given by impact_speed" in str(err)
    others = [m for m in methods() if "impact_speed" in methods()[m].safe_sets]
    assert others and str(err).endswith(f"; {', '.join(others)} do")
    check_scene(parse_scene(scene(first_passage={"energy": 0.3})))    # energy: accepted
