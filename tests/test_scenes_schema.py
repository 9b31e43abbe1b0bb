"""Scene validation: every malformed scene is one clear line naming the key, before work."""
import textwrap

import pytest

from fpk_vibro.app.scenes import SceneError, check_scene, load_scene, parse_scene, schema_table
from conftest import paper_tables

GOOD = paper_tables() + """
[study]
methods = ["averaging"]
quantities = ["energy", "moments"]
"""


def write(tmp_path, text):
    p = tmp_path / "scene.toml"
    p.write_text(textwrap.dedent(text))
    return p


def test_good_scene(tmp_path):
    s = load_scene(write(tmp_path, GOOD))
    assert s.system.r == 0.92 and s.methods == ("averaging",) and not s.transient
    assert s.points() == [({}, s.system)]
    assert s.name == "scene"


def test_sweep_points(tmp_path):
    s = load_scene(write(tmp_path, GOOD + "\n[sweep]\nr = [0.98, 0.92]\nD1 = [0.01, 0.02, 0.03]\n"))
    pts = s.points()
    assert len(pts) == 6 and pts[-1][1].D1 == 0.03 and pts[-1][1].r == 0.92


BAD = [
    ("typo in table", GOOD + "\n[sytem]\na = 1\n", "sytem", "system"),
    ("typo in key", GOOD.replace("D2 = 0.01", "D22 = 0.01"), "system.D22", "D2"),
    ("typo in study key", GOOD.replace("methods =", "method ="), "study.method", "methods"),
    ("unknown method", GOOD.replace('["averaging"]', '["averagin"]'), "study.methods", "averaging"),
    ("unknown quantity", GOOD.replace('"moments"]', '"moment"]'), "study.quantities", "moments"),
    ("methods not a list", GOOD.replace('["averaging"]', '"averaging"'), "study.methods", "list"),
    ("empty methods", GOOD.replace('["averaging"]', "[]"), "study.methods", "empty"),
    ("string number", GOOD.replace("c = 0.025", 'c = "0.025"'), "system.c", "number"),
    ("bool number", GOOD.replace("c = 0.025", "c = true"), "system.c", "number"),
    ("negative damping", GOOD.replace("c = 0.025", "c = -1.0"), "system.c", ">= 0"),
    ("zero D1", GOOD.replace("D1 = 0.01", "D1 = 0.0"), "system.D1", "D1"),
    ("r above 1", GOOD.replace("r = 0.92", "r = 1.2"), "barriers.r", "[0, 1]"),
    ("negative delta", GOOD.replace("delta = 0.6", "delta = -0.6"), "barriers.delta", "delta"),
    ("missing a", GOOD.replace("a = 1.0\n", ""), "system.a", "missing"),
    ("missing delta", GOOD.replace("delta = 0.6\n", ""), "barriers.delta", "missing"),
    ("unknown sides", GOOD.replace("r = 0.92", 'r = 0.92\nsides = "above"'), "barriers.sides", "both"),
    ("walls crossed", GOOD.replace("r = 0.92", "r = 0.92\n[barriers.left]\nposition = 0.7\n"
                                  "[barriers.right]\nposition = 0.5")
     .replace("delta = 0.6\n", "").replace("r = 0.92\n", ""), "barriers.left", "left of"),
    ("wall r out of range", GOOD.replace("r = 0.92", "[barriers.right]\nposition = 0.5\nr = 1.5")
     .replace("delta = 0.6\n", ""), "barriers.right", "[0, 1]"),
    ("wall without position", GOOD.replace("r = 0.92", "[barriers.right]\nr = 0.5")
     .replace("delta = 0.6\n", ""), "barriers.right", "position"),
    ("wall unknown key", GOOD.replace("r = 0.92", "[barriers.right]\nposition = 0.5\nrr = 0.5")
     .replace("delta = 0.6\n", ""), "barriers.right", "rr"),
    ("walls and shorthand disagree", GOOD.replace("r = 0.92", "r = 0.92\n[barriers.right]\n"
     "position = 0.5"), "barriers.delta", "not both"),
    ("sweep of a missing wall", GOOD.replace("r = 0.92", "r = 0.92\nsides = \"right\"") +
     "\n[sweep]\nleft.r = [0.5]\n", "sweep.left.r", "no left wall"),
    ("missing system", "[barriers]" + GOOD.split("[barriers]")[1], "[system]", "missing"),
    ("missing study", GOOD.split("[study]")[0], "[study]", "missing"),
    ("negative time", GOOD.replace('quantities =', 'times = [1.0, -2.0]\nquantities ='), "study.times[1]", ">="),
    ("transient without initial", GOOD.replace('quantities =', 'times = [1.0]\nquantities ='), "initial.mean", "initial"),
    ("fem degree 5", GOOD + "\n[fem]\ndegree = 5\n", "fem.degree", "[1, 4]"),
    ("fem nx float", GOOD + "\n[fem]\nnx = 10.5\n", "fem.nx", "integer"),
    ("mc paths zero", GOOD + "\n[montecarlo]\nn_paths = 0\n", "montecarlo.n_paths", "[2"),
    ("unknown solver", GOOD + '\n[fem]\nsolver = "lu"\n', "fem.solver", "auto"),
    ("sweep unknown parameter", GOOD + "\n[sweep]\ngamma = [1.0]\n", "sweep.gamma", "allowed"),
    ("sweep invalid value", GOOD + "\n[sweep]\nr = [0.5, 1.5]\n", "sweep.r", "[0, 1]"),
    ("three sweeps", GOOD + "\n[sweep]\nr = [0.5]\nc = [0.1]\nD1 = [0.1]\n", "sweep", "at most two"),
    ("exact with r < 1", GOOD.replace('["averaging"]', '["exact"]'), "study.methods", "exact"),
    ("output format", GOOD + '\n[output]\nformats = ["pdf"]\n', "output.formats", "png"),
    ("table is a value", "fem = 3\n" + GOOD, "fem", "table"),
    ("bad toml", GOOD + "\n[study\n", "TOML", "TOML"),
    ("non-finite", GOOD.replace("c = 0.025", "c = nan"), "system.c", "finite"),
    ("unconfined side", GOOD.replace("b = 0.2", "b = -0.2").replace("r = 0.92", 'r = 0.92\nsides = "right"'),
     "system.b", "confine"),
]


@pytest.mark.parametrize("label, text, key, hint", BAD, ids=[b[0] for b in BAD])
def test_malformed_scene_is_one_line_naming_the_key(tmp_path, label, text, key, hint):
    with pytest.raises(SceneError) as exc:
        check_scene(load_scene(write(tmp_path, text)))
    msg = str(exc.value)
    assert "\n" not in msg
    assert key in msg and hint in msg


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="cannot read"):
        load_scene(tmp_path / "nope.toml")


def test_schema_documented():
    table = schema_table()
    assert "`system.D1`" in table and "`montecarlo.seed`" in table and "`sweep.r`" in table


def test_parse_scene_dict():
    with pytest.raises(SceneError, match="barriers.r"):
        parse_scene({"system": dict(a=1, b=0, c=0.1, D1=0.1), "barriers": dict(delta=1, r=-1),
                     "study": dict(methods=["averaging"])})


def test_positive_transient_needs_implicit_euler():
    base = {"system": dict(a=1, b=0, c=0.1, D1=0.1), "barriers": dict(delta=1, r=0.9),
            "study": dict(methods=["fem"], times=[1.0]),
            "initial": dict(mean=[0.0, 1.0], std=[0.1, 0.1])}
    with pytest.raises(SceneError, match="fem.scheme"):
        check_scene(parse_scene({**base, "fem": dict(positivity=True, scheme="bdf2")}))
    with pytest.raises(SceneError, match="fem.scheme"):
        check_scene(parse_scene({**base, "fem": dict(positivity=True, scheme="theta",
                                                     theta=0.5)}))
    assert check_scene(parse_scene({**base, "fem": dict(positivity=True, scheme="euler")}))


def test_option_of_the_other_mode_is_refused():
    base = {"system": dict(a=1, b=0, c=0.1, D1=0.1), "barriers": dict(delta=1, r=0.9),
            "study": dict(methods=["fem"])}
    with pytest.raises(SceneError, match="fem.scheme: only used by transient"):
        parse_scene({**base, "fem": dict(scheme="euler")})
