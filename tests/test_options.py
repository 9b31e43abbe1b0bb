"""Each option is declared once: the solvers' keywords, the scene schema and the table
of scene keys (docs/guide/keys.md) all come from the same declaration, and agree on
name, default and range."""
import dataclasses
import inspect
import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fpk_vibro.forcing import FORCING_KEYS
from fpk_vibro.noise import EXTERNAL_KEYS
from fpk_vibro import VibroImpactSystem, averaging, fem, montecarlo
from fpk_vibro._checks import InputError
from fpk_vibro.app.cli import build_parser
from fpk_vibro.model import FIELDS
from fpk_vibro.options import REQUIRED
from fpk_vibro.app.scenes import SCHEMA, STUDY_KEYS, schema_table

SOLVERS = [(averaging, "stationary"), (averaging, "transient"), (fem, "stationary"),
           (fem, "transient"), (montecarlo, "stationary"), (montecarlo, "transient")]
NOT_OPTIONS = {"system", "initial", "times"}       # the model, [initial], study.times
IDS = [f"{m.__name__.split('.')[-1]}.{mode}" for m, mode in SOLVERS]


def _cli_flags() -> set[str]:
    flags = set()
    for action in build_parser()._subparsers._group_actions[0].choices["run"]._actions:
        flags.update(action.option_strings)
    return flags


def _scene_key_exists(pointer: str) -> bool:
    if pointer.startswith("cli "):
        return pointer[4:] in _cli_flags()
    keys = re.findall(r"\b(\w+)\.(\w+)\b", pointer)
    return bool(keys) and all(t in SCHEMA and k in SCHEMA[t] for t, k in keys)


@pytest.mark.parametrize("module, mode", SOLVERS, ids=IDS)
def test_every_keyword_is_declared_and_reachable_from_a_scene(module, mode):
    func = getattr(module, mode)
    declared = module.Options.declared()
    table = SCHEMA[module.Options.WHERE]
    params = {n: p for n, p in inspect.signature(func).parameters.items() if n not in NOT_OPTIONS}
    for name, param in params.items():
        assert param.kind is inspect.Parameter.KEYWORD_ONLY, name
        assert name in declared, f"{func.__module__}.{mode}: keyword {name!r} not declared"
        opt = declared[name]
        assert mode in opt.modes, f"{name!r} is a keyword of {mode} but not declared for it"
        assert param.default == opt.default_for(mode), (
            f"{mode}({name}={param.default!r}) but the declaration says "
            f"{opt.default_for(mode)!r}")
        if opt.scene in ("", "file"):
            assert table.get(name) is opt, f"{name!r} missing from the scene's [{module.Options.WHERE}]"
        else:
            assert _scene_key_exists(opt.scene), f"{name!r}: {opt.scene!r} is no scene key or flag"
    for name, opt in declared.items():     # no stale declaration
        if mode in opt.modes:
            assert name in params, f"{name!r} declared for {mode} but not a keyword of it"


def test_the_model_fields_are_the_scene_keys():
    fields = {f.name: f for f in dataclasses.fields(VibroImpactSystem)}
    assert set(fields) == set(FIELDS)
    for name, opt in FIELDS.items():
        table, _, key = opt.scene.partition(".")
        if key:
            assert SCHEMA[table][key] is opt
        else:                  # a field that is a whole table: [forcing], [external]
            assert tuple(SCHEMA[table]) == {"forcing": FORCING_KEYS,
                                            "external": EXTERNAL_KEYS}[table]
        default = fields[name].default
        if opt.default is REQUIRED:
            assert default is dataclasses.MISSING
        else:
            assert default == opt.default


def _edge_values(opt):
    """Values at and just beyond each end of a numeric range."""
    vals = []
    for end, open_, step in ((opt.lo, opt.lo_open, -1), (opt.hi, opt.hi_open, +1)):
        if math.isinf(end):
            continue
        if opt.kind == "int":
            vals += [(int(end), True), (int(end) + step, False)]
        else:
            vals += [(end, not open_), (end * (1 + 1e-9 * step) + 1e-300 * step, False)]
    return vals


NUMERIC = [(m, mode, name, opt) for m, mode in SOLVERS
           for name, opt in m.Options.for_mode(mode).items() if opt.kind in ("int", "float")]


@pytest.mark.parametrize("module, mode, name, opt", NUMERIC,
                         ids=[f"{m.Options.WHERE}.{mode}.{n}" for m, mode, n, _ in NUMERIC])
def test_same_range_in_the_api_and_in_scenes(module, mode, name, opt):
    for value, ok in _edge_values(opt):
        if opt.even and isinstance(value, int) and value % 2:
            ok = False
        outcomes = []
        for call in (lambda: module.Options.from_call(mode, {name: value}),
                     lambda: module.Options.from_scene(mode, {name: value})):
            try:
                call()
                outcomes.append(True)
            except InputError as exc:
                assert name in str(exc) and "\n" not in str(exc)
                outcomes.append(False)
        assert outcomes == [ok, ok], (name, value)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(NUMERIC), st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(min_value=-10 ** 500,
                                                                max_value=10 ** 500),
    st.text(max_size=5), st.booleans(), st.none(), st.lists(st.integers(), max_size=2)))
def test_any_value_is_accepted_inside_the_range_or_named_in_one_line(case, value):
    module, mode, name, opt = case
    try:
        got = module.Options.from_call(mode, {name: value})
    except InputError as exc:
        msg = str(exc)
        assert f"{module.Options.WHERE}.{mode}: {name} must be" in msg and "\n" not in msg
        assert len(msg) < 400
        return
    v = getattr(got, name)
    if value is None:                  # "auto": kept, or resolved when the Options is made
        assert opt.nullable
        return
    assert not isinstance(value, bool) and math.isfinite(v)
    assert (v > opt.lo if opt.lo_open else v >= opt.lo) and (v < opt.hi if opt.hi_open else v <= opt.hi)
    if opt.kind == "int":
        assert isinstance(v, int) and v == value


def test_the_keys_page_is_the_generated_table():
    """The table of scene keys is on docs/guide/keys.md (it was in the README), pasted
    there from `fpk-vibro keys` when the site is built: never stale, held once."""
    import runpy
    root = Path(__file__).parent.parent
    conf = runpy.run_path(str(root / "docs" / "conf.py"))
    source = [(root / "docs" / "guide" / "keys.md").read_text(encoding="utf-8")]
    conf["_generated"](None, "guide/keys", source)
    assert schema_table() in source[0]
    for path in [root / "README.md", *sorted((root / "docs").rglob("*.md"))]:
        if "_build" not in path.parts:
            assert "| `system.a` |" not in path.read_text(encoding="utf-8"), path


def test_every_table_of_the_schema_is_documented():
    table = schema_table()
    for t, keys in SCHEMA.items():
        for k in keys:
            assert f"`{t}.{k}`" in table
    assert set(STUDY_KEYS) <= set(SCHEMA)


def test_reduced_sizes_come_from_the_declarations():
    from fpk_vibro.app.scenes import parse_scene
    scene = parse_scene({"system": dict(a=1, b=0.2, c=0.025, D1=0.01),
                         "barriers": dict(delta=0.6, r=0.9),
                         "study": dict(methods=["fem", "montecarlo", "averaging"]),
                         "fem": dict(nx=200, ny=400), "montecarlo": dict(n_paths=10_000)})
    red = scene.reduced().numerics
    assert red["fem"]["nx"] == fem.Options.declared()["nx"].reduced
    assert red["fem"]["ny"] == fem.Options.declared()["ny"].reduced
    assert red["montecarlo"]["n_paths"] == montecarlo.Options.declared()["n_paths"].reduced
    assert red["montecarlo"]["t_sample"] == montecarlo.Options.declared()["t_sample"].reduced


def test_a_reduced_run_with_rtol_lets_rtol_choose_the_grid():
    """--reduced with [fem] rtol: no nx/ny caps that the rtol rule would refuse."""
    from fpk_vibro import fem
    out = fem.Options.reduce("stationary", {"rtol": 1e-3})
    assert out["rtol"] == 1e-3 and "nx" not in out and "ny" not in out
    fem.Options.from_call("stationary", out)          # accepted as it stands
    assert fem.Options.reduce("stationary", {})["nx"] == 24
