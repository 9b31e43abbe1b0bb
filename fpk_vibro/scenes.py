"""Scenes: a declared study in a small TOML file, validated before any work starts.

A scene names the system, the barriers, which methods to run, which quantities to
compute and at which times (absent: stationary), the numerics of each method, an
optional sweep over one or two parameters, and the output.  Every key, its type,
range and default is listed in :data:`SCHEMA` (and in the README).  Any unknown
key, wrong type, out-of-range value or missing required key raises
:class:`SceneError` with a one-line message naming the key (and, for a typo, the
closest valid key).
"""
from __future__ import annotations

import difflib
import itertools
import math
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

from .model import VibroImpactSystem

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["Scene", "SceneError", "load_scene", "parse_scene", "SCHEMA", "METHODS", "QUANTITIES"]

METHODS = ("averaging", "fem", "montecarlo", "exact")
QUANTITIES = ("energy", "x", "y", "joint", "moments")
FORMATS = ("json", "npz", "png", "vtu")
SWEEPABLE = ("a", "b", "c", "D1", "D2", "delta", "r")


class SceneError(ValueError):
    """An invalid scene: the message names the key and what is allowed."""


@dataclass(frozen=True)
class Key:
    """One scene key: a checker returning the cleaned value, a default, a doc line."""

    check: Callable[[str, Any], Any]
    default: Any = None
    required: bool = False
    doc: str = ""


def _num(lo: float = -math.inf, hi: float = math.inf, *, lo_open: bool = False,
         hi_open: bool = False, integer: bool = False) -> Callable[[str, Any], Any]:
    def check(key: str, v: Any) -> Any:
        kind = "an integer" if integer else "a number"
        ok_type = isinstance(v, int) if integer else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok_type:
            raise SceneError(f"{key}: must be {kind}; got {v!r}")
        if not math.isfinite(v):
            raise SceneError(f"{key}: must be finite; got {v!r}")
        below = v <= lo if lo_open else v < lo
        above = v >= hi if hi_open else v > hi
        if below or above:
            if hi == math.inf:
                rng = f"{'>' if lo_open else '>='} {lo:g}"
            elif lo == -math.inf:
                rng = f"{'<' if hi_open else '<='} {hi:g}"
            else:
                rng = f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
            raise SceneError(f"{key}: must be {rng}; got {v!r}")
        return v if integer else float(v)
    return check


def _choice(options: tuple[str, ...]) -> Callable[[str, Any], Any]:
    def check(key: str, v: Any) -> Any:
        if not isinstance(v, str) or v not in options:
            hint = _closest(v, options) if isinstance(v, str) else ""
            raise SceneError(f"{key}: must be one of {list(options)}; got {v!r}{hint}")
        return v
    return check


def _subset(options: tuple[str, ...], *, nonempty: bool = True) -> Callable[[str, Any], Any]:
    def check(key: str, v: Any) -> Any:
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            raise SceneError(f"{key}: must be a list of strings from {list(options)}; got {v!r}")
        for s in v:
            if s not in options:
                raise SceneError(f"{key}: unknown entry {s!r}; allowed {list(options)}"
                                 f"{_closest(s, options)}")
        if nonempty and not v:
            raise SceneError(f"{key}: must not be empty; allowed {list(options)}")
        if len(set(v)) != len(v):
            raise SceneError(f"{key}: has repeated entries; got {v!r}")
        return tuple(v)
    return check


def _times(key: str, v: Any) -> Any:
    if not isinstance(v, list) or not v:
        raise SceneError(f"{key}: must be a non-empty list of numbers >= 0; got {v!r}")
    return tuple(_num(0.0)(f"{key}[{i}]", t) for i, t in enumerate(v))


def _string(key: str, v: Any) -> Any:
    if not isinstance(v, str) or not v.strip():
        raise SceneError(f"{key}: must be a non-empty string; got {v!r}")
    return v


def _bool(key: str, v: Any) -> Any:
    if not isinstance(v, bool):
        raise SceneError(f"{key}: must be true or false; got {v!r}")
    return v


SCHEMA: dict[str, dict[str, Key]] = {
    "system": {
        "a": Key(_num(), required=True, doc="linear stiffness (1/s²)"),
        "b": Key(_num(), required=True, doc="cubic stiffness (1/(m² s²))"),
        "c": Key(_num(0.0), required=True, doc="damping (1/s), the paper's ε²c"),
        "D1": Key(_num(0.0, lo_open=True), required=True, doc="external noise intensity, the paper's ε²D11"),
        "D2": Key(_num(0.0), 0.0, doc="parametric noise intensity, the paper's ε²D22"),
    },
    "barriers": {
        "sides": Key(_choice(("both", "right", "none")), "both", doc="barriers at ±Δ, +Δ only, or none"),
        "delta": Key(_num(0.0, lo_open=True), None, doc="barrier position Δ (m); required unless sides = 'none'"),
        "r": Key(_num(0.0, 1.0), 1.0, doc="restitution coefficient"),
    },
    "study": {
        "name": Key(_string, None, doc="a label for the results (default: the file name)"),
        "methods": Key(_subset(METHODS), required=True, doc=f"any of {list(METHODS)}"),
        "quantities": Key(_subset(QUANTITIES), ("energy", "x", "y", "moments"),
                          doc=f"any of {list(QUANTITIES)}"),
        "times": Key(_times, None, doc="output times (s); absent = stationary"),
    },
    "averaging": {
        "n_theta": Key(_num(4, 2000, integer=True), 48, doc="Gauss nodes per orbit"),
        "n_panel": Key(_num(4, 200, integer=True), 24, doc="Gauss nodes per energy panel"),
        "n_cells": Key(_num(16, 200_000, integer=True), 400, doc="cells in H (transient)"),
    },
    "fem": {
        "nx": Key(_num(2, 100_000, integer=True), None, doc="elements in x (default: by accuracy rule)"),
        "ny": Key(_num(2, 100_000, integer=True), None, doc="elements in y"),
        "y_max": Key(_num(0.0, lo_open=True), None, doc="velocity truncation: y in (−y_max, y_max) (m/s); default: Gibbs-tail rule"),
        "degree": Key(_num(1, 2, integer=True), 1, doc="1 (Q1) or 2 (Q2)"),
        "solver": Key(_choice(("auto", "direct", "amg")), "auto", doc="linear solver"),
        "positivity": Key(_bool, None, doc="positivity-preserving discretisation, degree 1 (default false: Galerkin); transient: implicit Euler, first order"),
        "mesh": Key(_string, None, doc="a mesh file of the strip (meshio format), relative to the scene"),
        "dt": Key(_num(0.0, lo_open=True), None, doc="time step (s), transient"),
        "scheme": Key(_choice(("bdf2", "theta", "euler")), None, doc="time scheme, transient (default: bdf2; euler, the only one allowed, with positivity)"),
        "theta": Key(_num(0.5, 1.0), 0.5, doc="θ of the θ-scheme (1/2 Crank–Nicolson, 1 implicit Euler)"),
    },
    "montecarlo": {
        "n_paths": Key(_num(1, 10**9, integer=True), None, doc="paths (default: method's)"),
        "dt": Key(_num(0.0, lo_open=True), None, doc="time step (s)"),
        "t_burn": Key(_num(0.0), None, doc="burn-in time (s)"),
        "t_sample": Key(_num(0.0, lo_open=True), None, doc="sampled time (s)"),
        "seed": Key(_num(0, 2**63 - 1, integer=True), 0, doc="random seed"),
        "bins": Key(_num(4, 10_000, integer=True), None, doc="histogram bins"),
    },
    "initial": {
        "mean": Key(lambda k, v: _pair(k, v), None, doc="[x0, y0] of the Gaussian start (transient)"),
        "std": Key(lambda k, v: _pair(k, v, nonneg=True), None, doc="[sx, sy]; 0 = exactly the mean"),
    },
    "sweep": {p: Key(lambda k, v: _sweep_values(k, v), None, doc=f"list of values of {p}")
              for p in SWEEPABLE},
    "output": {
        "directory": Key(_string, None, doc="output directory (default: results/<scene name>)"),
        "formats": Key(_subset(FORMATS), ("json", "npz", "png"), doc=f"any of {list(FORMATS)}"),
    },
}


def _pair(key: str, v: Any, nonneg: bool = False) -> tuple[float, float]:
    if not isinstance(v, list) or len(v) != 2:
        raise SceneError(f"{key}: must be a list of two numbers; got {v!r}")
    lo = 0.0 if nonneg else -math.inf
    return tuple(_num(lo)(f"{key}[{i}]", x) for i, x in enumerate(v))  # type: ignore[return-value]


def _sweep_values(key: str, v: Any) -> tuple[float, ...]:
    if not isinstance(v, list) or not v:
        raise SceneError(f"{key}: must be a non-empty list of numbers; got {v!r}")
    return tuple(_num()(f"{key}[{i}]", x) for i, x in enumerate(v))


def _closest(word: str, options) -> str:
    match = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean {match[0]!r}?)" if match else ""


@dataclass(frozen=True)
class Scene:
    """A validated scene.  ``points()`` expands the sweep into independent studies."""

    name: str
    system: VibroImpactSystem
    methods: tuple[str, ...]
    quantities: tuple[str, ...]
    times: tuple[float, ...] | None
    numerics: dict[str, dict[str, Any]]
    initial: dict[str, tuple[float, float]] | None
    sweep: dict[str, tuple[float, ...]]
    output_dir: Path
    formats: tuple[str, ...]
    source: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def transient(self) -> bool:
        return self.times is not None

    def reduced(self) -> "Scene":
        """The same scene at a small size (quick look, tests): few paths, coarse meshes."""
        num = {m: dict(v) for m, v in self.numerics.items()}
        num["montecarlo"].update(n_paths=min(num["montecarlo"].get("n_paths", 512), 512),
                                 t_sample=min(num["montecarlo"].get("t_sample", 200.0), 200.0))
        num["fem"].update(nx=min(num["fem"].get("nx", 24), 24), ny=min(num["fem"].get("ny", 32), 32))
        num["fem"].pop("mesh", None)
        num["averaging"]["n_cells"] = min(num["averaging"].get("n_cells", 200), 200)
        return replace(self, numerics=num)

    def points(self) -> list[tuple[dict[str, float], VibroImpactSystem]]:
        """[(parameter values, system)] for each sweep point (one point if no sweep)."""
        if not self.sweep:
            return [({}, self.system)]
        names = list(self.sweep)
        out = []
        for values in itertools.product(*(self.sweep[n] for n in names)):
            params = dict(zip(names, values))
            out.append((params, self.system.replace(**params)))
        return out


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file (TOML)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene ({exc.strerror})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML ({exc})") from None
    return parse_scene(data, name=path.stem, base=path.parent)


def parse_scene(data: dict[str, Any], *, name: str = "scene", base: Path | None = None) -> Scene:
    """Validate a scene given as a dict (the parsed TOML); see :data:`SCHEMA`."""
    clean: dict[str, dict[str, Any]] = {}
    for table in data:
        if table not in SCHEMA:
            raise SceneError(f"[{table}]: unknown table; allowed {list(SCHEMA)}{_closest(table, SCHEMA)}")
        if not isinstance(data[table], dict):
            raise SceneError(f"{table}: must be a table [{table}]; got {data[table]!r}")
    for table, keys in (("system", "a, b, c, D1"), ("study", "methods")):
        if table not in data:
            raise SceneError(f"[{table}]: required table is missing ({keys})")
    for table, keys in SCHEMA.items():
        given = data.get(table, {})
        for k in given:
            if k not in keys:
                raise SceneError(f"{table}.{k}: unknown key; allowed {list(keys)}{_closest(k, keys)}")
        clean[table] = {}
        for k, spec in keys.items():
            full = f"{table}.{k}"
            if k in given:
                clean[table][k] = spec.check(full, given[k])
            elif spec.required and (table in data or table in ("system", "study")):
                raise SceneError(f"{full}: required key is missing ({spec.doc})")
            else:
                clean[table][k] = spec.default
    sys_, bar, study = clean["system"], clean["barriers"], clean["study"]
    if bar["sides"] != "none" and bar["delta"] is None:
        raise SceneError("barriers.delta: required key is missing (sides = "
                         f"{bar['sides']!r} needs the barrier position)")
    try:
        system = VibroImpactSystem(a=sys_["a"], b=sys_["b"], c=sys_["c"], D1=sys_["D1"],
                                   D2=sys_["D2"], delta=bar["delta"], r=bar["r"],
                                   barriers=bar["sides"])
    except ValueError as exc:
        raise SceneError(_scene_key_of(str(exc)) + str(exc).replace("VibroImpactSystem: ", "")) from None
    fem_ = clean["fem"]
    if fem_["positivity"] and (fem_["scheme"] == "bdf2" or
                               (fem_["scheme"] == "theta" and fem_["theta"] != 1)):
        raise SceneError(f"fem.scheme: positivity = true needs implicit Euler (scheme = "
                         f"'euler', or 'theta' with theta = 1); got scheme = "
                         f"{fem_['scheme']!r}, theta = {fem_['theta']}")
    sweep = {k: v for k, v in clean["sweep"].items() if v is not None}
    if len(sweep) > 2:
        raise SceneError(f"sweep: at most two parameters; got {sorted(sweep)}")
    for params in itertools.product(*sweep.values()) if sweep else []:
        try:
            system.replace(**dict(zip(sweep, params)))
        except ValueError as exc:
            raise SceneError(f"sweep.{_field_of(str(exc))}: {str(exc).replace('VibroImpactSystem: ', '')}") from None
    times = study["times"]
    init = None
    if times is not None:
        ini = clean["initial"]
        if ini["mean"] is None or ini["std"] is None:
            raise SceneError("initial.mean: a transient scene (study.times) needs [initial] "
                             "mean = [x0, y0] and std = [sx, sy]")
        lo, hi = system.x_bounds
        if not lo <= ini["mean"][0] <= hi:
            raise SceneError(f"initial.mean[0]: must lie in the strip [{lo}, {hi}]; got {ini['mean'][0]}")
        init = {"mean": ini["mean"], "std": ini["std"]}
        if "exact" in study["methods"]:
            raise SceneError("study.methods: 'exact' is stationary only; remove it or study.times")
    elif any(v is not None for v in clean["initial"].values()):
        raise SceneError("initial: only used with study.times (a transient scene)")
    if "exact" in study["methods"]:
        for _, s in ([({}, system)] if not sweep else
                     [(p, system.replace(**dict(zip(sweep, p)))) for p in itertools.product(*sweep.values())]):
            if s.D2 != 0 or (s.has_barrier and s.r != 1):
                raise SceneError(f"study.methods: 'exact' needs r = 1 (or no barrier) and D2 = 0; "
                                 f"got r={s.r}, D2={s.D2}")
    scene_name = study["name"] or name
    out = clean["output"]["directory"]
    out_dir = Path(out) if out else Path("results") / scene_name
    if base is not None and not out_dir.is_absolute() and out:
        out_dir = base / out_dir
    numerics = {m: {k: v for k, v in clean[m].items() if v is not None}
                for m in ("averaging", "fem", "montecarlo")}
    if numerics["fem"].get("mesh") and base is not None:
        numerics["fem"]["mesh"] = str(base / numerics["fem"]["mesh"])
    return Scene(name=scene_name, system=system, methods=study["methods"],
                 quantities=study["quantities"], times=times, numerics=numerics, initial=init,
                 sweep=sweep, output_dir=out_dir, formats=clean["output"]["formats"], source=data)


_FIELD_TABLE = {"a": "system", "b": "system", "c": "system", "D1": "system", "D2": "system",
                "delta": "barriers", "r": "barriers", "barriers": "barriers"}


def _field_of(message: str) -> str:
    body = message.replace("VibroImpactSystem: ", "")
    return body.split(" ", 1)[0]


def _scene_key_of(message: str) -> str:
    f = _field_of(message)
    table = _FIELD_TABLE.get(f, "system")
    key = "sides" if f == "barriers" else f
    return f"{table}.{key}: "


def schema_table() -> str:
    """The schema as Markdown rows (key, default, meaning) for the README."""
    rows = ["| key | default | meaning |", "|---|---|---|"]
    for table, keys in SCHEMA.items():
        for k, spec in keys.items():
            default = "required" if spec.required else ("—" if spec.default is None else repr(spec.default))
            rows.append(f"| `{table}.{k}` | {default} | {spec.doc} |")
    return "\n".join(rows)
