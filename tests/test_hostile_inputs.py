"""Malformed input of every kind ends in one line naming the argument or key, before any
work: solver keywords (generated from the declarations), the model, initial conditions,
output times, scenes (every case found by trying the package as a new user) and the
command line (exit status 2, no traceback, nothing written)."""
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, averaging, exact, fem, montecarlo
from fpk_vibro.app import cli
from fpk_vibro.app.scenes import SceneError, check_scene, parse_scene
from conftest import paper_tables

PAPER = VibroImpactSystem.paper(r=0.92)
INIT = {"mean": (0.0, 1.0), "std": (0.05, 0.05)}
SOLVERS = [(averaging, "stationary"), (averaging, "transient"), (fem, "stationary"),
           (fem, "transient"), (montecarlo, "stationary"), (montecarlo, "transient")]
HUGE = 10 ** 400

CUSTOM_BAD = {
    "mesh": [3, "", ["a.msh"]],
    "positivity": ["sometimes", 2, None],
    "discretisation": ["x", 3],
    "seed": [-1, 2.5, "s", HUGE, 2 ** 63],
    "quantities": [["zz"], 5, ["x", "x"], [1]],
    "bins": [1, HUGE, "x", {"zz": 3}, {"energy": [1.0, 1.0]}, {"energy": [0.0, 1.0, 3.0]},
             {"joint": [3]}, True],
}


def _bad_values(name, opt):
    if opt.kind == "int":
        vals = ["3", 2.5, True, HUGE, float("nan"), int(opt.lo) - 1]
        if math.isfinite(opt.hi):
            vals.append(int(opt.hi) + 1)
        if opt.even:
            vals.append(int(opt.lo) + 1)
    elif opt.kind == "float":
        vals = ["x", float("nan"), float("inf"), -float("inf"), HUGE, True]
        if math.isfinite(opt.lo):
            vals.append(opt.lo - 1.0)
        if math.isfinite(opt.hi):
            vals.append(opt.hi * 2 + 1.0)
    elif opt.kind == "choice":
        vals = ["nonsense", 3] + ([] if opt.nullable else [None])
    elif opt.kind == "bool":
        vals = ["yes", 1]
    else:
        vals = CUSTOM_BAD[name]
    return vals


CASES = [(m, mode, name, v) for m, mode in SOLVERS
         for name, opt in m.Options.for_mode(mode).items() for v in _bad_values(name, opt)]


def _call(module, mode, system=PAPER, **kw):
    func = getattr(module, mode)
    if mode == "transient":
        kw = {"initial": INIT, "times": [1.0], **kw}
    return func(system, **kw)


def _one_line(exc, *words):
    msg = str(exc.value)
    assert "\n" not in msg and len(msg) < 500, msg
    for w in words:
        assert w in msg, (w, msg)


@pytest.mark.parametrize("module, mode, name, value", CASES,
                         ids=[f"{m.Options.WHERE}.{mode}.{n}={v!r:.20}" for m, mode, n, v in CASES])
def test_bad_keyword_is_one_line_naming_it(module, mode, name, value):
    with pytest.raises(ValueError) as exc:
        _call(module, mode, **{name: value})
    _one_line(exc, name)


def test_there_are_enough_hostile_cases():
    assert len(CASES) >= 150


SYSTEMS_BAD = [None, "paper", 3, {"a": 1}]


@pytest.mark.parametrize("system", SYSTEMS_BAD, ids=repr)
@pytest.mark.parametrize("module, mode", SOLVERS + [(exact, "gibbs")],
                         ids=lambda v: getattr(v, "__name__", v))
def test_not_a_system(module, mode, system):
    with pytest.raises(ValueError) as exc:
        _call(module, mode, system=system)
    _one_line(exc, "system")


MODEL_BAD = [dict(a=HUGE), dict(a="1"), dict(b=float("nan")), dict(c=-1.0), dict(c=True),
             dict(D1=0.0), dict(D1=-HUGE), dict(D2=float("inf")), dict(r=1.5), dict(r=-0.1),
             dict(delta=0.0), dict(delta=None), dict(delta="0.6"), dict(barriers="above"),
             dict(barriers=None), dict(b=-0.2, barriers="right"), dict(b=-0.2, barriers="left"),
             dict(c=0.0, r=1.0)]


@pytest.mark.parametrize("kw", MODEL_BAD, ids=repr)
def test_bad_model_field(kw):
    with pytest.raises(ValueError) as exc:
        VibroImpactSystem.paper(**kw)
    _one_line(exc, "VibroImpactSystem:", next(iter(kw)) if next(iter(kw)) != "barriers" or
              kw["barriers"] in ("above", None) else "b")


def _strings(n, rng):
    return np.array([["a", "b"]] * n)


INITIAL_BAD = [{"mean": (0.0,), "std": (0.0, 0.0)}, "x", {"mean": (0, 1), "std": (-1, 0)},
               {"mean": (5.0, 0.0), "std": (0.0, 0.0)}, {"mean": (0, 1)},
               {"mean": (HUGE, 0), "std": (0, 0)}, {"mean": (0, 1), "std": (0, 0), "z": 1}]


@pytest.mark.parametrize("initial", INITIAL_BAD, ids=repr)
@pytest.mark.parametrize("module", [averaging, fem, montecarlo], ids=lambda m: m.__name__)
def test_bad_initial(module, initial):
    with pytest.raises(ValueError) as exc:
        module.transient(PAPER, initial=initial, times=[1.0])
    _one_line(exc, "initial")


def test_a_sampler_returning_strings_is_named():
    with pytest.raises(ValueError) as exc:
        montecarlo.transient(PAPER, initial=_strings, times=[1.0], n_paths=64)
    _one_line(exc, "initial(n, rng)")


TIMES_BAD = [[], [-1.0], [float("nan")], "x", [HUGE], [[1.0, 2.0], [3.0]]]


@pytest.mark.parametrize("times", TIMES_BAD, ids=repr)
@pytest.mark.parametrize("module", [averaging, fem, montecarlo], ids=lambda m: m.__name__)
def test_bad_times(module, times):
    with pytest.raises(ValueError) as exc:
        module.transient(PAPER, initial=INIT, times=times)
    _one_line(exc, "times")


@pytest.mark.parametrize("module", [fem, montecarlo], ids=lambda m: m.__name__)
def test_unsorted_times(module):
    with pytest.raises(ValueError) as exc:
        module.transient(PAPER, initial=INIT, times=[2.0, 1.0])
    _one_line(exc, "times", "increasing")


# -- work beyond the machine is refused before any allocation ----------------------------
BEYOND = [(fem, "stationary", dict(nx=100_000), "nx"),
          (fem, "stationary", dict(nx=2000, ny=200_000), "nx"),
          (montecarlo, "stationary", dict(t_sample=1e12), "t_sample"),
          (montecarlo, "stationary", dict(bins=100_000), "bins"),
          (montecarlo, "stationary", dict(n_paths=10 ** 9, t_sample=1e4), "n_paths"),
          (montecarlo, "transient", dict(times=[1e12]), "times"),
          (fem, "transient", dict(times=[1e12]), "times")]


@pytest.mark.parametrize("module, mode, kw, key", BEYOND, ids=lambda v: repr(v)[:30])
def test_work_beyond_the_machine_is_refused(module, mode, kw, key):
    with pytest.raises(ValueError) as exc:
        _call(module, mode, **kw)
    _one_line(exc, key, "estimated", "limit", "--force")


def test_save_vtu_with_an_unknown_extension(tmp_path):
    sol = fem.stationary(PAPER, nx=4, ny=8)
    with pytest.raises(ValueError) as exc:
        sol.save_vtu(tmp_path / "x.foo")
    _one_line(exc, "path", ".vtu")
    assert not list(tmp_path.iterdir())


# -- scenes -----------------------------------------------------------------------------
BASE = {"system": dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01),
        "barriers": dict(delta=0.6, r=0.92), "study": dict(methods=["fem"])}
TRANSIENT = {"study": dict(methods=["fem"], times=[1.0, 2.0]),
             "initial": dict(mean=[0.0, 1.0], std=[0.05, 0.05])}
MESHES = Path(__file__).parent.parent / "meshes"


def _scene(**tables):
    out = {k: dict(v) for k, v in BASE.items()}
    for k, v in tables.items():
        out[k] = v
    return out


SCENES_BAD = [
    ("unsorted times", _scene(**{**TRANSIENT, "study": dict(methods=["fem"], times=[2.0, 1.0])}),
     "study.times"),
    ("missing mesh file", _scene(fem=dict(mesh="nope.msh")), "fem.mesh"),
    ("mesh of another strip", _scene(fem=dict(mesh=str(MESHES / "paper_d1.0_quad_40x96.msh"))),
     "fem.mesh"),
    ("foreign file as mesh", _scene(fem=dict(mesh="/etc/passwd")), "fem.mesh"),
    ("mesh is a directory", _scene(fem=dict(mesh=str(MESHES))), "fem.mesh"),
    ("mesh with nx", _scene(fem=dict(mesh=str(MESHES / "paper_d0.6_quad_32x96.msh"), nx=8)),
     "fem.nx"),
    ("odd ny", _scene(fem=dict(ny=33)), "fem.ny"),
    ("MC dt too large", _scene(study=dict(methods=["montecarlo"]), montecarlo=dict(dt=10.0)),
     "montecarlo.dt"),
    ("averaging on a double well", _scene(system=dict(a=-1.0, b=1.0, c=0.1, D1=0.05),
                                          barriers=dict(delta=2.0, r=0.9),
                                          study=dict(methods=["averaging"])), "study.methods"),
    ("tiny y_max", _scene(fem=dict(y_max=1e-9)), "fem.y_max"),
    ("nx beyond memory", _scene(fem=dict(nx=100_000)), "fem.nx"),
    ("n_cells out of range", _scene(**{**TRANSIENT, "study": dict(methods=["averaging"],
                                                                  times=[1.0])},
                                    averaging=dict(n_cells=200_000)), "averaging.n_cells"),
    ("t_sample forever", _scene(study=dict(methods=["montecarlo"]),
                                montecarlo=dict(t_sample=1e12)), "montecarlo.t_sample"),
    ("times forever", _scene(**{**TRANSIENT, "study": dict(methods=["montecarlo"],
                                                           times=[1e12])}), "study.times"),
    ("fem times forever", _scene(**{**TRANSIENT, "study": dict(methods=["fem"], times=[1e12])}),
     "study.times"),
    ("400-digit integer", _scene(fem=dict(nx=HUGE)), "fem.nx"),
    ("400-digit parameter", _scene(system=dict(a=HUGE, b=0.2, c=0.025, D1=0.01)), "system.a"),
    ("stationary-only key in a transient", _scene(**TRANSIENT, fem=dict(solver="direct")),
     "fem.solver"),
    ("transient-only key stationary", _scene(fem=dict(dt=0.1)), "fem.dt"),
    ("progress is not a scene key", _scene(montecarlo=dict(progress=True)), "montecarlo.progress"),
    ("bins table with unknown quantity", _scene(montecarlo=dict(bins={"zz": 3})),
     "montecarlo.bins"),
    ("positivity string unknown", _scene(fem=dict(positivity="maybe")), "fem.positivity"),
    ("positivity with Q2", _scene(fem=dict(positivity=True, degree=2)), "fem.positivity"),
    ("seed negative", _scene(montecarlo=dict(seed=-5)), "montecarlo.seed"),
    ("c = 0 without y_max", _scene(system=dict(a=1.0, b=0.2, c=0.0, D1=0.01),
                                   barriers=dict(delta=0.6, r=0.5)), "fem.y_max"),
    ("sweep point invalid", _scene(sweep=dict(r=[0.5, 1.5])), "sweep.r"),
    ("sweep of a double well for averaging", _scene(study=dict(methods=["averaging"]),
                                                    sweep=dict(a=[1.0, -1.0])), "study.methods"),
    ("initial outside the strip", _scene(**{**TRANSIENT,
                                            "initial": dict(mean=[3.0, 0.0], std=[0.0, 0.0])}),
     "initial.mean"),
    ("name not a string", _scene(study=dict(methods=["fem"], name=3)), "study.name"),
    ("formats unknown", _scene(output=dict(formats=["pdf"])), "output.formats"),
    ("a scene that is a list", [1, 2], "scene"),
]


@pytest.mark.parametrize("label, data, key", SCENES_BAD, ids=[c[0] for c in SCENES_BAD])
def test_bad_scene_is_one_line_naming_the_key(label, data, key):
    with pytest.raises(SceneError) as exc:
        check_scene(parse_scene(data, base=Path(".")))
    _one_line(exc, key)


def test_a_huge_sweep_is_refused_without_expanding_it():
    data = _scene(sweep=dict(r=list(np.linspace(0, 1, 3000)), c=list(np.linspace(0.01, 1, 3000))))
    with pytest.raises(SceneError) as exc:
        parse_scene(data)
    _one_line(exc, "sweep", "9000000 points", "limit")


def test_force_lifts_the_limits():
    from fpk_vibro import budget
    data = _scene(sweep=dict(r=list(np.linspace(0.1, 1, 101)), c=list(np.linspace(0.01, 1, 101))))
    old = budget.MAX_POINTS
    try:
        budget.MAX_POINTS = 10_000
        with pytest.raises(SceneError):
            parse_scene(data)
        with budget.unlimited():
            assert parse_scene(data).n_points == 101 * 101
    finally:
        budget.MAX_POINTS = old


# -- the command line -------------------------------------------------------------------
GOOD = paper_tables(D2=None) + """
[study]
methods = ["averaging"]
quantities = ["moments"]
"""


def _write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def _cli_cases(tmp_path):
    scene = _write(tmp_path, GOOD)
    bad_toml = _write(tmp_path, GOOD + "\n[study\n", "bad.toml")
    binary = tmp_path / "bin.toml"
    binary.write_bytes(b"\xff\xfe\x00" * 100)
    results = tmp_path / "res"
    results.mkdir()
    (results / "results.json").write_text('{"points": [{"parameters": 3}]}')
    empty = tmp_path / "empty"
    empty.mkdir()
    big_mc = _write(tmp_path, GOOD.replace('["averaging"]', '["montecarlo"]')
                    + "\n[montecarlo]\nt_sample = 1e12\n", "big.toml")
    out = str(tmp_path / "out")
    return [
        (["run", str(scene), "--workers", "0", "--out", out], "--workers"),
        (["run", str(scene), "--workers", "-3", "--out", out], "--workers"),
        (["run", str(scene), "--workers", "x", "--out", out], "--workers"),
        (["run", str(scene), "--frobnicate"], "--frobnicate"),
        (["run"], "scene"),
        (["run", str(tmp_path / "nope.toml"), "--out", out], "nope.toml"),
        (["run", str(tmp_path), "--out", out], str(tmp_path)),
        (["run", str(bad_toml), "--out", out], "TOML"),
        (["run", str(binary), "--out", out], "bin.toml"),
        (["run", str(big_mc), "--out", out], "montecarlo.t_sample"),
        (["check", str(big_mc)], "montecarlo.t_sample"),
        (["check", str(bad_toml)], "TOML"),
        (["show", str(empty)], "results.json"),
        (["show", str(results)], "results.json"),
        (["bench", "nothing"], "nothing"),
        (["study", "nothing", str(scene)], "nothing"),
        ([], "command"),
        (["paper", "--out"], "--out"),
    ]


def test_cli_errors_are_one_line_with_status_2_and_write_nothing(tmp_path, capsys):
    cases = _cli_cases(tmp_path)
    for argv, word in cases:
        try:
            status = cli.main(argv)
        except SystemExit as exc:
            status = exc.code
        err = capsys.readouterr().err
        assert status == 2, (argv, status, err)
        assert err.count("\n") == 1 and word in err and "Traceback" not in err, (argv, err)
        assert not (tmp_path / "out").exists()


def test_cli_error_in_a_fresh_process(tmp_path):
    scene = _write(tmp_path, GOOD.replace("r = 0.92", "r = 2"))
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "check", str(scene)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "barriers.r" in r.stderr
