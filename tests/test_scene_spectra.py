"""Scenes with the quantities "spectra" and "crossings" (issue 36): the keys of
[spectra] and [crossings] (one line naming the key), their defaults, results.json,
densities.npz, netCDF with the coordinates ω (or f) and b, the figures, a sweep's
peak frequency, resume, and only what the scene asks is computed.

Most runs put a stand-in spectrum (the linear oscillator's closed form, known
exactly) behind the registry so that what the app does with a Spectrum is checked
exactly; :func:`test_the_real_engines_through_a_scene` runs the methods' own."""
import copy
import math

import numpy as np
import pytest

from scipy.integrate import trapezoid

from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import SceneError, check_scene, parse_scene
from fpk_vibro.registry import methods, register, replace
from fpk_vibro.scales import omega0
from fpk_vibro.spectrum import Spectrum

BASE = {"system": dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01),
        "barriers": dict(delta=0.6, r=0.9),
        "study": {"methods": ["fem"], "quantities": ["moments", "spectra", "crossings"]},
        "fem": {"nx": 24},
        "output": {"formats": ["json", "npz", "png", "nc"]}}
CALLS: list = []


def _scene(**tables):
    d = copy.deepcopy(BASE)
    for k, v in tables.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return parse_scene(d)


def _linear_S(system, w, of):
    S = system.D1 / math.pi / ((system.a - w ** 2) ** 2 + (system.c * w) ** 2)
    return S * w ** 2 if of == "y" else S


def _stand_in(name):
    def spectrum(system, omega, of="x", seed=None):
        CALLS.append((name, of, seed))
        w = np.asarray(omega, dtype=float)
        S = _linear_S(system, w, of)
        var = system.D1 / (system.a * system.c) * (system.a if of == "y" else 1.0)
        return Spectrum(name, system, of, w, S, variance=var,
                        se=0.05 * S if name == "montecarlo" else None,
                        estimate={"density": 0.01 * S, "relative": 0.01, "variance": 0.0,
                                  "correlation": 0.0, "assumes": "a stand-in"})
    return spectrum


@pytest.fixture
def stand_in():
    """The three methods' spectra replaced by the stand-in (restored after)."""
    saved = {m: methods()[m] for m in ("fem", "montecarlo", "averaging")}
    CALLS.clear()
    for m, method in saved.items():
        register(replace(method, spectrum=lambda f=_stand_in(m): f))
    yield CALLS
    for method in saved.values():
        register(method)


def _one_line(exc, key):
    text = str(exc)
    assert "\n" not in text and text.startswith(key) and exc.name == key, (text, exc.name)


@pytest.mark.parametrize("table, value, key", [
    ("spectra", {"omega": [1.0, 0.5]}, "spectra.omega"),
    ("spectra", {"omega": [-1.0, 1.0]}, "spectra.omega"),
    ("spectra", {"omega": []}, "spectra.omega"),
    ("spectra", {"omega": {"start": 0, "stop": 2}}, "spectra.omega"),
    ("spectra", {"omega": {"start": 0, "stop": 2, "n": 1}}, "spectra.omega"),
    ("spectra", {"omega": {"start": 2, "stop": 1, "n": 5}}, "spectra.omega"),
    ("spectra", {"of": "z"}, "spectra.of"),
    ("spectra", {"of": ["x", "x"]}, "spectra.of"),
    ("spectra", {"units": "kHz"}, "spectra.units"),
    ("spectra", {"sided": "both"}, "spectra.sided"),
    ("spectra", {"omaga": [1.0]}, "spectra.omaga"),
    ("crossings", {"levels": [0.2, 0.1]}, "crossings.levels"),
    ("crossings", {"levels": "0.1"}, "crossings.levels"),
    ("crossings", {"levels": {"start": 0, "stop": 1, "n": 2.5}}, "crossings.levels"),
    ("crossings", {"displacement": -0.5}, "crossings.displacement"),
    ("crossings", {"displacement": [0.5, -0.5]}, "crossings.displacement"),
    ("crossings", {"rice_times": [-1.0]}, "crossings.rice_times"),
])
def test_a_bad_key_is_one_line_naming_it(table, value, key):
    with pytest.raises(SceneError) as err:
        _scene(**{table: value})
    _one_line(err.value, key)


@pytest.mark.parametrize("table, value", [("spectra", {"of": "y"}),
                                          ("crossings", {"levels": [0.1]})])
def test_a_table_without_its_quantity_is_refused(table, value):
    with pytest.raises(SceneError) as err:
        _scene(study={"methods": ["fem"], "quantities": ["moments"]}, **{table: value})
    _one_line(err.value, table)
    assert f'"{table}"' in str(err.value)


def test_the_grids_default_to_the_systems_of_the_sweep():
    sc = _scene()
    w = np.array(sc.spectra["omega"])
    assert w.size == 301 and w[0] == 0 and np.isclose(w[-1], 3 * omega0(sc.system))
    assert sc.spectra["of"] == ("x",) and sc.spectra["units"] == "rad/s"
    levels = np.array(sc.crossings["levels"])
    assert levels[0] == -0.6 and levels[-1] == 0.6 and np.all(np.diff(levels) > 0)
    swept = _scene(sweep={"delta": [0.45, 0.6]})
    assert {-0.6, -0.45, 0.45, 0.6} <= set(swept.crossings["levels"])
    sc = _scene(spectra={"omega": {"start": 0.5, "stop": 1.5, "n": 3}, "of": ["x", "y"]},
                crossings={"levels": [0.1, 0.3]})
    assert sc.spectra["omega"] == (0.5, 1.0, 1.5) and sc.spectra["of"] == ("x", "y")
    assert sc.crossings["levels"] == (0.1, 0.3)


def test_spectra_and_crossings_are_stationary_only():
    for extra in ({"study": {"methods": ["fem"], "quantities": ["spectra"], "times": [1.0]},
                   "initial": {"mean": [0, 0], "std": [0.1, 0.1]}},
                  {"forcing": {"amplitude": 0.05, "frequency": 1.0},
                   "study": {"methods": ["fem"], "quantities": ["crossings"]}}):
        with pytest.raises(SceneError) as err:
            _scene(**extra)
        _one_line(err.value, "study.quantities")


def test_a_rice_band_without_levels_inside_the_walls_is_refused_before_work():
    sc = _scene(crossings={"levels": [0.7, 0.8], "rice_times": [1.0, 2.0]})
    with pytest.raises(SceneError) as err:
        check_scene(sc)
    _one_line(err.value, "crossings.displacement")


def test_a_method_without_spectra_gives_way_to_one_that_has_them():
    with pytest.raises(SceneError) as err:      # exact gives crossings, not spectra
        _scene(barriers={"delta": 0.6, "r": 1.0}, system=dict(a=1.0, b=0.2, c=0.025, D1=0.01),
               study={"methods": ["exact"], "quantities": ["spectra"]})
    _one_line(err.value, "study.quantities")


def test_a_run_writes_spectra_and_crossings_everywhere(tmp_path, stand_in):
    """fem at one point: the records are the Spectrum's own (exactly the stand-in's S,
    in Hz one-sided where asked), ν⁺ at each wall is FE's impact rate there (the
    identity), the Rice estimate is exp(−rate t) and the true R(t) is FE's first
    passage; densities.npz holds S and R(τ), netCDF the coordinates f and b; the
    figures are written."""
    import xarray as xr
    sc = _scene(spectra={"of": ["x", "y"], "units": "Hz", "sided": "one",
                         "omega": {"start": 0.0, "stop": 3.0, "n": 61}},
                crossings={"levels": {"start": -0.6, "stop": 0.6, "n": 13},
                           "rice_times": [0.0, 5.0, 20.0]})
    doc = run_scene(sc, out=tmp_path, workers=1, log=lambda s: None)
    assert doc["spectra"]["units"] == "Hz" and len(doc["crossings"]["levels"]) == 13
    point = doc["points"][0]
    assert point["status"] == "done", point.get("error")
    w = np.linspace(0.0, 3.0, 61)
    e = point["methods"]["fem"]
    for of in ("x", "y"):
        rec = e["spectra"][of]
        S = _linear_S(sc.system, w, of)
        assert np.allclose(rec["omega"], w) and np.allclose(rec["density"], S, rtol=1e-12)
        assert rec["error_estimate"]["relative"] == 0.01
        req = rec["requested"]
        assert np.allclose(req["frequency"], w / (2 * np.pi))
        assert np.allclose(req["density"], 2 * 2 * np.pi * S, rtol=1e-12)
    cr = e["crossings"]
    assert np.allclose(cr["levels"], np.linspace(-0.6, 0.6, 13))
    up = np.array(cr["upcrossing_rate"])
    assert up.shape == (13,) and np.all(up > 0)
    for side in ("left", "right"):
        wall = cr["walls"][side]
        assert wall["identity"] < 1e-4            # ν⁺(wall) = impact rate (measured ~1e-6)
        assert wall["threshold_energy"] == pytest.approx(0.5 * 0.36 + 0.05 * 0.6 ** 4)
    rice = cr["rice"]
    assert rice["band"] == [-0.5, 0.5]            # the highest level inside the walls
    assert np.allclose(rice["estimate"], np.exp(-rice["rate"] * np.array([0.0, 5.0, 20.0])))
    true = rice["true"]["survival"]
    assert true[0] == pytest.approx(1.0) and true[1] > true[2] > 0
    with np.load(tmp_path / "densities.npz") as npz:
        key = "p0.fem.spectrum_x"
        assert np.allclose(npz[f"{key}.density"], _linear_S(sc.system, w, "x"))
        assert npz[f"{key}.correlation"][0] == pytest.approx(
            2 * trapezoid(npz[f"{key}.density"], w))
    with xr.open_dataset(tmp_path / "results.nc", engine="h5netcdf") as ds:
        assert np.allclose(ds["frequency"], w / (2 * np.pi))
        assert ds["frequency"].attrs["units"] == "Hz"
        assert np.allclose(ds["spectral_density"].sel({"method": "fem", "signal": "y"})[0],
                           req["density"])
        assert np.allclose(ds["level"], cr["levels"])
        assert np.allclose(ds["upcrossing_rate"].sel({"method": "fem"})[0], up)
        assert np.allclose(ds["rice_true_reliability"].sel({"method": "fem"})[0], true)
        assert "E_x2" in ds                       # beside what the run always writes
    for fig in ("p0_spectra.png", "p0_crossings.png", "p0_rice.png"):
        assert fig in point["figures"] and (tmp_path / fig).stat().st_size > 5_000


def test_only_what_the_scene_asks_is_computed(tmp_path, stand_in):
    doc = run_scene(_scene(study={"methods": ["fem"], "quantities": ["moments", "crossings"]},
                           output={"formats": ["json"]}),
                    out=tmp_path / "a", workers=1, log=lambda s: None)
    e = doc["points"][0]["methods"]["fem"]
    assert stand_in == [] and "spectra" not in e and "levels" in e["crossings"]
    assert "rice" in e["crossings"] and "true" not in e["crossings"]["rice"]   # no times
    doc = run_scene(_scene(study={"methods": ["fem"], "quantities": ["moments", "spectra"]},
                           output={"formats": ["json"]}),
                    out=tmp_path / "b", workers=1, log=lambda s: None)
    e = doc["points"][0]["methods"]["fem"]
    assert stand_in == [("fem", "x", None)] and "crossings" not in e
    assert "figures" not in doc["points"][0]


def test_a_sweep_draws_the_peak_frequency_and_resume_keeps_the_points(tmp_path, stand_in):
    """The stand-in peaks near √a: a sweep of a moves the peak, the record, netCDF
    and the figure show it; Monte Carlo gets the scene's seed; a resumed run computes
    nothing again."""
    import xarray as xr
    sc = _scene(study={"methods": ["fem", "montecarlo"], "quantities": ["moments", "spectra"]},
                sweep={"a": [1.0, 2.25]}, montecarlo={"n_paths": 256, "t_sample": 40.0,
                                                     "seed": 7},
                spectra={"omega": {"start": 0.0, "stop": 3.0, "n": 301}})
    doc = run_scene(sc, out=tmp_path, workers=1, log=lambda s: None)
    assert ("montecarlo", "x", 7) in stand_in and len(stand_in) == 4
    peaks = [p["methods"]["fem"]["spectra"]["x"]["peak_frequency"] for p in doc["points"]]
    for a, peak in zip([1.0, 2.25], peaks):
        assert abs(peak - math.sqrt(a - 0.025 ** 2 / 2)) < 0.01     # grid step 0.01
    assert "sweep_peak_frequency.png" in doc["figures"]
    assert (tmp_path / "sweep_peak_frequency.png").stat().st_size > 5_000
    with xr.open_dataset(tmp_path / "results.nc", engine="h5netcdf") as ds:
        assert np.allclose(ds["peak_frequency"].sel({"method": "fem", "signal": "x"}), peaks)
        assert "spectral_density_se" in ds and "omega" in ds.coords
    lines = []
    run_scene(sc, out=tmp_path, workers=1, log=lines.append, resume=True)
    assert len(stand_in) == 4 and "resuming: 2 of 2 point(s) reused" in lines[0], lines


def test_the_real_engines_through_a_scene(tmp_path):
    """The methods' own spectra and crossings on the paper's case (r = 0.92) at small
    sizes: Monte Carlo's
    spectrum carries its standard errors and agrees with FE's near the peak within
    4 SE + both estimates, ν⁺ at each wall is the impact rate (FE to 1e-4, Monte
    Carlo's counted rates within 4 SE), and the Rice rate exceeds the true decay."""
    sc = _scene(system=dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01),
                barriers=dict(delta=0.6, r=0.92),
                study={"methods": ["fem", "montecarlo"],
                       "quantities": ["moments", "impacts", "spectra", "crossings"]},
                fem={"rtol": 1e-2}, montecarlo={"seed": 3, "n_paths": 64, "t_sample": 4000.0},
                spectra={"omega": {"start": 0.5, "stop": 1.5, "n": 101}},
                crossings={"levels": {"start": -0.6, "stop": 0.6, "n": 7},
                           "rice_times": [0.0, 20.0]},
                output={"formats": ["json"]})
    doc = run_scene(sc, out=tmp_path, workers=1, log=lambda s: None)
    point = doc["points"][0]
    assert point["status"] == "done", point.get("error")
    m = point["methods"]
    fe, mc = (m[k]["spectra"]["x"] for k in ("fem", "montecarlo"))
    w = np.array(fe["omega"])
    near = np.abs(w - fe["peak_frequency"]) < 0.1
    S_fe, S_mc, se = (np.array(r)[near] for r in (fe["density"], mc["density"], mc["se"]))
    bound = 4 * se + np.array(fe["error_estimate"]["density"])[near] + np.array(
        mc["error_estimate"]["density"])[near]
    assert np.all(np.abs(S_mc - S_fe) <= bound)
    for side in ("left", "right"):
        assert m["fem"]["crossings"]["walls"][side]["identity"] < 1e-4
    counted = m["montecarlo"]["crossings"]["counted"]
    b = np.array(counted["levels"])
    for side, at in (("left", 0), ("right", -1)):
        rate, rse = counted["impact_rate"][side], counted["impact_rate_se"][side]
        assert b[at] == (-0.6 if side == "left" else 0.6)
        assert abs(counted["upcrossing_rate"][at] - rate) < 4 * (
            counted["upcrossing_rate_se"][at] + rse)
    rice = m["fem"]["crossings"]["rice"]
    assert rice["estimate"][1] < rice["true"]["survival"][1]     # clumped crossings
