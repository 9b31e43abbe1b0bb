"""`check` is a promise: every generated scene that it accepts also runs (reduced)
without error; what it refuses is refused with one line naming a key."""
import json

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import SceneError, check_scene, parse_scene


@st.composite
def scenes(draw):
    sides = draw(st.sampled_from(["both", "both", "right", "none"]))
    system = {"a": draw(st.sampled_from([-1.0, 0.0, 0.5, 1.0, 2.0])),
              "b": draw(st.sampled_from([-0.3, 0.0, 0.2, 1.0])),
              "c": draw(st.sampled_from([0.0, 0.02, 0.1, 0.3])),
              "D1": draw(st.sampled_from([0.005, 0.02, 0.05])),
              "D2": draw(st.sampled_from([0.0, 0.0, 0.02]))}
    barriers = {"sides": sides, "r": draw(st.sampled_from([0.0, 0.3, 0.8, 1.0]))}
    if sides != "none":
        barriers["delta"] = draw(st.sampled_from([0.3, 0.8, 2.0]))
    methods = draw(st.lists(st.sampled_from(["averaging", "fem", "montecarlo"] * 3 + ["exact"]),
                            min_size=1, max_size=3, unique=True))
    study = {"methods": methods,
             "quantities": draw(st.lists(st.sampled_from(["energy", "x", "y", "joint",
                                                          "moments"]),
                                         min_size=1, max_size=3, unique=True))}
    scene = {"system": system, "barriers": barriers, "study": study,
             "output": {"formats": ["json", "npz"]}}
    if draw(st.booleans()):
        study["times"] = draw(st.sampled_from([[0.5], [0.5, 2.0]]))
        scene["initial"] = {"mean": [0.0, draw(st.sampled_from([0.0, 0.3]))],
                            "std": [draw(st.sampled_from([0.0, 0.1])), 0.1]}
    if "fem" in methods:
        fem = {"nx": draw(st.sampled_from([8, 12])), "ny": 16,
               "degree": draw(st.sampled_from([1, 2]))}
        if fem["degree"] == 1 and draw(st.booleans()):
            fem["positivity"] = True
            if "times" in study:
                fem["scheme"] = "euler"
        scene["fem"] = fem
    if "montecarlo" in methods:
        mc = {"n_paths": 64, "seed": draw(st.integers(0, 2 ** 63 - 1))}
        if "times" not in study:
            mc["t_sample"] = 20.0
            mc["t_burn"] = 10.0
        scene["montecarlo"] = mc
    if draw(st.booleans()):
        scene["sweep"] = {"r": [0.5, 0.9]}
    return scene


@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=scenes())
def test_a_scene_that_check_accepts_runs(tmp_path_factory, data):
    try:
        scene = parse_scene(data)
        check_scene(scene)
    except SceneError as exc:
        msg = str(exc)
        assert "\n" not in msg and exc.name, msg
        return
    out = tmp_path_factory.mktemp("run")
    doc = run_scene(scene.reduced(), out=out, workers=1, log=lambda s: None)
    for point in doc["points"]:
        assert "error" not in point, (data, point.get("error"))
        for method, entry in point["methods"].items():
            for rec in entry.get("at", [entry]):
                assert all(v == v for v in rec["moments"].values()), (data, method)
    assert json.loads((out / "results.json").read_text())["points"]
