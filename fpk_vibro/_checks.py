"""Argument checks shared by the solvers: one message format for bad input.

``<where>: <name> must be <allowed>; got <value>`` — raised before any work.
"""
from __future__ import annotations

import math
import numbers
from typing import Any

__all__ = ["invalid", "check_int", "check_float"]


def invalid(where: str | None, name: str, allowed: str, value: Any) -> ValueError:
    """The ValueError for ``name`` = ``value`` outside ``allowed`` (to raise)."""
    return ValueError(f"{where + ': ' if where else ''}{name} must be {allowed}; got {value!r}")


def check_int(name: str, value: Any, lo: int, hi: int | None = None, *,
              where: str | None = None) -> int:
    """``value`` as an int in [lo, hi] (hi None: unbounded); bools are rejected."""
    allowed = f"an integer in [{lo}, {hi}]" if hi is not None else f"an integer >= {lo}"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) \
            or value < lo or (hi is not None and value > hi):
        raise invalid(where, name, allowed, value)
    return int(value)


def check_float(name: str, value: Any, lo: float, hi: float = math.inf, *,
                lo_open: bool = True, hi_open: bool = False, where: str | None = None) -> float:
    """``value`` as a finite float in the interval lo..hi (open or closed ends)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise invalid(where, name, "a real number", value)
    v = float(value)
    if not (math.isfinite(v) and (v > lo if lo_open else v >= lo)
            and (v < hi if hi_open else v <= hi)):
        if math.isinf(hi):
            allowed = f"a finite number {'>' if lo_open else '>='} {lo:g}"
        else:
            lb, rb = "(" if lo_open else "[", ")" if hi_open else "]"
            allowed = f"a finite number in {lb}{lo:g}, {hi:g}{rb}"
        raise invalid(where, name, allowed, value)
    return v
