"""A rigid wall of the strip and its law: position, restitution, the velocity and
energy maps of one impact (docs/theory.md, §Walls)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import InputError, at, invalid
from .option_schema import REQUIRED, Option

__all__ = ["Wall", "WALL_FIELDS"]

#: The fields of one wall ([barriers.left] / [barriers.right] in a scene).
WALL_FIELDS: dict[str, Option] = {
    "position": Option(REQUIRED, "wall position x_w (any side of the equilibrium)", "float",
                       lo=float("-inf"), unit="m"),
    "r": Option(1.0, "restitution coefficient of this wall, y⁺ = −r y⁻", "float", lo=0.0,
                hi=1.0),
}


@dataclass(frozen=True)
class Wall:
    """A rigid wall at x = ``position`` with restitution ``r`` (y⁺ = −r y⁻).

    Parameters
    ----------
    position : float
        Where the wall stands; any finite value (at or beyond the equilibrium too).
    r : float, default 1
        Restitution coefficient in [0, 1]: 1 elastic, 0 plastic.
    """

    position: float
    r: float = 1.0

    def __post_init__(self) -> None:
        for name, opt in WALL_FIELDS.items():
            object.__setattr__(self, name, opt.validate(name, getattr(self, name), "Wall"))

    def outgoing(self, v: np.ndarray) -> np.ndarray:
        """The velocity after an impact at velocity ``v`` (the wall law y⁺ = −r y⁻)."""
        return -self.r * np.asarray(v, dtype=float)

    def loss(self, v: np.ndarray) -> np.ndarray:
        """The energy one impact at velocity ``v`` removes: ½ (1 − r²) v²."""
        return 0.5 * (1.0 - self.r * self.r) * np.square(np.asarray(v, dtype=float))

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
