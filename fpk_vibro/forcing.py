"""Deterministic harmonic forcing F cos(Ωt + φ0) added to the random excitation.

With ``VibroImpactSystem(..., forcing=Harmonic(amplitude=F, frequency=Ω, phase=φ0))``
the equation of motion is

    x'' + c x' + a x + b x³ = F cos(Ωt + φ0) + ξ1(t) + x ξ2(t),

and the response is not stationary but periodic: its density repeats with the period
2π/Ω (docs/theory.md, §Harmonic forcing).  A *phase* φ is Ωt + φ0 taken mod 2π: the
forcing at phase φ is F cos φ, and ``phases`` are radians in [0, 2π).  The first
harmonic of the mean, E[x](t) ≈ x̄ + A cos(Ωt + φ0 − θ), is described by its amplitude
A ≥ 0 and lag θ in [0, 2π) (:func:`first_harmonic`).

In a scene: a ``[forcing]`` table ``amplitude = …``, ``frequency = …``, ``phase = …``.

Examples
--------
>>> from fpk_vibro import Harmonic
>>> f = Harmonic(amplitude=0.05, frequency=0.9)
>>> round(f.period, 4), float(f.force(0.0)), f.phase_at(f.period / 2)
(6.9813, 0.05, 3.141592653589793)
>>> Harmonic(amplitude=0.05, frequency=0.0)
Traceback (most recent call last):
...
fpk_vibro._checks.InputError: Harmonic: frequency must be a finite number > 0; got 0.0
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import check_float, from_table, invalid

__all__ = ["Harmonic", "FORCING_KEYS", "first_harmonic", "check_phases"]

#: The keys of a ``[forcing]`` table.
FORCING_KEYS = ("amplitude", "frequency", "phase")
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Harmonic:
    """F cos(Ωt + φ0) (module docstring).

    Parameters
    ----------
    amplitude : float
        F ≥ 0 (force per unit mass, the units of a x).
    frequency : float
        Ω > 0 (rad per unit time).
    phase : float, default 0
        φ0, any finite number (stored mod 2π).
    """

    amplitude: float
    frequency: float
    phase: float = 0.0

    def __post_init__(self) -> None:
        where = "Harmonic"
        F = check_float("amplitude", self.amplitude, lo=0.0, lo_open=False, where=where)
        W = check_float("frequency", self.frequency, lo=0.0, where=where)
        p = check_float("phase", self.phase, where=where)
        object.__setattr__(self, "amplitude", F)
        object.__setattr__(self, "frequency", W)
        object.__setattr__(self, "phase", p % TWO_PI)

    @property
    def period(self) -> float:
        """2π/Ω."""
        return TWO_PI / self.frequency

    def force(self, t: Any) -> np.ndarray:
        """F cos(Ωt + φ0) at the times ``t``."""
        return self.amplitude * np.cos(self.frequency * np.asarray(t, float) + self.phase)

    def phase_at(self, t: Any) -> Any:
        """The phase (Ωt + φ0) mod 2π at the times ``t``."""
        out = np.mod(self.frequency * np.asarray(t, float) + self.phase, TWO_PI)
        return float(out) if out.ndim == 0 else out

    def time_of(self, phase: Any) -> Any:
        """The first time t ≥ 0 at which the phase is ``phase``."""
        out = np.mod(np.asarray(phase, float) - self.phase, TWO_PI) / self.frequency
        return float(out) if out.ndim == 0 else out

    def to_dict(self) -> dict[str, float]:
        """The scene table {amplitude, frequency, phase}."""
        return {"amplitude": self.amplitude, "frequency": self.frequency,
                "phase": self.phase}

    @classmethod
    def of(cls, value: Any, where: str | None = "VibroImpactSystem",
           name: str = "forcing") -> "Harmonic | None":
        """None, a :class:`Harmonic`, or its table {amplitude, frequency[, phase]}."""
        return from_table(cls, value, FORCING_KEYS, ("amplitude", "frequency"), where, name,
                          "Harmonic(amplitude=F, frequency=Ω, phase=φ0) or its table "
                          "{amplitude, frequency, phase}")


def check_phases(where: str, phases: Any) -> np.ndarray:
    """Phases in radians in [0, 2π): a non-empty 1-D sequence of finite numbers (kept
    in the order given); anything else one line naming ``phases``."""
    rule = "a non-empty sequence of phases in radians in [0, 2π)"
    try:
        p = np.atleast_1d(np.asarray(phases, dtype=float))
    except (TypeError, ValueError):
        raise invalid(where, "phases", rule, phases) from None
    if p.ndim != 1 or p.size == 0 or isinstance(phases, (str, bytes)):
        raise invalid(where, "phases", rule, phases)
    bad = ~np.isfinite(p) | (p < 0) | (p >= TWO_PI)
    if np.any(bad):
        raise invalid(where, "phases", rule, phases, f"entry {int(np.argmax(bad))} is "
                      f"{p[int(np.argmax(bad))]!r}")
    return p


def first_harmonic(phases: np.ndarray, values: np.ndarray) -> tuple[float, float, float]:
    """(x̄, A, θ) of ``values`` at ``phases`` equally spaced over one period (the
    discrete Fourier coefficients): values ≈ x̄ + A cos(φ − θ), φ the phase Ωt + φ0,
    A ≥ 0, θ in [0, 2π)."""
    phases, values = np.asarray(phases, float), np.asarray(values, float)
    n = phases.size
    mean = float(values.mean())
    c = 2.0 / n * float(np.sum(values * np.cos(phases)))
    s = 2.0 / n * float(np.sum(values * np.sin(phases)))
    return mean, math.hypot(c, s), math.atan2(s, c) % TWO_PI
