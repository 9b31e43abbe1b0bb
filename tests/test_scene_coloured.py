"""Scenes with coloured external noise ([external] tau = τ): the key, its sweep, its
one-line refusals and a small run through the runner (issue 35)."""
import json

import pytest

from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import SceneError, check_scene, parse_scene

BASE = {"system": dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.0),
        "barriers": dict(delta=0.6, r=0.92),
        "study": {"methods": ["montecarlo"], "quantities": ["energy", "moments"]}}


def _scene(**tables):
    return parse_scene({**BASE, **tables})


def _one_line(exc: SceneError, key: str) -> None:
    text = str(exc)
    assert "\n" not in text and text.startswith(key) and exc.name == key


def test_external_table_gives_the_coloured_system():
    scene = _scene(external={"tau": 0.5})
    assert scene.system.external.tau == 0.5
    assert scene.system.to_dict()["external"] == {"tau": 0.5}
    assert scene.mode == "stationary"
    assert _scene().system.external is None         # no table: white noise


@pytest.mark.parametrize("tau", [0, -1, "x", float("inf")])
def test_a_bad_tau_is_one_line_naming_the_key(tau):
    with pytest.raises(SceneError) as err:
        _scene(external={"tau": tau})
    _one_line(err.value, "external.tau")


@pytest.mark.parametrize("table, key", [({}, "external.tau"), ({"tau": 1, "t": 2}, "external.t")])
def test_a_missing_or_unknown_key_of_external_is_named(table, key):
    with pytest.raises(SceneError) as err:
        _scene(external=table)
    _one_line(err.value, key)


def test_a_sweep_of_tau_makes_one_point_per_value():
    taus = [0.1, 0.25, 0.5, 1.0]
    # TOML reads `external.tau = [...]` as a sub-table, `"external.tau" = [...]` does not
    for sweep in ({"external": {"tau": taus}}, {"external.tau": taus}):
        scene = _scene(external={"tau": 0.5}, sweep=sweep)
        points = scene.points()
        assert scene.n_points == len(points) == len(taus)
        assert [p["external.tau"] for p, _ in points] == taus
        assert [s.external.tau for _, s in points] == taus
        assert all(s.D1 == 0.01 and s.r == 0.92 for _, s in points)


@pytest.mark.parametrize("values", [[0.1, 0.0], [0.1, -1.0], [0.1, "x"]])
def test_a_bad_swept_tau_is_one_line(values):
    with pytest.raises(SceneError) as err:
        _scene(external={"tau": 0.5}, sweep={"external.tau": values})
    _one_line(err.value, "sweep.external.tau")
    assert "sweep.external.tau[1]" in str(err.value)


def test_a_sweep_of_tau_needs_the_table():
    with pytest.raises(SceneError) as err:
        _scene(sweep={"external.tau": [0.1, 1.0]})
    _one_line(err.value, "sweep.external.tau")
    assert "[external]" in str(err.value)


def test_forcing_with_coloured_noise_is_refused_in_one_line():
    with pytest.raises(SceneError) as err:
        _scene(external={"tau": 0.5}, forcing={"amplitude": 0.05, "frequency": 1.0})
    _one_line(err.value, "external")


def test_a_method_without_coloured_noise_is_refused_before_work():
    scene = parse_scene({**BASE, "external": {"tau": 0.5},
                         "study": {"methods": ["averaging"], "quantities": ["energy"]}})
    with pytest.raises(SceneError) as err:
        check_scene(scene)
    assert "\n" not in str(err.value) and "averaging" in str(err.value)


def test_a_small_coloured_sweep_runs_and_writes_the_moments(tmp_path):
    """Two points (τ = 0.1, 1) of Monte Carlo: results.json holds the moments and
    E[ζ²], E[ζ y] with their SEs, E[ζ²] is D1/τ (ζ is sampled exactly from its
    stationary law), the input E[ζ y] is positive, E[H] falls with τ at fixed D1 (the
    noise's spectrum D1/π / (1 + ω²τ²) falls at the resonance), and the figure of
    the moments against τ is written."""
    taus = [0.1, 1.0]
    scene = parse_scene({**BASE, "external": {"tau": 0.5}, "sweep": {"external.tau": taus},
                         "montecarlo": {"n_paths": 256, "t_sample": 100.0, "seed": 3},
                         "output": {"formats": ["json", "png"]}})
    run_scene(scene, out=tmp_path, workers=1, log=lambda s: None)
    doc = json.loads((tmp_path / "results.json").read_text())
    assert [p["parameters"]["external.tau"] for p in doc["points"]] == taus
    e_h = []
    for point, tau in zip(doc["points"], taus):
        assert point["status"] == "done"
        mc = point["methods"]["montecarlo"]
        assert {"E_H", "E_x2", "E_y2"} <= set(mc["moments"]) and "E_H" in mc["moments_se"]
        col = mc["coloured"]
        assert abs(col["E_zeta2"] - 0.01 / tau) < 3 * col["E_zeta2_se"] + 1e-3 * 0.01 / tau
        assert col["E_zeta_y"] > 3 * col["E_zeta_y_se"]
        e_h.append((mc["moments"]["E_H"], mc["moments_se"]["E_H"]))
    (h1, s1), (h2, s2) = e_h
    assert h1 - h2 > 3 * (s1 ** 2 + s2 ** 2) ** 0.5
    assert "sweep_moments.png" in doc["figures"]
    assert (tmp_path / "sweep_moments.png").stat().st_size > 5_000
