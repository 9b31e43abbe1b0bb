"""The one argument checker: every bad input ends in one line naming it.

Messages read ``<where>: <name> must be <allowed>; got <value>`` and are raised as
:class:`InputError` (a ``ValueError``) before any work.  The error carries
``where`` and ``name`` so that callers (scenes, the CLI) can name their own key
without parsing the text.
"""
from __future__ import annotations

import difflib
import math
import numbers
import os
import sys
import warnings
from collections.abc import Iterable
from typing import Any

__all__ = ["InputError", "invalid", "retired", "show", "check_int", "check_float",
           "check_choice", "check_bool", "check_points", "closest"]

#: Longest value representation put in a message.
_SHOW = 80


class InputError(ValueError):
    """A bad argument, option or scene key; ``name`` and ``where`` say which."""

    def __init__(self, message: str, *, where: str | None = None, name: str = "") -> None:
        super().__init__(message)
        self.where, self.name = where, name

    @property
    def rule(self) -> str:
        """The message after ``<where>: <name>``: what is wrong, to put after another key."""
        text = str(self)
        if self.where and text.startswith(self.where + ": "):
            text = text[len(self.where) + 2:]
        if self.name and text.startswith(self.name):
            text = text[len(self.name):].lstrip(":").lstrip()
        return text

    def keyed(self, key: str, suffix: str = "") -> str:
        """The message naming ``key`` (e.g. a scene key) instead."""
        rule = self.rule
        sep = " " if rule.startswith(("must ", "needs ", "= ")) else ": "
        return f"{key}{sep}{rule}{suffix}"


def show(value: Any) -> str:
    """A short one-line representation of ``value`` for a message."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool) \
            and abs(int(value)) > 10 ** 30:
        return f"<integer with {len(str(abs(int(value))))} digits>"
    try:
        text = repr(value)
    except Exception:  # a hostile __repr__ must not hide the real error
        text = f"<{type(value).__name__}>"
    text = " ".join(text.split())
    return text if len(text) <= _SHOW else text[:_SHOW - 3] + "..."


def at(where: str | None, text: str) -> str:
    """``text`` prefixed by ``<where>: `` when there is a ``where`` (None: no prefix)."""
    return f"{where}: {text}" if where else text


def invalid(where: str | None, name: str, allowed: str, value: Any, why: str = "") -> InputError:
    """The error for ``name`` = ``value`` outside ``allowed`` (to raise)."""
    msg = at(where, f"{name} must be {allowed}; got {show(value)}")
    if why:
        msg += f" ({why})"
    return InputError(msg, where=where, name=name)


def retired(where: str | None, name: str, value: Any, why: str, use: str) -> None:
    """Warn that ``name`` = ``value`` is retired: still accepted, for one release.

    The DeprecationWarning reads ``<where>: <name> = <value> is retired (<why>) and
    goes in the next release; use <use>`` and names the first caller outside the
    package, so that Python shows it where that caller is the user's script.

    Parameters
    ----------
    where, name, value
        As for :func:`invalid`: the caller, the option and its retired value.
    why : str
        Why it is retired (what the measurements showed).
    use : str
        What to give instead.
    """
    frame, level, package = sys._getframe(0), 1, os.path.dirname(__file__) + os.sep
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    warnings.warn(at(where, f"{name} = {show(value)} is retired ({why}) and goes in the "
                            f"next release; use {use}"), DeprecationWarning, stacklevel=level)


def closest(word: Any, options: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for a near miss, else an empty string."""
    if not isinstance(word, str):
        return ""
    match = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean {match[0]!r}?)" if match else ""


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def check_int(name: str, value: Any, lo: int, hi: int | None = None, *,
              where: str | None = None, even: bool = False) -> int:
    """``value`` as an int in [lo, hi] (hi None: unbounded); bools are rejected."""
    allowed = f"an integer in [{lo}, {hi}]" if hi is not None else f"an integer >= {lo}"
    if even:
        allowed = "an even " + allowed[3:]
    if not _is_int(value) or value < lo or (hi is not None and value > hi) \
            or (even and value % 2):
        raise invalid(where, name, allowed, value)
    return int(value)


def interval(lo: float, hi: float, lo_open: bool, hi_open: bool) -> str:
    """'a finite number > 0', 'a finite number in [0, 1]', … for a message."""
    if math.isinf(hi) and math.isinf(lo):
        return "a finite number"
    if math.isinf(hi):
        return f"a finite number {'>' if lo_open else '>='} {lo:g}"
    if math.isinf(lo):
        return f"a finite number {'<' if hi_open else '<='} {hi:g}"
    lb, rb = "(" if lo_open else "[", ")" if hi_open else "]"
    return f"a finite number in {lb}{lo:g}, {hi:g}{rb}"


def check_float(name: str, value: Any, lo: float = -math.inf, hi: float = math.inf, *,
                lo_open: bool = True, hi_open: bool = False, where: str | None = None) -> float:
    """``value`` as a finite float in the interval lo..hi (open or closed ends)."""
    allowed = interval(lo, hi, lo_open, hi_open)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise invalid(where, name, allowed, value)
    try:
        v = float(value)
    except (OverflowError, ValueError):
        raise invalid(where, name, allowed, value) from None
    if not (math.isfinite(v) and (v > lo if lo_open else v >= lo)
            and (v < hi if hi_open else v <= hi)):
        raise invalid(where, name, allowed, value)
    return v


def check_choice(name: str, value: Any, choices: tuple, *, where: str | None = None) -> Any:
    """``value`` if it is one of ``choices`` (compared by type and value)."""
    for c in choices:
        if type(value) is type(c) and value == c:
            return c
    words = [c for c in choices if isinstance(c, str)]
    raise invalid(where, name, f"one of {list(choices)}", value, closest(value, words)[2:-1])


#: What :func:`check_points` accepts, for its messages.
POINTS = "finite real numbers (a number or an array of them)"


def check_points(name: str, value: Any, *, where: str | None = None):
    """``value`` (a number, list or array) as a float array of finite numbers.

    None, strings, booleans, complex or object arrays, NaN and ±inf are refused with
    one line naming ``name``; for an array the first bad entry and its index.
    """
    import numpy as np
    if value is None or isinstance(value, (str, bytes)):
        raise invalid(where, name, POINTS, value)
    try:
        arr = np.asarray(value)
    except Exception:            # ragged lists, hostile __array__
        raise invalid(where, name, POINTS, value) from None
    if arr.dtype.kind not in "iuf":
        raise invalid(where, name, POINTS, value)
    arr = arr.astype(float, copy=False)
    bad = ~np.isfinite(arr)
    if bad.any():
        if arr.ndim == 0:
            raise invalid(where, name, POINTS, value)
        i = tuple(int(k) for k in np.argwhere(bad)[0])
        raise invalid(where, name, POINTS, float(arr[i]),
                      f"at index {i[0] if len(i) == 1 else i} of {arr.size} values")
    return arr


def check_bool(name: str, value: Any, *, where: str | None = None) -> bool:
    if not isinstance(value, bool):
        raise invalid(where, name, "True or False", value)
    return value


def from_table(cls: Any, value: Any, keys: tuple, required: tuple, where: str | None,
               name: str, allowed: str) -> Any:
    """None, an instance of ``cls``, or ``cls(**value)`` for a table ``value`` with
    ``keys`` (``required`` among them): the one parser of a model's table field
    (``[forcing]``, ``[external]``); anything else one line naming ``name``."""
    if value is None or isinstance(value, cls):
        return value
    if isinstance(value, dict):
        unknown = set(value) - set(keys)
        if unknown or not set(required) <= set(value):
            table = "{" + ", ".join(required) + (
                "[, " + ", ".join(k for k in keys if k not in required) + "]"
                if len(keys) > len(required) else "") + "}"
            raise invalid(where, name, f"a table {table}", value,
                          f"unknown {sorted(unknown)}" if unknown else
                          f"{' and '.join(required)} {'is' if len(required) == 1 else 'are'} "
                          "required")
        try:
            return cls(**value)
        except InputError as exc:
            raise InputError(f"{where}: {name}.{exc.name} {exc.rule}", where=where,
                             name=f"{name}.{exc.name}") from None
    raise invalid(where, name, allowed, value)
