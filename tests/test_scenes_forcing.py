"""Scenes with harmonic forcing: the [forcing] table and its sweeps, the periodic
response run per method and phase (results.json, densities.npz, netCDF, figures), and
the one-line refusals of bad forcing values and of what a forced system lacks."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from fpk_vibro import Harmonic, registry
from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import SceneError, check_scene, load_scene, parse_scene, schema_table
from fpk_vibro.forcing import first_harmonic

EXAMPLE = Path(__file__).parent.parent / "examples" / "forced_response.toml"
PERIODIC = ("fem", "montecarlo")


@pytest.fixture
def periodic_declared():
    """fem and Monte Carlo declare the periodic mode and harmonic forcing for the test
    (as the registry does once they are validated); restored afterwards."""
    saved = {name: registry.methods()[name] for name in PERIODIC}
    for name, m in saved.items():
        registry.register(registry.replace(
            m, modes=tuple(dict.fromkeys(m.modes + ("periodic",))),
            features=tuple(dict.fromkeys(m.features + ("harmonic forcing",)))))
    yield
    for m in saved.values():
        registry.register(m)


def _scene(**over):
    data = {"system": dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01),
            "barriers": dict(delta=0.6, r=0.8),
            "forcing": dict(amplitude=0.05, frequency=0.9),
            "study": dict(methods=["montecarlo"], quantities=["moments"]),
            "montecarlo": dict(seed=1)}
    for table, keys in over.items():
        if keys is None:
            data.pop(table, None)
        else:
            data[table] = {**data.get(table, {}), **keys}
    return data


def _refused(data, key):
    with pytest.raises(SceneError) as exc:
        check_scene(parse_scene(data))
    msg = str(exc.value)
    assert "\n" not in msg and key in msg, msg
    return msg


def test_the_forcing_table_makes_a_periodic_scene(periodic_declared):
    scene = parse_scene(_scene(forcing=dict(phase=7.0)))
    assert scene.system.forcing == Harmonic(0.05, 0.9, 7.0 - 2 * math.pi)
    assert scene.mode == "periodic" and scene.periodic and not scene.transient
    assert scene.phases == tuple(k * math.pi / 4 for k in range(8))
    assert parse_scene(_scene(study=dict(phases=[0.0, 3.0]))).phases == (0.0, 3.0)
    plain = parse_scene(_scene(forcing=None))
    assert plain.mode == "stationary" and plain.phases is None and plain.system.forcing is None
    forced_transient = parse_scene(_scene(study=dict(times=[1.0]),
                                          initial=dict(mean=[0.0, 0.0], std=[0.1, 0.1])))
    assert forced_transient.mode == "transient" and forced_transient.system.forcing is not None


@pytest.mark.parametrize("over, key", [
    (dict(forcing=dict(amplitude=-0.1)), "forcing.amplitude"),
    (dict(forcing=dict(frequency=0.0)), "forcing.frequency"),
    (dict(forcing=dict(phase=float("nan"))), "forcing.phase"),
    (dict(forcing=dict(phase="π")), "forcing.phase"),
    (dict(forcing=dict(amplitud=0.1)), "forcing.amplitud"),
    (dict(study=dict(phases=[0.0, 7.0])), "study.phases[1]"),
    (dict(study=dict(phases=[])), "study.phases"),
    (dict(study=dict(phases=[1.0, 1.0])), "study.phases"),
    (dict(study=dict(phases=[1.0], times=[1.0]),
          initial=dict(mean=[0.0, 0.0], std=[0.1, 0.1])), "study.phases"),
    (dict(forcing=None, study=dict(phases=[1.0])), "study.phases"),
    (dict(sweep={"forcing.frequency": [0.9, 0.0]}), "sweep.forcing.frequency[1]"),
    (dict(sweep={"forcing": {"amplitude": [0.1, -1.0]}}), "sweep.forcing.amplitude[1]"),
    (dict(forcing=None, sweep={"forcing.amplitude": [0.1]}), "sweep.forcing.amplitude"),
    (dict(sweep={"forcing.phase": [0.1]}), "sweep.forcing.phase"),
])
def test_bad_forcing_values_are_one_line_naming_the_key(periodic_declared, over, key):
    data = _scene(**over)
    if data.get("forcing") is not None and "amplitud" in data["forcing"]:
        del data["forcing"]["amplitude"]
    _refused(data, key)


def test_a_forcing_table_needs_amplitude_and_frequency(periodic_declared):
    msg = _refused({**_scene(), "forcing": {"amplitude": 0.05}}, "forcing.frequency")
    assert "required" in msg


@pytest.mark.parametrize("quantity", ["first_passage", "inter_impact", "impact_energy"])
def test_stationary_quantities_on_a_forced_scene_are_refused(periodic_declared, quantity):
    over = {"study": dict(quantities=["moments", quantity])}
    if quantity == "first_passage":
        over["first_passage"] = dict(energy=0.5)
    msg = _refused(_scene(**over), "study.quantities")
    assert quantity in msg and "[forcing]" in msg


def test_averaging_and_exact_are_refused_naming_fem_and_montecarlo(periodic_declared):
    for method in ("averaging", "exact"):
        msg = _refused(_scene(study=dict(methods=["montecarlo", method])), "study.methods")
        assert method in msg and "fem, montecarlo do" in msg


def test_a_forced_scene_runs_with_montecarlo_and_writes_everything(periodic_declared,
                                                                   tmp_path):
    pytest.importorskip("xarray")
    scene = parse_scene(_scene(
        study=dict(quantities=["x", "joint", "moments", "impacts"]),
        output=dict(formats=["json", "npz", "png", "nc"]))).reduced()
    doc = run_scene(scene, out=tmp_path, workers=1, log=lambda s: None)
    assert doc["periodic"] is True and len(doc["phases"]) == 8
    point = doc["points"][0]
    assert point["status"] == "done", point.get("error")
    e = point["methods"]["montecarlo"]
    per = e["periodic"]
    ph = np.array(per["phases"])
    assert ph.tolist() == list(scene.phases)
    for key in ("E_x", "E_x2", "E_y2", "E_H", "P_impact"):
        assert len(per["moments"][key]) == len(per["moments_se"][key]) == 8
    assert set(per["impact_rates"]) == set(per["impact_rates_se"]) == {"left", "right"}
    assert len(per["error_estimate"]["phases"]) == 8
    assert {"mean_x", "amplitude", "lag"} <= set(per["error_estimate"])
    assert per["error_estimate"]["phases"][0]["E_x2"] > 0
    # the first harmonic the engine reports (16 phases a period) is the one of the
    # eight recorded phases, within the statistics (the same paths, other bins)
    ex, se = np.array(per["moments"]["E_x"]), np.array(per["moments_se"]["E_x"])
    m8, A8, th8 = first_harmonic(ph, ex)
    sA = per["harmonic_se"]["amplitude"]
    assert abs(A8 - per["amplitude"]) < 3 * sA + 0.03 * per["amplitude"]
    assert per["amplitude"] > 5 * sA            # the forcing shows: E[x] is not flat
    # the period average is the mean over the phases (8 equally spaced), within 3 SE
    for key in ("E_x2", "E_H"):
        mean8 = float(np.mean(per["moments"][key]))
        assert abs(mean8 - e["moments"][key]) < 3 * e["moments_se"][key]
    assert e["error_estimate"]["E_H"] > 0              # the average's estimate
    for name in ("p0_phase_moments.png", "p0_montecarlo_joint_phases.png",
                 "p0_impact_rates.png", "p0_x.png"):
        assert name in point["figures"] and (tmp_path / name).stat().st_size > 5_000
    with np.load(tmp_path / "densities.npz") as npz:
        assert "p0.montecarlo.x.ph3.pdf" in npz.files and "p0.montecarlo.x.pdf" in npz.files
        assert "p0.montecarlo.joint.ph7.pdf" in npz.files
        area = np.trapezoid(npz["p0.montecarlo.x.ph3.pdf"], npz["p0.montecarlo.x.ph3.grid"])
        assert area == pytest.approx(1.0, abs=0.02)
    import xarray as xr
    with xr.open_dataset(tmp_path / "results.nc", engine="h5netcdf") as ds:
        assert ds["phase_E_x2"].dims == ("point", "method", "phase")
        assert ds["impact_rate"].dims == ("point", "method", "phase", "wall")
        assert float(ds["amplitude"][0, 0]) == pytest.approx(per["amplitude"])
        assert np.allclose(ds["phase"].values, ph)
        assert np.allclose(ds["phase_E_H_se"][0, 0].values, per["moments_se"]["E_H"])


def test_a_frequency_sweep_builds_distinct_systems_and_the_response_curve(
        periodic_declared, tmp_path):
    """Walls at ±0.6 harden the oscillator: its resonance bends above Ω = 1, so the
    amplitude of the mean grows from Ω = 0.8 to 1.0 (measured 0.035 ± 0.002 and
    0.064 ± 0.003 at the reduced size)."""
    scene = parse_scene(_scene(sweep={"forcing.frequency": [0.8, 1.0]},
                               output=dict(formats=["json", "png"]))).reduced()
    systems = [s for _, s in scene.points()]
    assert [s.forcing.frequency for s in systems] == [0.8, 1.0]
    assert all(s.forcing.amplitude == 0.05 and s.delta == 0.6 for s in systems)
    doc = run_scene(scene, out=tmp_path, workers=1, log=lambda s: None)
    assert "sweep_response.png" in doc["figures"]
    assert (tmp_path / "sweep_response.png").stat().st_size > 5_000
    recs = [p["methods"]["montecarlo"]["periodic"] for p in doc["points"]]
    assert [p["system"]["forcing"]["frequency"] for p in doc["points"]] == [0.8, 1.0]
    A = [r["amplitude"] for r in recs]
    se = [r["harmonic_se"]["amplitude"] for r in recs]
    assert A[1] - A[0] > 3 * math.hypot(*se)
    assert not any(f.startswith("p0_") and "joint" in f for f in doc["points"][0]["figures"])


def test_the_key_table_and_check_know_the_forcing_keys(periodic_declared, tmp_path, capsys):
    table = schema_table()
    for key in ("forcing.amplitude", "forcing.frequency", "forcing.phase", "study.phases",
                "sweep.forcing.frequency", "sweep.forcing.amplitude"):
        assert f"`{key}`" in table
    from fpk_vibro.app import cli
    scene = tmp_path / "s.toml"
    scene.write_text(EXAMPLE.read_text().replace('"fem", ', ""))
    assert cli.main(["check", str(scene), "--reduced"]) == 0
    assert "periodic response at 8 phases" in capsys.readouterr().out
    scene.write_text(EXAMPLE.read_text().replace("frequency = 0.9", "frequency = -0.9"))
    assert cli.main(["check", str(scene)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "forcing.frequency" in err


def test_the_example_is_a_forced_frequency_sweep(periodic_declared):
    scene = load_scene(EXAMPLE)
    assert scene.system.forcing == Harmonic(0.05, 0.9)
    assert scene.system.right.r == 0.8 and scene.system.delta == 0.6
    assert list(scene.sweep) == ["forcing.frequency"]
    assert min(scene.sweep["forcing.frequency"]) < 1.0 < max(scene.sweep["forcing.frequency"])
    assert set(scene.methods) == {"fem", "montecarlo"}


def test_a_forced_scene_with_times_is_a_transient_of_the_forced_system(periodic_declared,
                                                                       tmp_path):
    scene = parse_scene(_scene(study=dict(times=[1.0, 5.0]),
                               initial=dict(mean=[0.0, 0.0], std=[0.1, 0.1]),
                               output=dict(formats=["json"]))).reduced()
    assert scene.mode == "transient" and scene.phases is None
    doc = run_scene(scene, out=tmp_path, workers=1, log=lambda s: None)
    point = doc["points"][0]
    assert point["status"] == "done", point.get("error")
    assert point["system"]["forcing"] == {"amplitude": 0.05, "frequency": 0.9, "phase": 0.0}
    assert "periodic" not in doc and len(point["methods"]["montecarlo"]["at"]) == 2


def test_fem_and_montecarlo_agree_phase_by_phase_in_a_scene(periodic_declared, tmp_path):
    """The two engines of the periodic response through the same scene: E[x] and E[x²]
    at each of the 8 phases, the amplitude and the lag within 3.5 Monte Carlo SE (8
    phases a key) plus 0.3 % (FE's estimate is far below: 1e-5 relative)."""
    scene = parse_scene(_scene(study=dict(methods=["fem", "montecarlo"]),
                               output=dict(formats=["json", "png"]))).reduced()
    doc = run_scene(scene, out=tmp_path, workers=1, log=lambda s: None)
    point = doc["points"][0]
    assert point["status"] == "done", point.get("error")
    fe, mc = (point["methods"][m]["periodic"] for m in ("fem", "montecarlo"))
    assert fe["phases"] == mc["phases"] and "moments_se" not in fe
    for key in ("E_x", "E_x2", "E_H"):
        f, m, se = (np.array(v) for v in (fe["moments"][key], mc["moments"][key],
                                          mc["moments_se"][key]))
        assert np.all(np.abs(f - m) < 3.5 * se + 0.003 * np.abs(f)), key
    for key in ("amplitude", "lag"):
        assert abs(fe[key] - mc[key]) < 3.5 * mc["harmonic_se"][key] + 0.003 * abs(fe[key])
        assert fe["error_estimate"][key] < 0.1 * mc["harmonic_se"][key]
    assert "p0_phase_moments.png" in point["figures"]
