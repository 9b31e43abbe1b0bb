"""The model with walls anywhere: Wall, the two ways to give walls, and hostile input."""
import math

import pytest

from fpk_vibro import VibroImpactSystem, Wall, exact
from fpk_vibro._checks import InputError
from fpk_vibro.app.scenes import parse_scene

BASE = dict(a=1.0, b=0.2, c=0.025, D1=0.01)


def test_shorthand_builds_the_walls_and_walls_give_back_the_shorthand():
    s = VibroImpactSystem(**BASE, delta=0.6, r=0.9)
    assert (s.left, s.right) == (Wall(-0.6, 0.9), Wall(0.6, 0.9)) and s.symmetric
    w = VibroImpactSystem(**BASE, left=Wall(-0.6, 0.9), right=Wall(0.6, 0.9))
    assert w == s and (w.delta, w.r, w.barriers) == (0.6, 0.9, "both")
    one = VibroImpactSystem(**BASE, delta=0.6, r=0.9, barriers="right")
    assert one.left is None and one.right == Wall(0.6, 0.9)
    left = VibroImpactSystem(**BASE, delta=0.6, r=0.9, barriers="left")
    assert left.left == Wall(-0.6, 0.9) and left.right is None and left.x_bounds == (-0.6, math.inf)
    none = VibroImpactSystem(**BASE, barriers="none")
    assert none.walls == () and not none.has_barrier and none.x_bounds == (-math.inf, math.inf)


def test_asymmetric_walls_describe_themselves():
    s = VibroImpactSystem(**BASE, left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95))
    assert s.x_bounds == (-0.4, 0.8) and not s.symmetric
    assert (s.delta, s.r, s.barriers) == (None, None, "both")
    assert s.barrier_energy == pytest.approx(s.potential(-0.4))       # the lower wall
    assert s.effects[-2:] == ["impact_right", "impact_left"]
    same_r = VibroImpactSystem(**BASE, left=Wall(-0.4, 0.7), right=Wall(0.8, 0.7))
    assert same_r.r == 0.7 and same_r.delta is None


@pytest.mark.parametrize("system", [
    VibroImpactSystem(**BASE, left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95)),
    VibroImpactSystem(**BASE, right=Wall(-0.1, r=0.8)),
    VibroImpactSystem.paper(r=0.92),
    VibroImpactSystem(**BASE, barriers="none"),
], ids=["asym", "preload", "paper", "none"])
def test_dict_and_file_round_trip(system, tmp_path):
    assert VibroImpactSystem.from_dict(system.to_dict()) == system
    old = {k: v for k, v in VibroImpactSystem.paper(r=0.92).to_dict().items()
           if k not in ("left", "right")}                     # a file written before walls
    assert VibroImpactSystem.from_dict(old) == VibroImpactSystem.paper(r=0.92)


def test_replace():
    s = VibroImpactSystem.paper(r=0.92)
    assert s.replace(delta=1.0).right == Wall(1.0, 0.92)            # shorthand rebuilds walls
    t = s.replace(**{"left.r": 0.5})
    assert t.left == Wall(-0.6, 0.5) and t.right == Wall(0.6, 0.92) and t.r is None
    u = t.replace(right=Wall(1.0, 1.0))
    assert u.left == t.left and u.right == Wall(1.0, 1.0)
    assert t.replace(D1=0.02).left == t.left                          # other fields keep walls
    assert VibroImpactSystem.paper(r=0.9, right=Wall(0.7)).left is None


@pytest.mark.parametrize("kwargs, name, words", [
    (dict(left=Wall(0.5), right=Wall(0.2)), "left", "left of the right wall"),
    (dict(left=Wall(0.3), right=Wall(0.3)), "left", "empty"),
    (dict(right=Wall(0.5), delta=0.3), "delta", "not both"),
    (dict(right=Wall(0.5, 0.9), r=0.5), "r", "not both"),
    (dict(right="0.5"), "right", "a Wall"),
    (dict(left={"position": 0.1, "e": 1}), "left", "unknown keys"),
    (dict(left={"r": 0.5}), "left", "position is required"),
    (dict(left={"position": float("nan")}), "left", "finite"),
    (dict(right={"position": 0.4, "r": 1.5}), "right", "[0, 1]"),
    (dict(right=Wall(0.5), b=-0.1), "b", "no left wall"),
    (dict(left=Wall(-0.5), right=Wall(0.5), c=0.0), "c", "no other energy loss"),
])
def test_bad_walls_are_one_line_naming_the_field(kwargs, name, words):
    with pytest.raises(InputError) as exc:
        VibroImpactSystem(**{**BASE, **kwargs})
    msg = str(exc.value)
    assert exc.value.name == name and words in msg and "\n" not in msg, msg


@pytest.mark.parametrize("value", [float("inf"), "x", None, True, [0.1]])
def test_bad_wall_values(value):
    with pytest.raises(InputError) as exc:
        Wall(value)
    assert "position" in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(InputError):
        Wall(0.1, r=value)


def test_scene_walls_and_sweeps():
    data = {"system": dict(BASE), "barriers": {"left": {"position": -0.4, "r": 0.7},
                                               "right": {"position": 0.8}},
            "study": {"methods": ["fem"]}, "sweep": {"right": {"r": [0.9, 0.95]}}}
    scene = parse_scene(data)
    systems = [s for _, s in scene.points()]
    assert [s.right for s in systems] == [Wall(0.8, 0.9), Wall(0.8, 0.95)]
    assert all(s.left == Wall(-0.4, 0.7) for s in systems)


def test_exact_gibbs_needs_elastic_walls_only():
    s = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, left=Wall(-0.4), right=Wall(0.8))
    assert exact.gibbs(s).moments()["E_H"] > 0
    with pytest.raises(ValueError):
        exact.gibbs(s.replace(**{"left.r": 0.9}))
