"""The safe sets a first passage leaves: energy, displacement or impact speed.

A path starts inside a safe set and the first-passage time T is when it first leaves:

- ``energy=H_c``: the set {H < H_c}; T is the first time H reaches H_c;
- ``displacement=b`` (|x| < b) or ``displacement=(x_lo, x_hi)``: the set
  {x_lo < x < x_hi}; T is the first time x reaches a bound (a bound beyond a wall is
  never reached: only the other one counts);
- ``impact_speed=u_c``: every state of the strip is safe, and T is the time of the
  first impact faster than u_c (engineers' damage criterion: impact speed thresholds).

Each engine's ``first_passage`` takes exactly one of the three keywords
(:func:`parse_safe_set` checks them alike for every engine) and says in one line when
it cannot compute that kind, naming the engines that can (:func:`refuse`; the
registry fills :data:`SUPPORTED_BY` when the package loads: this module lies below the
methods).

Examples
--------
>>> from fpk_vibro import VibroImpactSystem
>>> from fpk_vibro.safe_sets import parse_safe_set
>>> s = VibroImpactSystem.paper()
>>> parse_safe_set("fem.first_passage", s, displacement=0.3).describe()
'-0.3 < x < 0.3'
>>> parse_safe_set("fem.first_passage", s, impact_speed=0.5).describe()
'impacts slower than u_c = 0.5'
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import InputError, check_float, invalid, show
from .model import VibroImpactSystem

__all__ = ["SafeSet", "KINDS", "parse_safe_set", "refuse", "SUPPORTED_BY"]

#: The kinds of safe set, in the order of the keywords.
KINDS = ("energy", "displacement", "impact_speed")

#: Which methods compute each kind (filled by :mod:`fpk_vibro.registry`).
SUPPORTED_BY: dict[str, tuple[str, ...]] = {}


@dataclass(frozen=True)
class SafeSet:
    """One safe set (module docstring).

    Attributes
    ----------
    kind : str
        "energy", "displacement" or "impact_speed".
    energy : float or None
        H_c of an energy set.
    x_lo, x_hi : float
        The bounds of a displacement set (±inf where a wall stops paths first).
    speed : float or None
        u_c of an impact-speed set.
    """

    kind: str
    energy: float | None = None
    x_lo: float = -math.inf
    x_hi: float = math.inf
    speed: float | None = None

    def contains(self, system: VibroImpactSystem, x: Any, y: Any) -> np.ndarray:
        """True where the state (x, y) is inside the set (arrays broadcast)."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if self.kind == "energy":
            return np.asarray(system.energy(x, y)) < self.energy
        if self.kind == "displacement":
            return (x > self.x_lo) & (x < self.x_hi) & np.isfinite(y)
        return np.isfinite(x) & np.isfinite(y)

    @property
    def value(self) -> Any:
        """What was given: H_c, (x_lo, x_hi) or u_c."""
        return {"energy": self.energy, "displacement": (self.x_lo, self.x_hi),
                "impact_speed": self.speed}[self.kind]

    def describe(self) -> str:
        """The set in words, for titles and messages."""
        if self.kind == "energy":
            return f"H < {self.energy:g}"
        if self.kind == "displacement":
            if math.isinf(self.x_lo):
                return f"x < {self.x_hi:g}"
            if math.isinf(self.x_hi):
                return f"x > {self.x_lo:g}"
            return f"{self.x_lo:g} < x < {self.x_hi:g}"
        return f"impacts slower than u_c = {self.speed:g}"

    def to_dict(self) -> dict[str, Any]:
        """{kind, value} (JSON-able: an open bound is null)."""
        value = self.value
        if self.kind == "displacement":
            value = [None if math.isinf(v) else v for v in value]
        return {"kind": self.kind, "value": value}


def refuse(method: str, kind: str) -> None:
    """Raise the one-line InputError of ``method`` for a safe set it cannot leave."""
    others = [m for m in SUPPORTED_BY.get(kind, ()) if m != method]
    also = f"; {', '.join(others)} do" if others else ""
    raise InputError(f"{method}.first_passage: does not compute first passage out of "
                     f"a safe set given by {kind}{also}", where=f"{method}.first_passage",
                     name=kind)


def parse_safe_set(where: str, system: VibroImpactSystem, *, energy: Any = None,
                   displacement: Any = None, impact_speed: Any = None) -> SafeSet:
    """The :class:`SafeSet` of exactly one of the keywords, checked.

    ``energy`` above the bottom of the potential on the strip; ``displacement`` a
    number b > 0 (|x| < b) or a pair x_lo < x_hi, one bound at least inside the strip;
    ``impact_speed`` a number u_c > 0 on a system with a wall.  Anything else is one
    :class:`~fpk_vibro._checks.InputError` naming the keyword.
    """
    given = {k: v for k, v in (("energy", energy), ("displacement", displacement),
                               ("impact_speed", impact_speed)) if v is not None}
    if len(given) != 1:
        got = ", ".join(given) if given else "none"
        raise InputError(f"{where}: give exactly one safe set: energy=H_c, "
                         f"displacement=b or (x_lo, x_hi), or impact_speed=u_c; got {got}",
                         where=where, name="energy")
    if energy is not None:
        from .scales import potential_min
        g0 = potential_min(system)
        return SafeSet("energy", energy=check_float("energy", energy, lo=g0, lo_open=True,
                                                    where=where))
    if impact_speed is not None:
        u_c = check_float("impact_speed", impact_speed, lo=0.0, lo_open=True, where=where)
        if not math.isfinite(u_c):
            raise invalid(where, "impact_speed", "a finite speed u_c > 0", impact_speed)
        if not system.walls:
            raise invalid(where, "impact_speed", "a threshold on a system with a wall "
                          "(without walls there are no impacts)", impact_speed)
        return SafeSet("impact_speed", speed=u_c)
    return _displacement(where, system, displacement)


def _displacement(where: str, system: VibroImpactSystem, value: Any) -> SafeSet:
    rule = "a bound b > 0 (|x| < b) or a pair (x_lo, x_hi) with x_lo < x_hi"
    if isinstance(value, (tuple, list, np.ndarray)):
        if len(value) != 2:
            raise invalid(where, "displacement", rule, value)
        lo = check_float("displacement[0]", value[0], where=where)
        hi = check_float("displacement[1]", value[1], where=where)
        if not lo < hi:
            raise invalid(where, "displacement", rule, value, f"x_lo = {lo:g} >= x_hi = {hi:g}")
    else:
        b = check_float("displacement", value, lo=0.0, lo_open=True, where=where)
        lo, hi = -b, b
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise invalid(where, "displacement", rule + " (finite)", value)
    x_lo, x_hi = system.x_bounds
    left = lo if lo > x_lo else -math.inf          # a bound at or beyond a wall: never
    right = hi if hi < x_hi else math.inf          # reached, paths rebound first
    if math.isinf(left) and math.isinf(right):
        raise InputError(f"{where}: displacement {show(value)} lies beyond the walls at "
                         f"{x_lo:g} and {x_hi:g}: paths never leave it; give a bound "
                         "inside the strip", where=where, name="displacement")
    if left >= x_hi or right <= x_lo:
        raise InputError(f"{where}: displacement {show(value)} does not meet the strip "
                         f"{x_lo:g} <= x <= {x_hi:g}", where=where, name="displacement")
    return SafeSet("displacement", x_lo=left, x_hi=right)
