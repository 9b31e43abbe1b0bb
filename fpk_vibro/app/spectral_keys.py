"""The keys of ``[spectra]`` and ``[crossings]`` (the quantities "spectra" and
"crossings"), declared once: the scene parser checks them by these declarations and
the table of scene keys (docs/guide/keys.md) is generated from them.

A grid of frequencies or levels is a list (strictly increasing) or a table
``{start = ..., stop = ..., n = ...}`` (``n`` equally spaced values from ``start`` to
``stop``, both included).  Defaults that depend on the system (the ω grid, the
levels, the band of the Rice comparison) are resolved per scene by
:mod:`fpk_vibro.app.scene_spectra`.

Examples
--------
>>> SPECTRA_KEYS["omega"].validate("spectra.omega", {"start": 0, "stop": 2, "n": 3}, None)
(0.0, 1.0, 2.0)
>>> SPECTRA_KEYS["of"].validate("spectra.of", "y", None)
('y',)
>>> CROSSINGS_KEYS["levels"].validate("crossings.levels", [0.3, 0.1], None)
Traceback (most recent call last):
...
fpk_vibro._checks.InputError: crossings.levels must be a non-empty, strictly increasing list of finite numbers, or {start, stop, n}; got [0.3, 0.1]
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._checks import check_float, check_int, invalid
from ..options import Option
from ..spectrum import SIDES, SIGNALS, UNITS

__all__ = ["SPECTRA_KEYS", "CROSSINGS_KEYS", "SIGNALS", "UNITS", "SIDES", "MAX_GRID"]

#: Most values of a grid of frequencies or levels.
MAX_GRID = 100_000
_RANGE_KEYS = ("start", "stop", "n")


def _grid(lo: float, what: str):
    """A check of a strictly increasing grid (a list, or {start, stop, n}) of values
    >= ``lo``."""
    rule = f"a non-empty, strictly increasing list of finite {what}, or {{start, stop, n}}"

    def check(name: str, v: Any, where: str | None) -> tuple[float, ...]:
        if isinstance(v, dict):
            unknown = sorted(set(v) - set(_RANGE_KEYS))
            missing = [k for k in _RANGE_KEYS if k not in v]
            if unknown or missing:
                why = f"unknown {unknown[0]!r}" if unknown else f"{missing[0]!r} is missing"
                raise invalid(where, name, "a table {start, stop, n}", v, why)
            start = check_float(f"{name}.start", v["start"], lo, lo_open=False, where=where)
            stop = check_float(f"{name}.stop", v["stop"], start, where=where)
            n = check_int(f"{name}.n", v["n"], 2, MAX_GRID, where=where)
            return tuple(float(x) for x in np.linspace(start, stop, n))
        if not isinstance(v, list) or not v or len(v) > MAX_GRID:
            raise invalid(where, name, rule, v)
        out = tuple(check_float(f"{name}[{i}]", x, lo, lo_open=False, where=where)
                    for i, x in enumerate(v))
        if any(b <= a for a, b in zip(out, out[1:])):
            raise invalid(where, name, rule, v)
        return out
    return check


def _signals(name: str, v: Any, where: str | None) -> tuple[str, ...]:
    rule = f"one of {list(SIGNALS)} or a list of them"
    names = [v] if isinstance(v, str) else v
    if not isinstance(names, list) or not names or any(s not in SIGNALS for s in names) \
            or len(set(names)) != len(names):
        raise invalid(where, name, rule, v)
    return tuple(names)


def _band(name: str, v: Any, where: str | None) -> Any:
    if isinstance(v, list):
        if len(v) != 2:
            raise invalid(where, name, "a number b > 0 or a pair [x_lo, x_hi]", v)
        lo, hi = (check_float(f"{name}[{i}]", x, where=where) for i, x in enumerate(v))
        if not lo < hi:
            raise invalid(where, name, "a pair [x_lo, x_hi] with x_lo < x_hi", v)
        return (lo, hi)
    return check_float(name, v, 0.0, where=where)


def _times(name: str, v: Any, where: str | None) -> tuple[float, ...]:
    return _grid(0.0, "numbers >= 0")(name, v, where)


def _custom(default: Any, doc: str, check, allowed: str, unit: str = "", auto: str = ""
            ) -> Option:
    return Option(default, doc, "custom", check=check, allowed=allowed, unit=unit, auto=auto)


#: ``[spectra]``: what the quantity "spectra" computes and how it is reported.
SPECTRA_KEYS: dict[str, Option] = {
    "omega": _custom(None, "angular frequencies ω (always rad/s, whatever `units`) at which "
                     "each method computes S(ω)", _grid(0.0, "numbers >= 0"),
                     "increasing list of numbers >= 0, or {start, stop, n}", "rad/s",
                     auto="301 values from 0 to 3 ω0 (the largest ω0 of the sweep's "
                     "systems)"),
    "of": _custom(("x",), "the signals: displacement \"x\", velocity \"y\" or both",
                  _signals, "\"x\", \"y\" or a list of them"),
    "units": Option(UNITS[0], "frequency of the figures, netCDF and the `requested` record: "
                    "rad/s (coordinate omega) or Hz (coordinate frequency; densities "
                    "per Hz, 2π times those per rad/s)", "choice", choices=UNITS),
    "sided": Option(SIDES[0], "\"two\": S(ω) with ∫ over the real line = Var; \"one\": "
                    "G = 2 S on ω ≥ 0", "choice", choices=SIDES),
}

#: ``[crossings]``: the levels of the rates and the Rice comparison.
CROSSINGS_KEYS: dict[str, Option] = {
    "levels": _custom(None, "the levels b of the upcrossing rate ν⁺(b) and the peak rate",
                      _grid(-math.inf, "numbers"),
                      "increasing list of numbers, or {start, stop, n}", "m",
                      auto="41 levels over the strip (up to 8 energy scales where there is "
                      "no wall) with every wall position"),
    "displacement": _custom(None, "the band of the Rice estimate exp(−(ν⁺(x_hi) + "
                            "ν⁺(x_lo)) t): |x| < b (a number) or x_lo < x < x_hi (a pair)",
                            _band, "number > 0 or list of two numbers", "m",
                            auto="|x| < the highest level inside the walls"),
    "rice_times": _custom(None, "times at which the Rice estimate is set beside the true "
                          "reliability R(t) of a first passage out of the band from the "
                          "stationary state (by each method of the scene that has one)",
                          _times, "increasing list of numbers >= 0, or {start, stop, n}",
                          "s", auto="none: the Rice rate alone"),
}
