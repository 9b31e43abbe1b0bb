"""The keys a scene may hold, each declared once, and the table of them.

``[system]`` and ``[barriers]`` come from :data:`fpk_vibro.model.FIELDS` (the walls'
sub-tables from :data:`fpk_vibro.model.WALL_FIELDS`), ``[forcing]`` from
:data:`FORCING_FIELDS` (the keys of :class:`fpk_vibro.forcing.Harmonic`), ``[external]``
from :data:`EXTERNAL_FIELDS` (those of :class:`fpk_vibro.noise.OrnsteinUhlenbeck`),
``[averaging]``, ``[fem]``, ``[montecarlo]`` from each method's ``Options``, the rest
from :data:`STUDY_KEYS` here (``[spectra]`` and ``[crossings]`` from
:mod:`fpk_vibro.app.spectral_keys`).  Parsing a scene is :mod:`fpk_vibro.app.scenes`.
"""
from __future__ import annotations

import math
from typing import Any

from .._checks import InputError, check_float, closest, invalid
from ..registry import QUANTITIES as _REGISTRY_QUANTITIES, methods
from ..model import FIELDS, WALL_FIELDS
from ..options import REQUIRED, Option, PerMode
from .spectral_keys import CROSSINGS_KEYS, SPECTRA_KEYS

__all__ = ["METHODS", "QUANTITIES", "STATIONARY_ONLY", "IMPACT_QUANTITIES", "LAW_PARAMETERS",
           "NOT_PERIODIC", "FORCING_FIELDS", "EXTERNAL_FIELDS", "FIELD_TABLES",
           "DEFAULT_PHASES", "FORMATS", "ERROR_ESTIMATES",
           "SWEEPABLE", "STUDY_KEYS",
           "TABLES", "SceneError", "table_keys", "schema_table", "sweep_option",
           "method_names", "method_tables", "tables"]


#: The methods registered when the package loads (fpk_vibro.registry); a scene
#: accepts every method registered when it is parsed (:func:`method_names`).
METHODS = tuple(methods())
QUANTITIES = _REGISTRY_QUANTITIES
#: Quantities of a stationary scene only.
STATIONARY_ONLY = ("impacts", "first_passage", "inter_impact", "impact_energy", "spectra",
                   "crossings")
#: Quantities about impacts: they need a system with a wall.
IMPACT_QUANTITIES = ("impacts", "inter_impact", "impact_energy")
#: Quantities a forced system does not have (they assume a stationary response).
NOT_PERIODIC = ("first_passage", "inter_impact", "impact_energy", "spectra", "crossings")
#: The phases of a periodic scene without ``study.phases``: 8 equally spaced.
DEFAULT_PHASES = tuple(2.0 * math.pi * k / 8 for k in range(8))
#: The keys of ``[forcing]`` (:class:`fpk_vibro.forcing.Harmonic`; it checks them too).
FORCING_FIELDS = {
    "amplitude": Option(REQUIRED, "F of the forcing F cos(Ωt + φ0) (force per unit mass); "
                        "required in a [forcing] table, which is optional (none: no "
                        "forcing)", "float", lo=0.0, lo_open=False, unit="m/s²"),
    "frequency": Option(REQUIRED, "Ω of the forcing: its period is 2π/Ω; required in a "
                        "[forcing] table", "float", lo=0.0, lo_open=True, unit="rad/s"),
    "phase": Option(0.0, "φ0 of the forcing (taken mod 2π): the phase at t = 0", "float",
                    unit="rad"),
}
#: The keys of ``[external]`` (:class:`fpk_vibro.noise.OrnsteinUhlenbeck`; it checks them
#: too): coloured external noise.
EXTERNAL_FIELDS = {
    "tau": Option(REQUIRED, "correlation time τ of the coloured external noise ζ, an "
                  "Ornstein–Uhlenbeck force of intensity system.D1 (E[ζ²] = D1/τ); required "
                  "in an [external] table, which is optional (none: white noise)", "float",
                  lo=0.0, lo_open=True, unit="s"),
}
#: The optional tables that are one model field each ([forcing] and [external]).
FIELD_TABLES = {"forcing": FORCING_FIELDS, "external": EXTERNAL_FIELDS}
FORMATS = ("json", "npz", "png", "vtu", "nc")
#: study.error_estimates: how each answer's error is estimated (fpk_vibro.app.estimates).
ERROR_ESTIMATES = ("auto", "fem-check", "none")
#: The parameters of a restitution law a sweep may change (a tanh law's; a table's
#: points are not swept), with the range of each alone (the law checks them together).
LAW_PARAMETERS = {
    "r0": Option(None, "r0 of the tanh law r0 − r1 tanh(u/u0): r at rest", "float",
                 lo=0.0, hi=1.0, lo_open=False),
    "r1": Option(None, "r1 of the tanh law: the fall of r from rest to high speed",
                 "float", lo=-1.0, hi=1.0, lo_open=False),
    "u0": Option(None, "u0 of the tanh law: the speed over which r changes", "float",
                 lo=0.0, lo_open=True, unit="m/s"),
}
SWEEPABLE = ("a", "b", "c", "D1", "D2", "delta", "r", "left.position", "left.r",
             "right.position", "right.r") + tuple(
    f"{wall}r.{k}" for wall in ("", "left.", "right.") for k in LAW_PARAMETERS) + (
    "forcing.amplitude", "forcing.frequency", "external.tau")


def sweep_option(p: str) -> Option:
    """The declaration a swept value is checked against (a model or a wall field, or a
    parameter of a law: ``r.r1``, ``left.r.u0``)."""
    parts = p.split(".")
    if parts[0] in FIELD_TABLES:
        return FIELD_TABLES[parts[0]][parts[1]]
    if parts[-1] in LAW_PARAMETERS and len(parts) >= 2 and parts[-2] == "r":
        return LAW_PARAMETERS[parts[-1]]
    return WALL_FIELDS[parts[1]] if len(parts) > 1 else FIELDS[p]


class SceneError(InputError):
    """An invalid scene: the message names the key and what is allowed."""


def method_names() -> tuple[str, ...]:
    """The registered methods (fpk_vibro.registry), at the time of asking."""
    return tuple(methods())


def _subset(allowed: tuple[str, ...] | Any, empty: bool = False):
    """A check of a list of names from ``allowed`` (a tuple, or a callable giving it
    at check time: the registered methods)."""
    def check(name: str, v: Any, where: str | None) -> tuple[str, ...]:
        options = allowed() if callable(allowed) else allowed
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            raise invalid(where, name, f"a list of names from {list(options)}", v)
        for s in v:
            if s not in options:
                raise invalid(where, name, f"a list of names from {list(options)}", v,
                              f"unknown {s!r}{closest(s, options)}".replace(" (", "; "))
        if not v and not empty:
            raise invalid(where, name, f"a non-empty list of names from {list(options)}", v)
        if len(set(v)) != len(v):
            raise invalid(where, name, "a list without repeated entries", v)
        return tuple(v)
    return check


def _numbers(count: int | None, lo: float = -math.inf, what: str = "numbers"):
    def check(name: str, v: Any, where: str | None) -> tuple[float, ...]:
        n = "a list of two" if count == 2 else "a non-empty list of"
        allowed = f"{n} finite {what}"
        if not isinstance(v, list) or not v or (count and len(v) != count) \
                or len(v) > 100_000:
            raise invalid(where, name, allowed, v)
        return tuple(check_float(f"{name}[{i}]", x, lo, lo_open=False, where=where)
                     for i, x in enumerate(v))
    return check


def _times(name: str, v: Any, where: str | None) -> tuple[float, ...]:
    from ..initial import parse_times
    _numbers(None, 0.0, "numbers >= 0")(name, v, where)
    try:
        return tuple(float(t) for t in parse_times(v, where or "study"))
    except ValueError:
        raise invalid(where, name, "a non-empty, strictly increasing list of finite "
                      "numbers >= 0", v) from None


def _displacement(name: str, v: Any, where: str | None) -> Any:
    if isinstance(v, list):
        return _numbers(2)(name, v, where)
    return check_float(name, v, 0.0, where=where)


def _phases(name: str, v: Any, where: str | None) -> tuple[float, ...]:
    allowed = "a non-empty list of distinct phases in radians in [0, 2π)"
    if not isinstance(v, list) or not v or len(v) > 10_000:
        raise invalid(where, name, allowed, v)
    out = tuple(check_float(f"{name}[{i}]", x, 0.0, 2.0 * math.pi, lo_open=False,
                            hi_open=True, where=where) for i, x in enumerate(v))
    if len(set(out)) != len(out):
        raise invalid(where, name, allowed, v, "a phase is repeated")
    return out


def _start(name: str, v: Any, where: str | None) -> Any:
    if v == "stationary":
        return v
    return _numbers(2)(name, v, where)


def _option(default: Any, doc: str, check, allowed: str, unit: str = "") -> Option:
    return Option(default, doc, "custom", check=check, allowed=allowed, unit=unit)


#: The scene's own keys (not model fields or method options).
STUDY_KEYS: dict[str, dict[str, Option]] = {
    "study": {
        "name": Option(None, "a label for the results (the default directory uses it with "
                       "every character but letters, digits, '.', '_', '-' replaced)", "text",
                       auto="the scene file's name"),
        "methods": _option(REQUIRED, "the methods to run", _subset(method_names),
                           f"list of {', '.join(METHODS)}"),
        "quantities": _option(("energy", "x", "y", "moments"), "what to compute",
                              _subset(QUANTITIES), f"list of {', '.join(QUANTITIES)}"),
        "times": Option(None, "output times; absent: stationary", "custom", check=_times,
                        allowed="increasing list of numbers >= 0", unit="s",
                        auto="stationary"),
        "phases": Option(DEFAULT_PHASES, "phases φ = (Ωt + φ0) mod 2π at which a forced scene "
                         "([forcing], no study.times) reports its periodic response (the "
                         "forcing there is F cos φ)", "custom", check=_phases,
                         allowed="list of distinct numbers in [0, 2π)", unit="rad",
                         auto="8 equally spaced: 0, π/4, …, 7π/4"),
        "error_estimates": Option(ERROR_ESTIMATES[0], "how each answer's error is estimated: "
                                  "\"auto\" every method's own estimate, averaging's from "
                                  "the scene's fem (else its indicator model, or none for a "
                                  "transient or first passage); \"fem-check\" averaging's "
                                  "by an FE solve even without fem in the scene; \"none\" no estimate (saves "
                                  "the extra runs)", "choice", choices=ERROR_ESTIMATES),
    },
    "initial": {
        "mean": Option(None, "[x0, y0] of the Gaussian start (transient)", "custom",
                       check=_numbers(2), allowed="list of two numbers", auto="none"),
        "std": Option(None, "[sx, sy]; 0 = exactly the mean", "custom",
                      check=_numbers(2, 0.0, "numbers >= 0"),
                      allowed="list of two numbers >= 0", auto="none"),
    },
    "first_passage": {
        "energy": Option(None, "critical energy H_c of the safe set {H < H_c} (the quantity "
                         "\"first_passage\" needs exactly one of energy, displacement, "
                         "impact_speed)", "float", lo=0.0,
                         lo_open=True, unit="J/kg", auto="none"),
        "displacement": Option(None, "the safe set |x| < b (a number b) or x_lo < x < x_hi "
                               "(a pair); a bound at or beyond a wall is never reached",
                               "custom", check=_displacement,
                               allowed="number > 0 or list of two numbers", unit="m",
                               auto="none"),
        "impact_speed": Option(None, "u_c: T is the time of the first impact faster than "
                               "u_c (needs a wall)", "float", lo=0.0, lo_open=True,
                               unit="m/s", auto="none"),
        "start": Option((0.0, 0.0), "where paths start: [x0, y0] or \"stationary\"",
                        "custom", check=lambda n, v, w: _start(n, v, w),
                        allowed="list of two numbers or \"stationary\""),
        "times": Option(None, "times at which R(t) is reported", "custom", check=_times,
                        allowed="increasing list of numbers >= 0", unit="s",
                        auto="a grid up to 5 τ"),
    },
    "spectra": SPECTRA_KEYS,
    "crossings": CROSSINGS_KEYS,
    "output": {
        "directory": Option(None, "output directory, relative to the scene", "text",
                            auto="results/<scene name>"),
        "formats": _option(("json", "npz", "png"), "files to write", _subset(FORMATS, True),
                           f"list of {', '.join(FORMATS)}"),
    },
}


def _method_options(method: str):
    return methods()[method].options_class()


def method_tables() -> tuple[str, ...]:
    """The registered methods with numerical options: each has a table of its own."""
    return tuple(name for name, m in methods().items() if m.options is not None)


def tables() -> tuple[str, ...]:
    """Every table a scene may hold, the methods' tables among them."""
    return ("system", "barriers", "forcing", "external", "study") + method_tables() + (
        "initial", "first_passage", "spectra", "crossings", "sweep", "output")


TABLES = tables()


def table_keys(table: str) -> dict[str, Option]:
    """{key: Option} of one table.  A method's table imports only that method."""
    if table in ("system", "barriers"):
        return {opt.scene.split(".")[1]: opt for opt in FIELDS.values()
                if opt.scene.startswith(table + ".")}
    if table in FIELD_TABLES:
        return FIELD_TABLES[table]
    if table in method_tables():
        return {k: o for k, o in _method_options(table).declared().items()
                if o.scene in ("", "file")}
    if table == "sweep":
        return {p: Option(None, _sweep_doc(p), "custom", check=_numbers(None),
                          allowed="list of numbers", unit=sweep_option(p).unit,
                          auto="no sweep")
                for p in SWEEPABLE}
    return STUDY_KEYS[table]


def _sweep_doc(p: str) -> str:
    parts = p.split(".")
    if parts[-1] in LAW_PARAMETERS:
        law = "barriers.r" if len(parts) == 2 else f"barriers.{parts[0]}.r"
        return (f"list of values of {parts[-1]} of the tanh law {law} (each point builds "
                "the law with it)")
    if parts[0] == "forcing":
        return (f"list of values of {p} (needs [forcing]; a sweep of forcing.frequency "
                "draws the response curve)")
    if parts[0] == "external":
        return (f"list of values of {p} (needs [external]; each point is solved at its "
                "τ, and the moments are drawn against τ)")
    return f"list of values of {p}"


def __getattr__(name: str) -> Any:
    if name == "SCHEMA":     # every table: imports every method (the key table, tests)
        return {t: table_keys(t) for t in tables()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def schema_table() -> str:
    """The scene keys as a Markdown table (key, default, allowed, meaning): docs/guide/keys.md.

    Defaults are written as a scene writes them (TOML): ``true``, ``"auto"``,
    ``[0.0, 0.0]``; a default that differs between stationary and transient runs
    names both (and first passage where it has one), and a key without a default is
    "not set"; a key of first passage says which runs use it.
    """
    rows = ["| key | default | allowed | meaning |", "|---|---|---|---|"]
    for table in tables():
        for k, opt in table_keys(table).items():
            if opt.default is REQUIRED:
                default = "required"
            elif isinstance(opt.default, PerMode):
                modes = [m for m in ("stationary", "transient", "first_passage")
                         if m in opt.modes]
                default = " / ".join(
                    f"{mode.replace('_', ' ')}: " + (_toml(v) if v is not None
                                                     else opt.auto or "not set")
                    for mode, v in ((m, opt.default.of(m)) for m in modes))
            elif opt.auto in ("none", "") and opt.default is None:
                default = "not set"
            elif opt.auto:
                default = f"auto: {opt.auto}"
            else:
                default = _toml(opt.default)
            allowed = opt.describe() + (f" ({opt.unit})" if opt.unit else "")
            doc = opt.doc
            if len(opt.modes) == 1:
                doc += f"; {opt.modes[0].replace('_', ' ')} runs only"
            elif "first_passage" in opt.modes:
                names = [m.replace("_", " ") for m in opt.modes]
                doc += "; " + ", ".join(names[:-1]) + " and " + names[-1] + " runs"
            cells = (f"`{table}.{k}`", default, allowed, doc)
            rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(rows)


def _toml(value: Any) -> str:
    """A default as TOML: ``true``, ``"auto"``, ``[0.0, 0.0]``, ``1e-08``.

    >>> _toml(True), _toml("auto"), _toml((0.0, 0.0)), _toml(["json", "npz"]), _toml(None)
    ('true', '"auto"', '[0.0, 0.0]', '["json", "npz"]', 'not set')
    """
    if value is None:
        return "not set"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)
