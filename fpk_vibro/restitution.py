"""Restitution that depends on the impact speed: the law r(u) of a wall.

An impact at speed u = |y⁻| leaves at speed φ(u) = u r(u), y⁺ = −φ(|y⁻|) sign(y⁻)
(docs/theory.md, §Walls).  A law keeps 0 ≤ r(u) ≤ 1 (no impact adds energy) and
φ strictly increasing (a faster impact leaves faster: the impact map is one-to-one,
so the rebound-speed density is defined); a law that breaks either is refused in one
line naming the speed where it fails.  A law constant in u follows the number's
rules (r = 0, the plastic wall, included).

Laws:

- :meth:`Restitution.table`: piecewise linear in u through given (speed, value)
  points, constant beyond the ends;
- :meth:`Restitution.tanh`: r(u) = r0 − r1 tanh(u/u0) (the path-integration
  literature's law: r falls with the impact speed);
- :meth:`Restitution.callable`: any vectorised Python function r(u) (Monte Carlo
  evaluates it on a table, :meth:`Restitution.kernel_table`).

``Wall(position, r=...)`` takes a number or any of these; in a scene ``r = {speeds =
[...], values = [...]}`` or ``r = {law = "tanh", r0 = ..., r1 = ..., u0 = ...}``.

Examples
--------
>>> from fpk_vibro import Restitution
>>> law = Restitution.tanh(0.9, 0.2, 1.0)
>>> [round(float(v), 4) for v in law([0.0, 1.0, 10.0])]
[0.9, 0.7477, 0.7]
>>> Restitution.table([0.0, 1.0], [0.9, 0.2])
Traceback (most recent call last):
...
fpk_vibro._checks.InputError: Restitution.table: u·r(u) must increase strictly with the impact speed u (the impact map must be one-to-one); it does not beyond u = 0.641 (u·r(u) = 0.289 there)
"""
from __future__ import annotations

import math
import numbers
from typing import Any, Callable

import numpy as np

from ._checks import InputError, check_float, check_points, invalid, show

__all__ = ["Restitution", "LAWS", "TABLE_POINTS"]

#: The scene forms of a law, by its ``law`` key (a table has no ``law`` key).
LAWS = ("table", "tanh")
#: Speeds at which Monte Carlo tabulates a Python callable (up to the speed bound it
#: gives, then constant): piecewise-linear error ~(u_max/TABLE_POINTS)² r''/8.
TABLE_POINTS = 4097
#: Speeds (relative to the law's own scale) at which r and u r(u) are checked.
_CHECK = np.concatenate([[0.0], np.geomspace(1e-6, 1e6, 6001)])


class Restitution:
    """A restitution law r(u) of the impact speed u ≥ 0 (module docstring).

    Made by :meth:`table`, :meth:`tanh`, :meth:`callable` or :meth:`of`; called on
    speeds it returns r(u) (vectorised).  Immutable, hashable, equal by value (a
    callable by identity).
    """

    __slots__ = ("kind", "speeds", "values", "r0", "r1", "u0", "function")

    def __init__(self, kind: str, *, speeds: tuple = (), values: tuple = (),
                 r0: float = 0.0, r1: float = 0.0, u0: float = 1.0,
                 function: Callable[[np.ndarray], Any] | None = None) -> None:
        for name, value in (("kind", kind), ("speeds", tuple(speeds)),
                            ("values", tuple(values)), ("r0", r0), ("r1", r1), ("u0", u0),
                            ("function", function)):
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("a Restitution law is immutable")

    # -- constructors -------------------------------------------------------------
    @classmethod
    def table(cls, speeds: Any, values: Any) -> "Restitution":
        """r(u) piecewise linear through (``speeds[k]``, ``values[k]``), constant beyond
        the ends; ``speeds`` ≥ 0 strictly increasing, ``values`` in [0, 1]."""
        where = "Restitution.table"
        u = check_points("speeds", speeds, where=where).ravel()
        r = check_points("values", values, where=where).ravel()
        if u.size == 0 or u.size != r.size:
            raise invalid(where, "values", f"as many values as speeds ({u.size})", values)
        if u[0] < 0 or np.any(np.diff(u) <= 0):
            raise invalid(where, "speeds", "speeds >= 0, strictly increasing", speeds)
        out = (r < 0.0) | (r > 1.0)
        if np.any(out):
            k = int(np.argmax(out))
            raise invalid(where, "values", "restitutions in [0, 1]", values,
                          f"{r[k]:g} at speed {u[k]:g}")
        law = cls("table", speeds=tuple(float(v) for v in u),
                  values=tuple(float(v) for v in r))
        law._check(where, np.union1d(u, _refine(u)))
        return law

    @classmethod
    def tanh(cls, r0: float, r1: float, u0: float) -> "Restitution":
        """r(u) = r0 − r1 tanh(u/u0): r0 at rest, r0 − r1 at high speed, u0 > 0 the
        speed over which it changes."""
        where = "Restitution.tanh"
        r0 = check_float("r0", r0, 0.0, 1.0, lo_open=False, where=where)
        r1 = check_float("r1", r1, -1.0, 1.0, lo_open=False, where=where)
        u0 = check_float("u0", u0, 0.0, where=where)
        if not 0.0 <= r0 - r1 <= 1.0:
            raise InputError(f"{where}: r0 − r1 (r at high speed) must lie in [0, 1]; got "
                             f"{r0 - r1:g}", where=where, name="r1")
        law = cls("tanh", r0=r0, r1=r1, u0=u0)
        law._check(where, u0 * _CHECK)
        return law

    @classmethod
    def callable(cls, function: Callable[[np.ndarray], Any]) -> "Restitution":
        """Any vectorised function r(u) (checked at speeds from 1e-6 to 1e6)."""
        where = "Restitution"
        if not callable(function):
            raise invalid(where, "r", "a number, a Restitution law or a function r(u)",
                          function)
        law = cls("callable", function=function)
        law._check(where, _CHECK)
        return law

    @classmethod
    def of(cls, value: Any, where: str | None = "Wall", name: str = "r"
           ) -> "float | Restitution":
        """A wall's ``r`` as given: a number in [0, 1] (returned as a float), a
        Restitution, a scene table ({speeds, values} or {law = "tanh", r0, r1, u0}) or
        a function r(u)."""
        if isinstance(value, Restitution):
            return value
        if isinstance(value, numbers.Real) and not isinstance(value, bool):
            return check_float(name, value, 0.0, 1.0, lo_open=False, where=where)
        if isinstance(value, dict):
            return cls.from_dict(value, where, name)
        if callable(value) and not isinstance(value, type):
            try:
                return cls.callable(value)
            except InputError as exc:
                raise InputError(f"{where}: {name}: {exc.rule}", where=where,
                                 name=name) from None
        raise invalid(where, name, "a number in [0, 1], a Restitution law, a table "
                      "{speeds, values}, {law = \"tanh\", r0, r1, u0} or a function r(u)",
                      value)

    @classmethod
    def from_dict(cls, data: dict, where: str | None = "Wall", name: str = "r"
                  ) -> "Restitution":
        """Inverse of :meth:`to_dict` (the scene form)."""
        law = data.get("law", "table")
        keys = {"table": {"speeds", "values"}, "tanh": {"r0", "r1", "u0"}}.get(law)
        if keys is None:
            raise invalid(where, f"{name}.law", f"one of {list(LAWS)}", law)
        given = set(data) - {"law"}
        if given != keys:
            missing, unknown = sorted(keys - given), sorted(given - keys)
            raise invalid(where, name, f"a table {{{', '.join(sorted(keys))}}} for the "
                          f"{law} law", data, f"missing {missing}" if missing
                          else f"unknown keys {unknown}")
        try:
            return (cls.table(data["speeds"], data["values"]) if law == "table"
                    else cls.tanh(data["r0"], data["r1"], data["u0"]))
        except InputError as exc:
            key = f"{name}.{exc.name}" if exc.name in keys else name
            text = exc.keyed(key) if exc.name in keys else f"{key}: {exc.rule}"
            raise InputError(f"{where}: {text}" if where else text, where=where,
                             name=key) from None

    # -- the law ------------------------------------------------------------------
    def __call__(self, u: Any) -> np.ndarray:
        """r(u) at the speeds ``u`` (≥ 0)."""
        u = np.asarray(u, dtype=float)
        if self.kind == "table":
            return np.interp(u, self.speeds, self.values)
        if self.kind == "tanh":
            return self.r0 - self.r1 * np.tanh(u / self.u0)
        with np.errstate(all="ignore"):
            out = np.asarray(self.function(u), dtype=float)
        return np.broadcast_to(out, u.shape).copy() if out.shape != u.shape else out

    def rebound(self, u: Any) -> np.ndarray:
        """φ(u) = u r(u): the speed after an impact at speed ``u``."""
        u = np.asarray(u, dtype=float)
        return u * self(u)

    @property
    def constant(self) -> float | None:
        """r where the law does not depend on u (a table of equal values), else None."""
        if self.kind == "table" and len(set(self.values)) == 1:
            return self.values[0]
        if self.kind == "tanh" and self.r1 == 0.0:
            return self.r0
        return None

    def bounds(self, u_max: float = math.inf) -> tuple[float, float]:
        """(min, max) of r over speeds in [0, ``u_max``] (on the check grid for a
        function)."""
        if self.kind == "table":
            u = np.asarray(self.speeds)
            pts = np.append(u[u <= u_max], min(u_max, u[-1]) if math.isfinite(u_max)
                            else u[-1])
            r = self(pts)
        elif self.kind == "tanh":
            r = self(np.array([0.0, u_max if math.isfinite(u_max) else 1e300]))
        else:
            grid = _CHECK if not math.isfinite(u_max) else np.linspace(0.0, u_max, 2049)
            r = self(grid)
        return float(np.min(r)), float(np.max(r))

    def kernel_table(self, u_max: float) -> tuple[np.ndarray, np.ndarray]:
        """(speeds, values) of a piecewise-linear table for compiled kernels: a table's
        own points; a function's at :data:`TABLE_POINTS` speeds up to ``u_max``
        (constant beyond); a tanh law is evaluated exactly by the kernels."""
        if self.kind == "table":
            return np.asarray(self.speeds), np.asarray(self.values)
        u = np.linspace(0.0, float(u_max), TABLE_POINTS)
        return u, self(u)

    # -- identity and storage -----------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The scene form: {speeds, values} or {law = "tanh", r0, r1, u0}; a function
        is stored as its table at :data:`TABLE_POINTS` speeds up to 1e3 u-units
        (``law = "table"``, what a reloaded file uses)."""
        if self.kind == "tanh":
            return {"law": "tanh", "r0": self.r0, "r1": self.r1, "u0": self.u0}
        if self.kind == "table":
            return {"speeds": list(self.speeds), "values": list(self.values)}
        u, r = self.kernel_table(1e3)
        return {"speeds": u.tolist(), "values": r.tolist()}

    def _key(self) -> tuple:
        return (self.kind, self.speeds, self.values, self.r0, self.r1, self.u0,
                id(self.function) if self.function is not None else None)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Restitution) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        if self.kind == "table":
            return f"Restitution.table({list(self.speeds)}, {list(self.values)})"
        if self.kind == "tanh":
            return f"Restitution.tanh({self.r0}, {self.r1}, {self.u0})"
        return f"Restitution.callable({show(self.function)})"

    def __reduce__(self):
        if self.kind == "table":
            return (Restitution.table, (self.speeds, self.values))
        if self.kind == "tanh":
            return (Restitution.tanh, (self.r0, self.r1, self.u0))
        return (Restitution.callable, (self.function,))

    # -- the rules ----------------------------------------------------------------
    def _check(self, where: str, u: np.ndarray) -> None:
        """0 ≤ r ≤ 1 and u r(u) strictly increasing at the speeds ``u`` (a law constant
        in u: 0 ≤ r ≤ 1 only)."""
        r = self(u)
        bad = ~np.isfinite(r) | (r < 0.0) | (r > 1.0)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise InputError(f"{where}: r(u) must lie in [0, 1] (no impact adds energy); "
                             f"r = {float(r[k]):.4g} at u = {u[k]:.3g}", where=where,
                             name="r")
        if self.constant is not None:
            return
        phi = u * r
        falls = np.diff(phi) <= 0.0
        if np.any(falls):
            k = int(np.argmax(falls))
            raise InputError(f"{where}: u·r(u) must increase strictly with the impact speed "
                             f"u (the impact map must be one-to-one); it does not beyond "
                             f"u = {u[k]:.3g} (u·r(u) = {phi[k]:.3g} there)", where=where,
                             name="r")
        if self.kind == "table" and self.values[-1] == 0.0:
            raise InputError(f"{where}: u·r(u) must increase strictly with the impact "
                             f"speed u; r = 0 beyond u = {self.speeds[-1]:.3g} makes it "
                             "flat there", where=where, name="r")


def _refine(u: np.ndarray, per: int = 64) -> np.ndarray:
    """``per`` speeds inside each segment of a table, and a few beyond its end."""
    inside = (u[:-1, None] + np.diff(u)[:, None] * np.linspace(0, 1, per + 1)[None, 1:]
              ).ravel() if u.size > 1 else np.empty(0)
    top = u[-1] if u[-1] > 0 else 1.0
    return np.concatenate([inside, top * np.array([1.5, 2.0, 10.0])])
