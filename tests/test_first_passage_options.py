"""First passage is a mode of the option system (issue 24): its numerical keywords
are declared once by each method's Options (mode "first_passage"), refused in one
line naming them (Python call and scene check) and set from a scene's method table."""
from __future__ import annotations

import textwrap

import pytest

from fpk_vibro import VibroImpactSystem, averaging, fem
from fpk_vibro import montecarlo as mc
from fpk_vibro._checks import InputError
from fpk_vibro.options import MODES
from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import SceneError, check_scene, load_scene
from conftest import paper_tables

PAPER = VibroImpactSystem.paper(r=0.92)

SCENE = paper_tables(D2=0.0) + """
[study]
methods = ["averaging"]
quantities = ["energy", "first_passage"]

[first_passage]
energy = 0.05
"""


def scene(tmp_path, text):
    p = tmp_path / "scene.toml"
    p.write_text(textwrap.dedent(text))
    return load_scene(p)


def one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


# -- declared once -------------------------------------------------------------------

def test_first_passage_is_a_mode():
    assert "first_passage" in MODES


@pytest.mark.parametrize("Options, names", [
    (mc.Options, {"n_paths", "dt", "t_max", "seed", "threads", "progress", "bridge",
                  "device"}),
    (fem.Options, {"nx", "ny", "degree", "n_steps", "rtol"}),
    (averaging.Options, {"n_grid", "n_cells"}),
])
def test_the_first_passage_keywords_are_declared_options(Options, names):
    """Options.for_mode("first_passage") lists exactly the solver's numerical keywords."""
    assert set(Options.for_mode("first_passage")) == names


@pytest.mark.parametrize("Options", [mc.Options, fem.Options, averaging.Options])
def test_the_declared_defaults_are_the_solvers(Options):
    import inspect
    solver = {"montecarlo": mc, "fem": fem, "averaging": averaging}[Options.WHERE]
    params = inspect.signature(solver.first_passage).parameters
    for name, opt in Options.for_mode("first_passage").items():
        assert params[name].default == opt.default_for("first_passage"), name


# -- refused in one line naming the keyword -----------------------------------------

@pytest.mark.parametrize("call, kw, name", [
    (mc.first_passage, {"n_paths": 1}, "n_paths"),
    (mc.first_passage, {"n_paths": 10 ** 10}, "n_paths"),
    (mc.first_passage, {"t_max": -1.0}, "t_max"),
    (mc.first_passage, {"t_max": 1e-9}, "t_max"),
    (mc.first_passage, {"dt": 100.0}, "dt"),
    (mc.first_passage, {"bridge": "yes"}, "bridge"),
    (fem.first_passage, {"nx": 1}, "nx"),
    (fem.first_passage, {"ny": 31}, "ny"),
    (fem.first_passage, {"degree": 3}, "degree"),
    (fem.first_passage, {"n_steps": 5}, "n_steps"),
    (fem.first_passage, {"rtol": -1.0}, "rtol"),
    (averaging.first_passage, {"n_grid": 3}, "n_grid"),
    (averaging.first_passage, {"n_cells": 10 ** 6}, "n_cells"),
], ids=lambda v: getattr(v, "__module__", None) and v.__module__.split(".")[1]
    if callable(v) else None)
def test_a_keyword_out_of_range_is_refused_naming_it(call, kw, name):
    with pytest.raises(InputError) as exc:
        call(PAPER, energy=0.5, **kw)
    assert exc.value.name == name
    assert one_line(exc).startswith(f"{exc.value.where}: {name}")
    assert exc.value.where.endswith(".first_passage")


def test_the_budget_sees_the_first_passage_keywords():
    """n_paths = 10⁹ passed the old ad hoc check's sibling in Options, 10⁷ here: now
    one range, and the budget refuses the memory."""
    with pytest.raises(InputError) as exc:
        mc.first_passage(PAPER, energy=0.5, n_paths=10 ** 9)
    assert exc.value.name == "n_paths" and "needs an estimated" in one_line(exc)


def test_a_scene_refuses_a_first_passage_keyword_out_of_range(tmp_path):
    text = SCENE + "\n[averaging]\nn_grid = 3\n"
    with pytest.raises(SceneError) as exc:
        scene(tmp_path, text)
    assert exc.value.name == "averaging.n_grid" and "averaging.n_grid" in one_line(exc)


def test_the_scene_check_runs_the_first_passage_rules(tmp_path):
    """fem.degree = 3 is a valid stationary degree, not a first-passage one."""
    text = SCENE.replace('methods = ["averaging"]', 'methods = ["fem"]') + \
        "\n[fem]\ndegree = 3\nnx = 8\nny = 8\n"
    with pytest.raises(SceneError) as exc:
        check_scene(scene(tmp_path, text))
    assert exc.value.name == "fem.degree"
    assert one_line(exc).startswith("fem.degree") and "[1, 2]" in str(exc.value)


def test_a_first_passage_key_without_first_passage_is_refused(tmp_path):
    text = SCENE.replace(', "first_passage"', "").replace(
        "[first_passage]\nenergy = 0.05\n", "") + "\n[averaging]\nn_grid = 200\n"
    with pytest.raises(SceneError) as exc:
        check_scene(scene(tmp_path, text))
    assert exc.value.name == "averaging.n_grid"
    assert one_line(exc).startswith("averaging.n_grid") and "first passage" in str(exc.value)


def test_a_first_passage_key_in_a_transient_scene_is_refused(tmp_path):
    text = SCENE.replace(', "first_passage"', "").replace(
        "[first_passage]\nenergy = 0.05\n", "").replace(
        '[study]\n', '[study]\ntimes = [1.0]\n') + \
        "\n[initial]\nmean = [0.0, 0.0]\nstd = [0.1, 0.1]\n\n[montecarlo]\nt_max = 5.0\n"
    text = text.replace('methods = ["averaging"]', 'methods = ["montecarlo"]')
    with pytest.raises(SceneError) as exc:
        scene(tmp_path, text)
    assert exc.value.name == "montecarlo.t_max" and "first-passage" in one_line(exc)


# -- a scene's keyword reaches the solver ------------------------------------------------

def test_the_scene_keywords_reach_first_passage(tmp_path):
    text = SCENE + "\n[averaging]\nn_grid = 200\nn_cells = 64\n"
    doc = run_scene(scene(tmp_path, text), out=tmp_path / "o", log=lambda s: None)
    info = doc["points"][0]["methods"]["averaging"]["first_passage"]["info"]
    assert info["n_grid"] == 200 and info["n_cells"] == 64
    plain = run_scene(scene(tmp_path, SCENE), out=tmp_path / "p", log=lambda s: None)
    record = plain["points"][0]["methods"]["averaging"]["first_passage"]
    assert record["info"]["n_grid"] == 4000 and record["info"]["n_cells"] == 400
    assert record["mean"] != doc["points"][0]["methods"]["averaging"]["first_passage"]["mean"]


def test_a_monte_carlo_scene_sets_n_paths_of_first_passage(tmp_path):
    text = SCENE.replace('methods = ["averaging"]', 'methods = ["montecarlo"]') + \
        "\n[montecarlo]\nn_paths = 64\nt_sample = 20.0\nseed = 3\nt_max = 400.0\n"
    doc = run_scene(scene(tmp_path, text), out=tmp_path / "o", log=lambda s: None)
    info = doc["points"][0]["methods"]["montecarlo"]["first_passage"]["info"]
    assert info["n_paths"] == 64 and info["t_max"] == pytest.approx(400.0, rel=1e-3)
