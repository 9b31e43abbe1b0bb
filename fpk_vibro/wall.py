"""A rigid wall of the strip and its law: position, restitution (a number or a law
r(u) of the impact speed, :mod:`fpk_vibro.restitution`), the velocity and energy maps
of one impact (docs/theory.md, §Walls)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import InputError, at, invalid
from .option_schema import REQUIRED, Option
from .restitution import Restitution

#: What a wall's ``r`` may be, in messages and the key table.
R_ALLOWED = ("a number in [0, 1], or a law r(u) of the impact speed u: {speeds = [...], "
             "values = [...]} (piecewise linear) or {law = \"tanh\", r0, r1, u0} "
             "(r0 − r1 tanh(u/u0))")

__all__ = ["Wall", "WALL_FIELDS", "Restitution"]

#: The fields of one wall ([barriers.left] / [barriers.right] in a scene).
WALL_FIELDS: dict[str, Option] = {
    "position": Option(REQUIRED, "wall position x_w (any side of the equilibrium)", "float",
                       lo=float("-inf"), unit="m"),
    "r": Option(1.0, "restitution of this wall, y⁺ = −r(|y⁻|) y⁻: a coefficient or a law "
                "of the impact speed", "custom", check=lambda n, v, w: Restitution.of(v, w, n),
                allowed=R_ALLOWED),
}


@dataclass(frozen=True)
class Wall:
    """A rigid wall at x = ``position`` with restitution ``r`` (y⁺ = −r y⁻).

    Parameters
    ----------
    position : float
        Where the wall stands; any finite value (at or beyond the equilibrium too).
    r : float, Restitution or callable, default 1
        Restitution coefficient in [0, 1] (1 elastic, 0 plastic), or a law r(u) of the
        impact speed u = |y⁻|: :meth:`Restitution.table`, :meth:`Restitution.tanh`, a
        vectorised function, or its scene table (:meth:`Restitution.of`).

    Examples
    --------
    >>> from fpk_vibro import Restitution, Wall
    >>> w = Wall(0.6, r=Restitution.tanh(0.9, 0.2, 1.0))
    >>> [round(float(v), 4) for v in w.outgoing([1.0, -2.0])]
    [-0.7477, 1.4144]
    >>> w.elastic, Wall(0.6).elastic
    (False, True)
    """

    position: float
    r: "float | Restitution" = 1.0

    def __post_init__(self) -> None:
        for name, opt in WALL_FIELDS.items():
            object.__setattr__(self, name, opt.validate(name, getattr(self, name), "Wall"))

    @property
    def law(self) -> Restitution | None:
        """The law r(u), or None for a constant coefficient (``r`` a number)."""
        return self.r if isinstance(self.r, Restitution) else None

    @property
    def elastic(self) -> bool:
        """True when no impact loses energy: r ≡ 1."""
        law = self.law
        return self.r == 1.0 if law is None else law.bounds() == (1.0, 1.0)

    def r_at(self, u: np.ndarray) -> np.ndarray:
        """r at the impact speeds ``u`` (≥ 0), an array of their shape."""
        u = np.asarray(u, dtype=float)
        return np.full(u.shape, float(self.r)) if self.law is None else self.law(u)

    def r_bounds(self, u_max: float = float("inf")) -> tuple[float, float]:
        """(min, max) of r over impact speeds in [0, ``u_max``]."""
        return (float(self.r), float(self.r)) if self.law is None else self.law.bounds(u_max)

    def outgoing(self, v: np.ndarray) -> np.ndarray:
        """The velocity after an impact at velocity ``v``: y⁺ = −r(|v|) v."""
        v = np.asarray(v, dtype=float)
        return -self.r_at(np.abs(v)) * v

    def loss(self, v: np.ndarray) -> np.ndarray:
        """The energy one impact at velocity ``v`` removes: ½ (1 − r(|v|)²) v²."""
        v = np.asarray(v, dtype=float)
        r = self.r_at(np.abs(v))
        return 0.5 * (1.0 - r * r) * np.square(v)

    def to_dict(self) -> dict[str, Any]:
        """{position, r}: r a number or the law's scene table."""
        return {"position": self.position,
                "r": self.r if self.law is None else self.law.to_dict()}

    @classmethod
    def of(cls, value: Any, side: str, where: str | None = "VibroImpactSystem") -> "Wall | None":
        """A Wall from a Wall, a {position, r} table or None (no wall)."""
        if value is None or isinstance(value, Wall):
            return value
        if isinstance(value, dict):
            unknown = set(value) - set(WALL_FIELDS)
            if unknown or "position" not in value:
                raise invalid(where, side, "a Wall or a table {position, r}",
                              value, f"unknown keys {sorted(unknown)}" if unknown
                              else "position is required")
            try:
                return cls(**value)
            except InputError as exc:
                raise InputError(at(where, f"{side}.{exc.name} {exc.rule}"), where=where,
                                 name=side) from None
        raise invalid(where, side, "a Wall, a table {position, r} or None", value)
