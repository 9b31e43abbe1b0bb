"""The vibro-impact Duffing oscillator shared by every method (DESIGN §1).

    x'' + c x' + a x + b x³ = ξ1(t) + x ξ2(t),   |x| < Δ
    y⁺ = −r y⁻   at x = ±Δ

with E[ξi(t) ξi(t + τ)] = 2 Di δ(τ).  In Itô form (no Wong–Zakai correction)

    dx = y dt,   dy = −(c y + a x + b x³) dt + sqrt(2 D1 + 2 D2 x²) dW.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import InputError, check_float, invalid
from .options import REQUIRED, Option

__all__ = ["VibroImpactSystem", "BARRIER_KINDS", "FIELDS", "check_system"]

BARRIER_KINDS = ("both", "right", "none")

#: The model's fields, declared once: validation here, the scene's [system] and
#: [barriers] tables and the README's key table come from this.
FIELDS: dict[str, Option] = {
    "a": Option(REQUIRED, "linear stiffness", "float", lo=float("-inf"), unit="1/s²",
                scene="system.a"),
    "b": Option(REQUIRED, "cubic stiffness", "float", lo=float("-inf"), unit="1/(m² s²)",
                scene="system.b"),
    "c": Option(REQUIRED, "damping, the paper's ε²c", "float", lo=0.0, unit="1/s",
                scene="system.c"),
    "D1": Option(REQUIRED, "external noise intensity, the paper's ε²D11", "float", lo=0.0,
                 lo_open=True, unit="m²/s³", scene="system.D1",
                 why="without external noise the origin is a noise-free fixed point and "
                     "there is no stationary density"),
    "D2": Option(0.0, "parametric noise intensity, the paper's ε²D22", "float", lo=0.0,
                 unit="1/s³", scene="system.D2"),
    "delta": Option(None, "barrier position Δ; required unless sides = \"none\"", "float",
                    lo=0.0, lo_open=True, unit="m", scene="barriers.delta"),
    "r": Option(1.0, "restitution coefficient, y⁺ = −r y⁻", "float", lo=0.0, hi=1.0,
                scene="barriers.r"),
    "barriers": Option("both", "barriers at ±Δ, at +Δ only, or none", "choice",
                       choices=BARRIER_KINDS, scene="barriers.sides"),
}


def _fail(field: str, allowed: str, value: Any, why: str = "") -> InputError:
    return invalid("VibroImpactSystem", field, allowed, value, why)


@dataclass(frozen=True, kw_only=True)
class VibroImpactSystem:
    """Duffing oscillator between rigid barriers under external and parametric noise.

    Parameters
    ----------
    a, b : float
        Linear and cubic stiffness, G(x) = a x²/2 + b x⁴/4 (paper Eq. 4).  With
        barriers on both sides any real values are allowed (softening b < 0,
        double well a < 0 < b); a side without barrier needs a confining
        potential (b > 0, or b = 0 and a > 0).
    c : float
        Damping, c ≥ 0.  The paper's ε²c.
    D1 : float
        External noise intensity, D1 > 0: E[ξ1(t) ξ1(t+τ)] = 2 D1 δ(τ).  The
        paper's ε²D11.
    D2 : float
        Parametric noise intensity, D2 ≥ 0 (noise x ξ2(t)).  The paper's ε²D22.
    delta : float or None
        Barrier position Δ > 0 (barriers at x = ±Δ, or only +Δ).  Ignored (may
        be None) when ``barriers="none"``.
    r : float
        Restitution coefficient, 0 ≤ r ≤ 1 (paper Eq. 1b): y⁺ = −r y⁻.
    barriers : {"both", "right", "none"}
        Bilateral barriers at ±Δ (the paper's case), a unilateral barrier at +Δ,
        or no barrier.

    Raises
    ------
    ValueError
        For any invalid field, naming the field, the allowed range and the value.
    """

    a: float
    b: float
    c: float
    D1: float
    D2: float = 0.0
    delta: float | None = None
    r: float = 1.0
    barriers: str = "both"

    def __post_init__(self) -> None:
        where = "VibroImpactSystem"
        for name in ("barriers",) + tuple(k for k in FIELDS if k != "barriers"):
            value = getattr(self, name)
            if name == "delta" and not self.has_barrier:      # ignored: None or finite
                if value is not None:
                    object.__setattr__(self, name, check_float(name, value, where=where))
                continue
            if name == "delta" and value is None:
                raise _fail(name, "a finite number > 0 when there is a barrier", value)
            object.__setattr__(self, name, FIELDS[name].validate(name, value, where))
        if self.barriers != "both" and not (self.b > 0 or (self.b == 0 and self.a > 0)):
            field = "b" if self.b != 0 else "a"
            raise _fail(field, "b > 0, or b = 0 with a > 0, on a side without barrier",
                        getattr(self, field),
                        f"with barriers={self.barriers!r} the potential must confine x "
                        f"where there is no barrier (a={self.a}, b={self.b})")
        if self.c == 0 and (self.r == 1.0 or not self.has_barrier):
            raise _fail("c", "> 0 when there is no other energy loss (r = 1 or no barrier)",
                        self.c, "without any dissipation there is no stationary density")

    # -- construction -------------------------------------------------------------
    @classmethod
    def paper(cls, r: float = 0.98, **overrides: Any) -> "VibroImpactSystem":
        """The parameters of Yang et al. (2016), Figs 3–5.

        a = 1, b = 0.2, c = 0.025, D1 = D2 = 0.01, Δ = 0.6, bilateral barriers;
        any field can be overridden by keyword (e.g. ``delta=1.0`` for Figs 6–7).
        """
        fields = dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01, delta=0.6, r=r, barriers="both")
        unknown = set(overrides) - set(fields)
        if unknown:
            raise ValueError(f"VibroImpactSystem.paper: unknown field(s) {sorted(unknown)}; "
                             f"allowed: {sorted(fields)}")
        fields.update(overrides)
        return cls(**fields)

    def replace(self, **changes: Any) -> "VibroImpactSystem":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "VibroImpactSystem":
        return cls(**data)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    # -- geometry and energy ------------------------------------------------------
    @property
    def has_barrier(self) -> bool:
        return self.barriers != "none"

    @property
    def x_bounds(self) -> tuple[float, float]:
        """(left, right) limits of the strip; ±inf where there is no barrier."""
        if self.barriers == "both":
            return (-self.delta, self.delta)
        if self.barriers == "right":
            return (-math.inf, self.delta)
        return (-math.inf, math.inf)

    def in_strip(self, x: np.ndarray) -> np.ndarray:
        """Boolean mask of points with left ≤ x ≤ right."""
        lo, hi = self.x_bounds
        x = np.asarray(x, dtype=float)
        return (x >= lo) & (x <= hi)

    def potential(self, x: np.ndarray) -> np.ndarray:
        """G(x) = a x²/2 + b x⁴/4 (paper Eq. 4)."""
        x2 = np.square(np.asarray(x, dtype=float))
        return x2 * (0.5 * self.a + 0.25 * self.b * x2)

    def energy(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """H = y²/2 + G(x) (paper Eq. 3)."""
        return 0.5 * np.square(np.asarray(y, dtype=float)) + self.potential(x)

    @property
    def barrier_energy(self) -> float:
        """G(Δ): energies above it impact (paper Eq. 5).  inf without barrier."""
        if not self.has_barrier:
            return math.inf
        return float(self.potential(self.delta))

    def amplitude(self, H: np.ndarray) -> np.ndarray:
        """Amplitude A with G(A) = H, A² = 4H / (sqrt(a² + 4bH) + a) (DESIGN §1).

        The cancellation-free form.  NaN where no real amplitude exists
        (softening b < 0 above the potential's maximum, or a ≤ 0 near H = 0).
        """
        H = np.asarray(H, dtype=float)
        disc = self.a * self.a + 4.0 * self.b * H
        with np.errstate(invalid="ignore", divide="ignore"):
            root = np.sqrt(disc)
            den = root + self.a
            A2 = np.where(disc >= 0, 4.0 * H / den, np.nan)
            A2 = np.where(H == 0, 0.0, A2)
            A2 = np.where(A2 >= 0, A2, np.nan)
        return np.sqrt(A2)

    def noise_intensity(self, x: np.ndarray) -> np.ndarray:
        """D(x) = D1 + D2 x²: the diffusion coefficient of the FPK (DESIGN §3)."""
        return self.D1 + self.D2 * np.square(np.asarray(x, dtype=float))

    @property
    def effects(self) -> list[str]:
        """The physical effects active in this system (terms that are non-zero)."""
        out = []
        if self.a != 0 or self.b != 0:
            out.append("restoring")
        if self.c != 0:
            out.append("damping")
        out.append("external_noise")
        if self.D2 != 0:
            out.append("parametric_noise")
        if self.has_barrier:
            out.append("impact_right")
        if self.barriers == "both":
            out.append("impact_left")
        return out


def check_system(where: str, system: Any) -> VibroImpactSystem:
    """``system`` if it is a :class:`VibroImpactSystem`, else a one-line error."""
    if not isinstance(system, VibroImpactSystem):
        raise invalid(where, "system", "a VibroImpactSystem", system)
    return system
