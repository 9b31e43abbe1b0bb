"""Scenes: a declared study in a small TOML file, validated before any work starts.

A scene names the system, the barriers, an optional harmonic forcing or coloured
external noise (``[external]``, an Ornstein–Uhlenbeck force of time τ), which methods
to run, which quantities to compute and at which times (absent: stationary, or with
``[forcing]`` the periodic response at ``study.phases``), the numerics of each
method, an optional sweep over one or two parameters, and the output.  Every key
comes from one declaration: ``[system]`` and ``[barriers]`` from
:data:`fpk_vibro.model.FIELDS`, ``[forcing]`` from
:data:`~fpk_vibro.app.scene_keys.FORCING_FIELDS`, ``[external]`` from
:data:`~fpk_vibro.app.scene_keys.EXTERNAL_FIELDS`,
``[averaging]``, ``[fem]``, ``[montecarlo]`` from each method's ``Options``, the
rest from :data:`STUDY_KEYS` here ("spectra" and "crossings":
:mod:`~fpk_vibro.app.scene_spectra`).  :data:`SCHEMA` gathers them (and the table of
docs/guide/keys.md is generated from it).

:func:`parse_scene` checks every key; :func:`check_scene` then runs, per point and
method, every check the solver itself runs (:mod:`fpk_vibro.app.plan`) and estimates the
cost.  Any failure is a :class:`SceneError` with one line naming the key.
"""
from __future__ import annotations

import itertools
import math
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .. import budget
from .._checks import InputError, closest, show
from ..model import FIELDS, VibroImpactSystem
from ..options import REQUIRED
from ..registry import methods as method_registry
from .outdir import safe_name
from .scene_impacts import (check_first_passage, check_law_sweep, check_laws, check_walls,
                            first_passage_table, flatten_sweep, point_system)
from .scene_spectra import check_spectral, spectral_tables
from .scene_keys import (FIELD_TABLES, FORMATS, METHODS, NOT_PERIODIC, QUANTITIES,  # noqa: F401
                         STATIONARY_ONLY, STUDY_KEYS, SWEEPABLE, TABLES, SceneError,
                         _method_options, method_tables,
                         schema_table, tables,
                         sweep_option, table_keys)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["Scene", "SceneError", "load_scene", "parse_scene", "SCHEMA", "METHODS",  # noqa: F822
           "QUANTITIES", "schema_table", "SWEEPABLE"]

#: Largest scene file read (bytes).
MAX_SCENE_BYTES = 1 << 20


def __getattr__(name: str) -> Any:
    if name == "SCHEMA":     # every table: imports every method (the key table, tests)
        return {t: table_keys(t) for t in tables()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

_FIELD_OF_KEY = {opt.scene: name for name, opt in FIELDS.items()}


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
    first_passage: dict[str, Any] | None = None
    error_estimates: str = "auto"
    phases: tuple[float, ...] | None = None
    spectra: dict[str, Any] | None = None       # [spectra], resolved (scene_spectra)
    crossings: dict[str, Any] | None = None     # [crossings], resolved

    @property
    def transient(self) -> bool:
        return self.times is not None

    @property
    def periodic(self) -> bool:
        """A forced scene without times: the periodic response at ``phases``."""
        return self.phases is not None

    @property
    def mode(self) -> str:
        return "transient" if self.transient else "periodic" if self.periodic else "stationary"

    @property
    def n_points(self) -> int:
        return math.prod(len(v) for v in self.sweep.values()) if self.sweep else 1

    def reduced(self) -> "Scene":
        """The same scene at the declared reduced sizes (quick look, tests)."""
        num = {m: _method_options(m).reduce(self.mode, v) if m in self.methods else v
               for m, v in self.numerics.items()}
        return replace(self, numerics=num)

    def points(self) -> list[tuple[dict[str, float], VibroImpactSystem]]:
        """[(parameter values, system)] for each sweep point (one point if no sweep)."""
        if not self.sweep:
            return [({}, self.system)]
        names = list(self.sweep)
        out = []
        for values in itertools.product(*(self.sweep[n] for n in names)):
            params = dict(zip(names, values))
            try:
                out.append((params, point_system(self.system, params)))
            except InputError as exc:
                raise SceneError(exc.keyed(f"sweep.{exc.name}", f" (at {_label(params)})"),
                                 name=f"sweep.{exc.name}") from None
        return out


def _label(params: dict[str, float]) -> str:
    return ", ".join(f"{k} = {v:g}" for k, v in params.items()) or "the single point"


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file (TOML)."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_SCENE_BYTES:
            raise SceneError(f"{path}: a scene file must be below {MAX_SCENE_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or "not UTF-8 text"
        raise SceneError(f"{path}: cannot read the scene ({reason})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML ({exc})") from None
    return parse_scene(data, name=path.stem, base=path.parent)


def _clean_tables(data: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Each given key checked by its declaration; unknown tables/keys rejected."""
    for table in data:
        if table not in tables():
            raise SceneError(f"[{table}]: unknown table; allowed {list(tables())}"
                             f"{closest(table, tables())}", name=table)
        if not isinstance(data[table], dict):
            raise SceneError(f"{table}: must be a table [{table}]; got {show(data[table])}",
                             name=table)
    for table, keys in (("system", "a, b, c, D1"), ("study", "methods")):
        if table not in data:
            raise SceneError(f"[{table}]: required table is missing ({keys})", name=table)
    clean: dict[str, dict[str, Any]] = {}
    for table in tables():
        given = data.get(table, {})
        if table == "sweep":      # TOML reads `left.r = [...]` as a sub-table
            given = flatten_sweep(given)
        if table == "barriers":   # a bad law: one line naming its key
            check_laws(given)
        clean[table] = {}
        if table in method_tables():
            continue              # their Options.from_scene checks them, per mode
        keys = table_keys(table)
        for k, v in given.items():
            full = f"{table}.{k}"
            if k not in keys:
                raise SceneError(f"{full}: unknown key; allowed {list(keys)}"
                                 f"{closest(k, keys)}", name=full)
            try:
                clean[table][k] = keys[k].validate(full, v, None)
            except InputError as exc:
                raise SceneError(str(exc), name=full) from None
        for k, opt in keys.items():      # (of a table given: [forcing] is optional)
            if opt.default is REQUIRED and k not in given and table in data:
                raise SceneError(f"{table}.{k}: required key is missing ({opt.doc})",
                                 name=f"{table}.{k}")
    return clean


def parse_scene(data: dict[str, Any], *, name: str = "scene", base: Path | None = None) -> Scene:
    """Validate a scene given as a dict (the parsed TOML); see :data:`SCHEMA`.

    Checks every key and the sweep's size; :func:`check_scene` adds the checks that
    need each point's system (the run does both before any work).
    """
    if not isinstance(data, dict):
        raise SceneError(f"a scene must be a table of tables; got {type(data).__name__}")
    clean = _clean_tables(data)
    sys_, bar, study = clean["system"], clean["barriers"], clean["study"]
    fields = {_FIELD_OF_KEY[f"system.{k}"]: v for k, v in sys_.items()}
    fields.update({_FIELD_OF_KEY[f"barriers.{k}"]: v for k, v in bar.items()})
    for table in FIELD_TABLES:          # [forcing], [external]: one field each
        if clean[table]:
            fields[table] = clean[table]
    sides = fields.get("barriers", "both")
    walls = fields.get("left") is not None or fields.get("right") is not None
    if sides != "none" and fields.get("delta") is None and not walls:
        raise SceneError(f"barriers.delta: required key is missing (sides = {sides!r} needs "
                         "the barrier position, or give [barriers.left] / "
                         "[barriers.right])", name="barriers.delta")
    try:
        system = VibroImpactSystem(**fields)
    except InputError as exc:
        key = FIELDS[exc.name].scene if exc.name in FIELDS else \
            exc.name if exc.name.startswith(tuple(f"{t}." for t in FIELD_TABLES)) \
            else "system"
        raise SceneError(exc.keyed(key), name=key) from None
    sweep = {k: v for k, v in clean["sweep"].items() if v is not None}
    if len(sweep) > 2:
        raise SceneError(f"sweep: at most two parameters; got {sorted(sweep)}", name="sweep")
    given_walls = [f"[barriers.{side}]" for side in ("left", "right") if bar.get(side)]
    for k in [k for k in sweep if k in ("delta", "r") or k.startswith("r.")]:
        if given_walls:
            raise SceneError(
                f"sweep.{k}: must not be swept with explicit walls {' and '.join(given_walls)} "
                f"(the symmetric shorthand would replace them by walls at ±delta with one r); got "
                f"sweep.{k} = {show(list(sweep[k]))}; sweep left.position/right.position or "
                f"left.r/right.r (or left.r.r1, ...) instead", name=f"sweep.{k}")
    n_points = math.prod(len(v) for v in sweep.values()) if sweep else 1
    if n_points > budget.MAX_POINTS and not budget.forced():
        raise SceneError(f"sweep: {n_points} points; the limit is {budget.MAX_POINTS} "
                         "(fpk_vibro.budget.MAX_POINTS); use fewer or force it (--force)",
                         name="sweep")
    for k, values in sweep.items():
        field_opt = sweep_option(k)
        for i, v in enumerate(values):
            try:
                field_opt.validate(k, v, None)
            except InputError as exc:
                raise SceneError(exc.keyed(f"sweep.{k}[{i}]"), name=f"sweep.{k}") from None
    check_law_sweep(system, sweep)
    times = study.get("times")
    phases = _periodic(system, sweep, study, times)
    mode = "transient" if times is not None else "periodic" if phases else "stationary"
    numerics: dict[str, dict[str, Any]] = {}
    for m in method_tables():
        try:
            numerics[m] = _method_options(m).from_scene(mode, data[m]) if data.get(m) else {}
        except InputError as exc:
            raise SceneError(str(exc), name=exc.name) from None
    if numerics.get("fem", {}).get("mesh") and base is not None:
        numerics["fem"]["mesh"] = str(base / numerics["fem"]["mesh"])
    methods = study["methods"]
    ini = clean["initial"]
    init = None
    if times is not None:
        if ini.get("mean") is None or ini.get("std") is None:
            raise SceneError("initial.mean: a transient scene (study.times) needs [initial] "
                             "mean = [x0, y0] and std = [sx, sy]", name="initial.mean")
        init = {"mean": ini["mean"], "std": ini["std"]}
        for m in methods:
            modes = [x for x in method_registry()[m].modes if x != "first_passage"]
            if "transient" not in modes:
                raise SceneError(f"study.methods: {m!r} is {' and '.join(modes)} only; "
                                 "remove it or study.times", name="study.methods")
    elif ini:
        raise SceneError("initial: only used with study.times (a transient scene)",
                         name="initial")
    quantities = study.get("quantities", STUDY_KEYS["study"]["quantities"].default)
    if times is not None and set(quantities) & set(STATIONARY_ONLY):
        raise SceneError(f"study.quantities: {sorted(set(quantities) & set(STATIONARY_ONLY))} "
                         "are stationary only; remove them or study.times",
                         name="study.quantities")
    if phases is not None:
        _check_periodic(methods, quantities)
    _check_someone_gives(methods, quantities)
    fp = first_passage_table(clean["first_passage"], quantities)
    formats = clean["output"].get("formats", STUDY_KEYS["output"]["formats"].default)
    if "nc" in formats:
        try:
            import h5netcdf  # noqa: F401
            import xarray  # noqa: F401
        except ImportError:
            raise SceneError("output.formats: \"nc\" (netCDF) needs xarray and h5netcdf: "
                             "pip install 'fpk_vibro[data]'", name="output.formats") from None
    scene_name = study.get("name") or name
    out = clean["output"].get("directory")
    out_dir = Path(out) if out else Path("results") / safe_name(scene_name)
    if base is not None and not out_dir.is_absolute() and out:
        out_dir = base / out_dir
    scene = Scene(name=scene_name, system=system, methods=methods,
                  quantities=quantities, first_passage=fp,
                  times=times, phases=phases, numerics=numerics, initial=init, sweep=sweep,
                  output_dir=out_dir,
                  error_estimates=study.get("error_estimates",
                                            STUDY_KEYS["study"]["error_estimates"].default),
                  formats=clean["output"].get("formats", STUDY_KEYS["output"]["formats"].default),
                  source=data)
    spectra, crossings = spectral_tables(clean, quantities, lambda: scene.points())
    return replace(scene, spectra=spectra, crossings=crossings)


def _periodic(system: VibroImpactSystem, sweep: dict[str, Any], study: dict[str, Any],
              times: Any) -> tuple[float, ...] | None:
    """The phases of a forced scene without times (a periodic response), else None;
    ``study.phases`` or a sweep of the forcing without ``[forcing]`` refused."""
    forced = system.forcing is not None
    for k in sweep:
        if k.startswith("external.") and system.external is None:
            raise SceneError(f"sweep.{k}: sweeps the coloured external noise, and the scene "
                             "has none; add [external] tau = τ", name=f"sweep.{k}")
        if k.startswith("forcing.") and not forced:
            raise SceneError(f"sweep.{k}: sweeps the harmonic forcing, and the scene has "
                             "none; add [forcing] amplitude = F, frequency = Ω",
                             name=f"sweep.{k}")
    if "phases" in study and (not forced or times is not None):
        why = "has no [forcing]" if not forced else "is transient (study.times)"
        raise SceneError("study.phases: only used by a forced scene without study.times "
                         f"(the periodic response); this one {why}; remove it",
                         name="study.phases")
    if not forced or times is not None:
        return None
    return study.get("phases", STUDY_KEYS["study"]["phases"].default)


def _check_periodic(names: list[str], quantities: tuple[str, ...]) -> None:
    """A periodic scene: methods that solve the periodic response, and no quantity of a
    stationary response."""
    stationary = [q for q in quantities if q in NOT_PERIODIC]
    if stationary:
        raise SceneError(f"study.quantities: {stationary} need a stationary response, and "
                         "[forcing] makes it periodic; remove them or [forcing]",
                         name="study.quantities")
    registry = method_registry()
    for m in names:
        if "periodic" not in registry[m].modes:
            have = [n for n, x in registry.items() if "periodic" in x.modes]
            others = f"; {', '.join(have)} do" if have else "; no registered method does"
            raise SceneError(f"study.methods: {m!r} does not solve the periodic response "
                             f"of a forced system ([forcing]){others}; remove it or "
                             "[forcing]", name="study.methods")


def _check_someone_gives(names: list[str], quantities: list[str]) -> None:
    """Each quantity asked for is given by at least one method of the scene (a method
    without it skips it; with none the scene would silently compute nothing)."""
    registry = method_registry()
    for q in quantities:
        if not any(q in registry[m].quantities for m in names):
            have = [m.name for m in registry.values() if q in m.quantities]
            raise SceneError(f"study.quantities: {q!r} is given by none of study.methods "
                             f"{list(names)}; add one of {', '.join(have)} or remove it",
                             name="study.quantities")


def check_scene(scene: Scene) -> list[dict[str, Any]]:
    """Every check the run makes, per point and method, and the cost estimates.

    Returns ``[{"parameters", "costs": {method: Cost}}]`` per point.

    Raises
    ------
    SceneError
        Naming the key (and the sweep point) of the first failure.
    """
    from .plan import plan
    out = []
    for params, system in scene.points():
        costs = {}
        at = f" (at {_label(params)})" if params else ""
        check_walls(scene.quantities, system, at)
        check_spectral(scene, system, at)
        if scene.first_passage is not None:
            registry = method_registry()
            check_first_passage(scene.first_passage,
                                {m: registry[m] for m in scene.methods}, system, at)
        for method in scene.methods:
            try:
                costs[method] = plan(scene, method, system)
            except InputError as exc:
                key = _scene_key(method, exc)
                at = f" (at {_label(params)})" if params else ""
                if key == "study.methods" and not exc.rule.startswith(method):
                    raise SceneError(f"{key}: {method}: {exc.rule}{at}", name=key) from None
                raise SceneError(exc.keyed(key, at), name=key) from None
        out.append({"parameters": params, "costs": costs})
    return out


def _scene_key(method: str, exc: InputError) -> str:
    """The scene key of a solver's error ``exc``."""
    if exc.name in ("times", "quantities"):
        return f"study.{exc.name}"
    if exc.name == "initial" or exc.name.startswith(("mean", "std", "initial")):
        return "initial." + ("std" if "std" in exc.name else "mean")
    if exc.name in ("system", "mode") or not exc.name:
        return "study.methods"
    if exc.name in FIELDS:
        return FIELDS[exc.name].scene
    if method in method_tables() and exc.name in _method_options(method).declared():
        return f"{method}.{exc.name}"
    return exc.name
