"""Issue 22 §8, each a pattern: one argument check for every density of every Solution
class; a bad ``grids`` dict of ``to_xarray`` named by its key; ``power_balance()`` of
a transient refused; ``fpk-vibro show`` marks a partial method; ``--quiet`` prints
nothing (meshio's VTU warning); no scene message starts with "None:"."""
import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, Wall, averaging, exact, fem, montecarlo
from fpk_vibro.app import cli
from fpk_vibro._checks import InputError
from fpk_vibro.app.scenes import SceneError, check_scene, parse_scene
from fpk_vibro.solution import Solution
from conftest import paper_tables

#: The densities and their point arguments (fpk_vibro.solution._POINT_ARGS).
_POINT_ARGS = {"pdf_energy": ("H",), "pdf_joint": ("x", "y"), "pdf_x": ("x",),
               "pdf_y": ("y",), "impact_speed_pdf": ("wall", "u")}

S = VibroImpactSystem.paper(r=0.92)
INIT = {"mean": (0.1, 0.3), "std": (0.1, 0.2)}
MC = dict(seed=1, n_paths=64, progress=False)
KINDS = {
    "exact": lambda: exact.gibbs(VibroImpactSystem(a=1, b=0.2, c=0.025, D1=0.01,
                                                   left=Wall(-0.4), right=Wall(0.8))),
    "averaging": lambda: averaging.stationary(S),
    "fem": lambda: fem.stationary(S, nx=8, ny=16),
    "montecarlo": lambda: montecarlo.stationary(
        S, t_sample=20.0, quantities=("energy", "x", "y", "joint", "impacts"), **MC),
    "averaging_transient": lambda: averaging.transient(S, initial=INIT, times=[1.0])[0],
    "fem_transient": lambda: fem.transient(S, initial=INIT, times=[1.0], nx=8)[0],
    "montecarlo_transient": lambda: montecarlo.transient(S, initial=INIT, times=[1.0],
                                                         **MC)[0],
}
_SOLUTIONS: dict = {}


def solution(kind):
    if kind not in _SOLUTIONS:
        _SOLUTIONS[kind] = KINDS[kind]()
    return _SOLUTIONS[kind]


def one_line(exc, *words):
    msg = str(exc.value)
    assert isinstance(exc.value, InputError), type(exc.value)
    assert "\n" not in msg and len(msg) < 300 and not msg.startswith("None"), msg
    for w in words:
        assert w in msg, (w, msg)


# -- one argument check for every pdf_* and impact_speed_pdf --------------------------
BAD = [(float("nan"), "nan"), (None, "None"), (float("inf"), "inf"), (-np.inf, "-inf"),
       ("0.1", "'0.1'"), ([0.1, float("nan")], "nan (at index 1"), (1j, "1j"), (True, "True")]
CALLS = {"pdf_energy": lambda s, v: s.pdf_energy(v), "pdf_x": lambda s, v: s.pdf_x(v),
         "pdf_y": lambda s, v: s.pdf_y(v), "pdf_joint x": lambda s, v: s.pdf_joint(v, 0.1),
         "pdf_joint y": lambda s, v: s.pdf_joint(0.1, y=v),
         "impact_speed_pdf": lambda s, v: s.impact_speed_pdf("right", v)}


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_density_refuses_nan_none_inf_and_strings_naming_the_argument(kind):
    sol = solution(kind)
    for call, f in CALLS.items():
        name = call.split()[0]
        if name == "impact_speed_pdf" and kind not in ("exact", "averaging", "fem",
                                                       "montecarlo"):
            continue                           # no impact-speed density here
        arg = call.split()[1] if " " in call else _POINT_ARGS[name][-1]
        for value, shown in BAD:
            with pytest.raises(ValueError) as exc:
                f(sol, value)
            one_line(exc, f"{name}: {arg} must be finite real numbers", f"got {shown}")
        ok = f(sol, [0.1, 0.2])                 # good points still work
        assert np.all(np.isfinite(ok)) and np.shape(ok) == (2,)


def test_impact_speed_pdf_of_inf_is_an_error_not_nan():
    with pytest.raises(InputError) as exc:
        solution("averaging").impact_speed_pdf("right", np.inf)
    one_line(exc, "u must be", "got inf")


def test_every_solution_class_has_the_check_on_every_density_it_defines():
    import importlib
    from fpk_vibro.solution import KIND_MODULES
    for module in set(KIND_MODULES.values()):
        importlib.import_module(module)
    seen = 0
    for cls in set(Solution._registry.values()):
        for klass in cls.__mro__:
            for name in _POINT_ARGS:
                if klass is not Solution and name in vars(klass):
                    assert getattr(vars(klass)[name], "_points_checked", False), (klass, name)
                    seen += 1
    assert seen >= 18                          # 5 classes, 4-5 densities each


# -- to_xarray(grids=...) -------------------------------------------------------------
BAD_GRIDS = [({"xx": [0.1]}, "grids", "'xx'"), ({"x": None}, "grids['x']", "None"),
             ({"x": [[0.1, 0.2]]}, "grids['x']", "[[0.1, 0.2]] (shape (1, 2))"),
             ({"x": []}, "grids['x']", "[] (shape (0,))"),
             ({"energy": [0.1, float("nan")]}, "grids['energy']", "nan"),
             ({"y": "abc"}, "grids['y']", "'abc'"),
             ({"joint": [0.1, 0.2, 0.3]}, "grids['joint']", "[0.1, 0.2, 0.3]"),
             ({"joint": ([0.1], None)}, "grids['joint'][1]", "None"),
             ({"joint": 3}, "grids['joint']", "3"), (3, "grids", "3"),
             ([("x", [0.1])], "grids", "[('x', [0.1])]")]


@pytest.mark.parametrize("grids, key, shown", BAD_GRIDS, ids=[repr(g)[:30] for g, _, _ in BAD_GRIDS])
def test_to_xarray_with_a_bad_grids_dict_names_the_key(grids, key, shown):
    pytest.importorskip("xarray")
    with pytest.raises(ValueError) as exc:
        solution("exact").to_xarray(grids)
    one_line(exc, f"to_xarray: {key} must be", f"got {shown}")


def test_to_xarray_takes_the_default_for_a_missing_grid():
    pytest.importorskip("xarray")
    sol = solution("exact")
    ds = sol.to_xarray({"x": np.linspace(-0.3, 0.3, 7)})
    assert ds.sizes["x"] == 7 and ds.sizes["y"] == sol.to_xarray().sizes["y"]


# -- power_balance of a transient ------------------------------------------------------
@pytest.mark.parametrize("kind", ["averaging_transient", "fem_transient", "montecarlo_transient"])
def test_power_balance_of_a_transient_is_refused_naming_its_time(kind, tmp_path):
    sol = solution(kind)
    with pytest.raises(ValueError) as exc:
        sol.power_balance()
    one_line(exc, "power_balance: time must be None (a stationary density)", "got 1.0",
             "dE[H]/dt")
    back = Solution.load(sol.save(tmp_path / "t"))       # also once saved and loaded
    with pytest.raises(InputError):
        back.power_balance()


def test_power_balance_of_a_stationary_density_is_unchanged():
    pb = solution("fem").power_balance()
    assert set(pb) == {"noise", "damping", "impacts", "residual"}
    assert all(np.isfinite(v) for v in pb.values())


# -- fpk-vibro show marks a partial method ----------------------------------------------
def test_show_marks_a_partial_monte_carlo_point(tmp_path, capsys):
    entry = {"wall_time_s": 1.0, "moments": {"E_H": 0.17, "E_x2": 0.1, "E_y2": 0.24},
             "moments_se": {"E_H": 0.01}}
    doc = {"status": "interrupted", "signal": "SIGINT", "points": [
        {"index": 0, "parameters": {"r": 0.9}, "status": "interrupted",
         "methods": {"averaging": dict(entry), "montecarlo": {**entry, "partial": True}}}]}
    (tmp_path / "results.json").write_text(json.dumps(doc))
    assert cli.main(["show", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    mc = [ln for ln in lines if "montecarlo" in ln]
    avg = [ln for ln in lines if "averaging" in ln]
    assert len(mc) == 1 and "PARTIAL" in mc[0], lines
    assert len(avg) == 1 and "PARTIAL" not in avg[0], lines


# -- --quiet prints nothing, not even meshio's warning ----------------------------------
FEM_VTU = paper_tables(D2=None) + """
[study]
methods = ["fem"]
quantities = ["moments"]
[fem]
nx = 8
ny = 16
[output]
formats = ["json", "vtu"]
"""


def test_quiet_run_writing_vtu_prints_nothing(tmp_path, capfd):
    scene = tmp_path / "s.toml"
    scene.write_text(textwrap.dedent(FEM_VTU))
    out = tmp_path / "out"
    assert cli.main(["run", str(scene), "--quiet", "--out", str(out)]) == 0
    captured = capfd.readouterr()
    assert captured.out == "" and captured.err == "", captured
    assert (out / "p0_fem.vtu").exists()


def test_save_vtu_writes_3d_points_without_a_warning(tmp_path, capfd):
    import meshio
    sol = solution("fem")
    for ext in ("vtu", "vtk", "xdmf", "msh"):
        sol.save_vtu(tmp_path / f"p.{ext}")
        assert capfd.readouterr().err == "", ext
        m = meshio.read(tmp_path / f"p.{ext}")
        assert m.points.shape[1] == 3 and np.all(m.points[:, 2] == 0.0), ext
        assert np.allclose(m.point_data["p"], sol.dofs[sol.basis.nodal_dofs[0]]), ext


# -- no scene message starts with "None:" -------------------------------------------------
BASE = {"system": dict(a=1.0, b=0.2, c=0.025, D1=0.01), "study": dict(methods=["averaging"])}
WALLS_BAD = [
    (dict(left=dict(position=-0.6, r=2.0), right=dict(position=0.6, r=0.5)),
     "barriers.left.r must be a finite number in [0, 1]; got 2.0"),
    (dict(right=dict(position="x", r=0.5)), "barriers.right.position must be a finite number"),
    (dict(right=dict(position=0.6, r="x")), "barriers.right.r must be"),
]


@pytest.mark.parametrize("barriers, start", WALLS_BAD, ids=["left.r", "right.position", "right.r"])
def test_wall_table_errors_start_with_the_key_not_none(barriers, start):
    with pytest.raises(SceneError) as exc:
        check_scene(parse_scene({**BASE, "barriers": barriers}, base=Path(".")))
    msg = str(exc.value)
    assert msg.startswith(start) and "None" not in msg and "\n" not in msg, msg


def test_wall_error_of_the_model_keeps_its_place():
    with pytest.raises(InputError) as exc:
        VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, left={"position": -0.6, "r": 2.0})
    assert str(exc.value).startswith("VibroImpactSystem: left.r must be"), str(exc.value)
