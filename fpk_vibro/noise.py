"""Coloured external noise: an Ornstein–Uhlenbeck force ζ of correlation time τ.

With ``VibroImpactSystem(..., external=OrnsteinUhlenbeck(tau=τ))`` the external
white noise ξ1 is replaced by ζ,

    dζ = −ζ/τ dt + sqrt(2 D1)/τ dW,      x'' + c x' + a x + b x³ = ζ(t) + x ξ2(t),

so E[ζ(t) ζ(t + s)] = (D1/τ) e^{−|s|/τ}: its variance is D1/τ and its spectral density
at zero frequency, ∫ E[ζ(t)ζ(t+s)] ds = 2 D1, is that of the white noise of the same
D1; as τ → 0 the system becomes the white-noise one (docs/theory.md, §Coloured
noise).  The parametric noise ξ2 stays white.  The state is (x, y, ζ); at an impact ζ
is continuous and only y maps.  ``external=None`` (the default) is the white noise.

In a scene: an ``[external]`` table ``tau = …``.

Examples
--------
>>> from fpk_vibro import OrnsteinUhlenbeck
>>> ou = OrnsteinUhlenbeck(tau=0.5)
>>> ou.variance(D1=0.01), round(ou.correlation(D1=0.01, s=0.5), 6)
(0.02, 0.007358)
>>> OrnsteinUhlenbeck(tau=0)
Traceback (most recent call last):
...
fpk_vibro._checks.InputError: OrnsteinUhlenbeck: tau must be a finite number > 0; got 0
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import check_float, from_table

__all__ = ["OrnsteinUhlenbeck", "EXTERNAL_KEYS"]

#: The keys of an ``[external]`` table.
EXTERNAL_KEYS = ("tau",)


@dataclass(frozen=True)
class OrnsteinUhlenbeck:
    """The external force ζ as an Ornstein–Uhlenbeck process (module docstring).

    Parameters
    ----------
    tau : float
        Correlation time τ > 0 (the units of t).  Its intensity is the system's D1.
    """

    tau: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau", check_float("tau", self.tau, lo=0.0,
                                                    where="OrnsteinUhlenbeck"))

    def variance(self, D1: float) -> float:
        """E[ζ²] = D1/τ in the stationary state."""
        return float(D1) / self.tau

    def correlation(self, D1: float, s: Any) -> Any:
        """E[ζ(t) ζ(t + s)] = (D1/τ) e^{−|s|/τ}."""
        out = self.variance(D1) * np.exp(-np.abs(np.asarray(s, float)) / self.tau)
        return float(out) if out.ndim == 0 else out

    def spectrum(self, D1: float, omega: Any) -> Any:
        """Two-sided spectral density S_ζ(ω) = (D1/π) / (1 + ω²τ²); S_ζ(0) = D1/π is
        that of the white noise 2 D1 δ(s)."""
        out = (float(D1) / math.pi) / (1.0 + np.square(np.asarray(omega, float) * self.tau))
        return float(out) if out.ndim == 0 else out

    def to_dict(self) -> dict[str, float]:
        """The scene table {tau}."""
        return {"tau": self.tau}

    @classmethod
    def of(cls, value: Any, where: str | None = "VibroImpactSystem",
           name: str = "external") -> "OrnsteinUhlenbeck | None":
        """None (white noise), an :class:`OrnsteinUhlenbeck`, or its table {tau}."""
        return from_table(cls, value, EXTERNAL_KEYS, ("tau",), where, name,
                          "OrnsteinUhlenbeck(tau=τ) or its table {tau} (None: white noise)")
