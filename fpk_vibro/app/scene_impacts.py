"""The scene keys of impact physics: restitution laws (and sweeps of their
parameters), the safe set of ``[first_passage]`` and the quantities that need walls.

- ``[barriers] r = {law = "tanh", r0, r1, u0}`` or ``r = {speeds = [...], values =
  [...]}`` (and the same in ``[barriers.left]`` / ``[barriers.right]``): a bad law is
  one line naming the key (:func:`check_laws`);
- ``[sweep] "r.r1" = [...]``, ``"left.r.u0" = [...]``: each point builds the law with
  that parameter changed (:func:`point_system`);
- ``[first_passage]`` takes exactly one of ``energy``, ``displacement``,
  ``impact_speed`` (:func:`first_passage_table`), checked per point and method
  (:func:`check_first_passage`): a method that cannot leave that safe set is refused
  naming the methods that can (:func:`fpk_vibro.safe_sets.refuse`).
"""
from __future__ import annotations

from typing import Any

from .._checks import InputError, show
from ..model import VibroImpactSystem
from ..restitution import Restitution
from ..safe_sets import KINDS, SafeSet, parse_safe_set, refuse
from .scene_keys import IMPACT_QUANTITIES, LAW_PARAMETERS, SceneError

__all__ = ["check_laws", "flatten_sweep", "check_law_sweep", "point_system",
           "first_passage_table", "check_first_passage", "safe_set_keyword", "check_walls"]

_LAW_KEYS = {"table": ("speeds", "values"), "tanh": ("r0", "r1", "u0")}


def _law(key: str, data: dict) -> None:
    """The law of the scene table ``data`` at ``key``, or one SceneError naming
    ``key.<parameter>`` (or ``key`` for a rule of the whole law)."""
    law = data.get("law", "table")
    keys = _LAW_KEYS.get(law) if isinstance(law, str) else None
    try:
        if keys is None or set(data) - {"law"} != set(keys):
            Restitution.from_dict(data, None, key)       # its one line names the key
            return
        if law == "table":
            Restitution.table(data["speeds"], data["values"])
        else:
            Restitution.tanh(data["r0"], data["r1"], data["u0"])
    except InputError as exc:
        raise SceneError(_keyed(exc, key, keys or ()), name=key) from None


def _keyed(exc: InputError, key: str, keys: tuple[str, ...]) -> str:
    """``exc`` of a law's constructor as one line naming ``key`` (or ``key.<param>``)."""
    text = str(exc)
    if exc.where and text.startswith(exc.where + ": "):
        text = text[len(exc.where) + 2:]
    if exc.name in keys:
        key = f"{key}.{exc.name}"
        if text.startswith(exc.name + " "):
            return f"{key} {text[len(exc.name) + 1:]}"
    return text if text.startswith(key) else f"{key}: {text}"


def check_laws(table: dict[str, Any]) -> None:
    """Every law of the ``[barriers]`` table (``r``, ``left.r``, ``right.r``)."""
    if isinstance(table.get("r"), dict):
        _law("barriers.r", table["r"])
    for side in ("left", "right"):
        wall = table.get(side)
        if isinstance(wall, dict) and isinstance(wall.get("r"), dict):
            _law(f"barriers.{side}.r", wall["r"])


def flatten_sweep(given: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """The ``[sweep]`` table with TOML's sub-tables as dotted keys: ``left.r = [...]``
    and ``left.r.u0 = [...]`` read as sub-tables, ``"left.r.u0" = [...]`` does not."""
    out: dict[str, Any] = {}
    for k, v in given.items():
        if isinstance(v, dict):
            out.update(flatten_sweep(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def _target(param: str) -> tuple[str, str] | None:
    """("r" | "left.r" | "right.r", law parameter) of a swept law parameter."""
    head, _, last = param.rpartition(".")
    return (head, last) if last in LAW_PARAMETERS and head.endswith("r") and head else None


def _law_of(system: VibroImpactSystem, target: str) -> Any:
    if target == "r":
        return system.r
    wall = getattr(system, target.split(".")[0])
    return None if wall is None else wall.r


def check_law_sweep(system: VibroImpactSystem, sweep: dict[str, Any]) -> None:
    """Each swept law parameter belongs to a tanh law of the scene, and its law is not
    swept as a whole too."""
    for param in sweep:
        found = _target(param)
        if found is None:
            continue
        target, _ = found
        key = f"sweep.{param}"
        if target in sweep:
            raise SceneError(f"{key}: must not be swept with sweep.{target} (which replaces "
                             "the whole law); sweep one of them", name=key)
        law = _law_of(system, target)
        where = "barriers." + target if target == "r" else f"[barriers.{target.split('.')[0]}] r"
        if not (isinstance(law, Restitution) and law.kind == "tanh"):
            what = ("no such wall" if law is None and target != "r" else
                    "a table law" if isinstance(law, Restitution) else
                    f"the number {show(law)}" if law is not None else "not given")
            raise SceneError(f"{key}: sweeps a parameter of the tanh law of {where}, which "
                             f"is {what}; give {where} = {{law = \"tanh\", r0 = ..., r1 = "
                             f"..., u0 = ...}} or sweep {target}", name=key)


def point_system(system: VibroImpactSystem, params: dict[str, Any]) -> VibroImpactSystem:
    """``system`` with the swept ``params`` (a law's parameters build its law anew)."""
    changes = {k: v for k, v in params.items() if _target(k) is None}
    laws: dict[str, dict[str, float]] = {}
    for k, v in params.items():
        found = _target(k)
        if found is not None:
            laws.setdefault(found[0], {})[found[1]] = v
    for target, values in laws.items():
        law = _law_of(system, target)
        given = {"r0": law.r0, "r1": law.r1, "u0": law.u0, **values}
        try:
            changes[target] = Restitution.tanh(given["r0"], given["r1"], given["u0"])
        except InputError as exc:       # named by a swept parameter of that law
            name = f"{target}.{exc.name if exc.name in values else next(iter(values))}"
            text = str(exc)
            if exc.where and text.startswith(exc.where + ": "):
                text = text[len(exc.where) + 2:]
            raise InputError(f"{name}: {text}", name=name) from None
    return system.replace(**changes)


def first_passage_table(fp: dict[str, Any], quantities: tuple[str, ...]
                        ) -> dict[str, Any] | None:
    """The scene's first passage: ``{kind: value, "start", "times"}`` with exactly one
    safe set (kind ``energy``, ``displacement`` or ``impact_speed``); None without the
    quantity."""
    if "first_passage" not in quantities:
        if fp:
            raise SceneError("first_passage: only used with the quantity \"first_passage\" "
                             "in study.quantities", name="first_passage")
        return None
    given = [k for k in KINDS if fp.get(k) is not None]
    if len(given) != 1:
        got = f"got {' and '.join(given)}" if given else "none given"
        key = f"first_passage.{given[1] if given else 'energy'}"
        raise SceneError(f"{key}: the quantity \"first_passage\" needs exactly one safe set: "
                         "energy = H_c, displacement = b or [x_lo, x_hi], or impact_speed = "
                         f"u_c; {got}", name=key)
    kind = given[0]
    value = fp[kind]
    return {kind: list(value) if isinstance(value, tuple) else value,
            "start": fp.get("start", (0.0, 0.0)), "times": fp.get("times")}


def safe_set_keyword(fp: dict[str, Any]) -> tuple[str, Any]:
    """(keyword, value) of the scene's safe set, as each ``first_passage`` takes it."""
    kind = next(k for k in KINDS if k in fp)
    value = fp[kind]
    return kind, tuple(value) if isinstance(value, list) else value


def check_first_passage(fp: dict[str, Any], methods: dict[str, Any],
                        system: VibroImpactSystem, at: str) -> SafeSet:
    """The safe set and start on this point's system, and each method's support of
    that kind of safe set; one SceneError naming the key."""
    from ..first_passage import parse_start
    kind, value = safe_set_keyword(fp)
    try:
        safe = parse_safe_set("first_passage", system, **{kind: value})
        parse_start("first_passage", system, fp["start"], safe)
    except InputError as exc:
        name = exc.name.split("[")[0] if exc.name else kind
        key = f"first_passage.{name if name in ('start', *KINDS) else kind}"
        raise SceneError(exc.keyed(key, at), name=key) from None
    for name, method in methods.items():
        if "first_passage" in method.modes and kind not in method.safe_sets:
            try:
                refuse(name, kind)
            except InputError as exc:
                key = f"first_passage.{kind}"
                raise SceneError(f"{key}: {exc}{at}", name=key) from None
    return safe


def check_walls(quantities: tuple[str, ...], system: VibroImpactSystem, at: str) -> None:
    """The impact quantities need a wall."""
    asked = [q for q in quantities if q in IMPACT_QUANTITIES]
    if asked and not system.has_barrier:
        raise SceneError(f"study.quantities: {asked} need a wall, and this system has none"
                         f"{at}; remove them or add [barriers]", name="study.quantities")
