"""The initial condition of transient problems, shared by every transient method.

A transient solver (Monte Carlo, finite elements, averaging) starts from an
initial density of the state (x, y).  Users give it as one of

- ``{"mean": (x0, y0), "std": (sx, sy)}``: independent Gaussians in x and y,
  the x component truncated to the strip ``left ≤ x ≤ right`` of the system
  (docs/theory.md, §Walls); a standard deviation 0 means exactly that value (a point mass
  in that component);
- a callable ``initial(n, rng)`` returning ``n`` samples, either as an array of
  shape ``(n, 2)`` (columns x, y) or as a pair ``(x, y)`` of arrays of shape
  ``(n,)``; ``rng`` is a :class:`numpy.random.Generator` the callable should
  use so that a seed reproduces the run.

:func:`parse_initial` validates either form (``ValueError`` naming the field,
the allowed range and the value) and returns an :class:`InitialCondition` with
``sample(n, rng)`` and, for the Gaussian form, the density ``pdf(x, y)`` that
a grid-based method projects on its mesh.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import special

from ._checks import invalid
from .model import VibroImpactSystem

__all__ = ["InitialCondition", "parse_initial", "parse_times"]


def _bad(field: str, allowed: str, value: Any) -> ValueError:
    return invalid("initial", field, allowed, value)


def _pair(spec: Mapping, key: str) -> tuple[float, float]:
    if key not in spec:
        raise _bad(key, "given (a pair of finite numbers)", "<missing>")
    val = spec[key]
    try:
        arr = np.asarray(val, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise _bad(key, "a pair of finite numbers", val) from None
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise _bad(key, "a pair of finite numbers", val)
    return float(arr[0]), float(arr[1])


@dataclass(frozen=True)
class InitialCondition:
    """A validated initial condition (see :func:`parse_initial`).

    Attributes
    ----------
    system : VibroImpactSystem
        The system whose strip bounds the x samples.
    mean, std : tuple of float or None
        The Gaussian form's parameters (``None`` for a sampler callable).
    sampler : callable or None
        The user's sampler (``None`` for the Gaussian form).
    """

    system: VibroImpactSystem
    mean: tuple[float, float] | None = None
    std: tuple[float, float] | None = None
    sampler: Callable[..., Any] | None = None

    @property
    def is_gaussian(self) -> bool:
        return self.sampler is None

    @property
    def has_density(self) -> bool:
        """True when :meth:`pdf` exists (Gaussian form with both std > 0)."""
        return self.is_gaussian and self.std[0] > 0 and self.std[1] > 0

    # -- sampling -----------------------------------------------------------------
    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``n`` states; returns ``(x, y)``, float64 arrays of shape ``(n,)``.

        Raises
        ------
        ValueError
            If a user sampler returns the wrong shape, a non-finite value or an x
            outside the strip.
        """
        n = int(n)
        if self.sampler is None:
            x = self._truncated_x(n, rng)
            y = np.full(n, self.mean[1]) if self.std[1] == 0 else \
                self.mean[1] + self.std[1] * rng.standard_normal(n)
            return x, y
        out = self.sampler(n, rng)
        try:
            if isinstance(out, tuple) and len(out) == 2:
                x = np.asarray(out[0], dtype=float).reshape(-1)
                y = np.asarray(out[1], dtype=float).reshape(-1)
                arr = None
            else:
                arr = np.asarray(out, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise _bad("initial(n, rng)", "numbers: an array of shape (n, 2) or a pair (x, y)",
                       out) from None
        if arr is not None:
            if arr.ndim != 2 or arr.shape[1] != 2:
                raise _bad("initial(n, rng)", f"an array of shape ({n}, 2) or a pair (x, y)",
                           f"<array of shape {arr.shape}>")
            x, y = arr[:, 0].copy(), arr[:, 1].copy()
        if x.shape != (n,) or y.shape != (n,):
            raise _bad("initial(n, rng)", f"{n} samples", f"<{x.shape[0]} x, {y.shape[0]} y>")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise _bad("initial(n, rng) samples", "finite", "<NaN or inf>")
        lo, hi = self.system.x_bounds
        bad = (x < lo) | (x > hi)
        if np.any(bad):
            raise _bad("initial(n, rng) x samples", f"in the strip [{lo}, {hi}]",
                       float(x[np.argmax(bad)]))
        return x, y

    def _truncated_x(self, n: int, rng: np.random.Generator) -> np.ndarray:
        mx, sx = self.mean[0], self.std[0]
        if sx == 0:
            return np.full(n, mx)
        lo, hi = self.system.x_bounds
        # inverse-CDF sampling of the truncated normal, on the side of the mean
        # that keeps the CDF away from 1 (no cancellation in the tails)
        a, b = (lo - mx) / sx, (hi - mx) / sx
        u = rng.random(n)
        if a > 0:          # whole interval right of the mean: use the mirrored tail
            pa, pb = special.ndtr(-a), special.ndtr(-b)
            z = -special.ndtri(pa + u * (pb - pa))
        else:
            pa, pb = special.ndtr(a), special.ndtr(b)
            z = special.ndtri(pa + u * (pb - pa))
        return np.clip(mx + sx * z, lo, hi)

    # -- density ------------------------------------------------------------------
    def pdf(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Initial density p0(x, y) (Gaussian form with both std > 0), zero off the strip.

        Raises
        ------
        ValueError
            For a sampler callable or a point mass (std 0), which have no density.
        """
        if not self.has_density:
            raise ValueError("initial: pdf needs the Gaussian form with std > 0 in both "
                             f"components; got {self.describe()}")
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        (mx, my), (sx, sy) = self.mean, self.std
        lo, hi = self.system.x_bounds
        mass = special.ndtr((hi - mx) / sx) - special.ndtr((lo - mx) / sx)
        gx = np.exp(-0.5 * ((x - mx) / sx) ** 2) / (sx * math.sqrt(2 * math.pi) * mass)
        gy = np.exp(-0.5 * ((y - my) / sy) ** 2) / (sy * math.sqrt(2 * math.pi))
        return np.where((x >= lo) & (x <= hi), gx * gy, 0.0)

    def describe(self) -> str:
        if self.sampler is not None:
            return f"sampler {getattr(self.sampler, '__name__', repr(self.sampler))}"
        return f"Gaussian mean={self.mean}, std={self.std}"


def parse_initial(spec: Any, system: VibroImpactSystem) -> InitialCondition:
    """Validate an ``initial`` argument (see module docstring) for ``system``.

    Parameters
    ----------
    spec : dict or callable or InitialCondition
        ``{"mean": (x0, y0), "std": (sx, sy)}`` or ``initial(n, rng)``.
    system : VibroImpactSystem

    Returns
    -------
    InitialCondition

    Raises
    ------
    ValueError
        Unknown keys, non-finite or negative values, or a mean x outside the strip
        (message names the field, the allowed range and the value).
    """
    if isinstance(spec, InitialCondition):
        if spec.system != system:
            raise ValueError("initial: InitialCondition was built for another system")
        return spec
    if callable(spec):
        return InitialCondition(system=system, sampler=spec)
    if not isinstance(spec, Mapping):
        raise _bad("initial", 'a dict {"mean": (x0, y0), "std": (sx, sy)} or a callable '
                   "initial(n, rng)", spec)
    unknown = set(spec) - {"mean", "std"}
    if unknown:
        raise _bad("initial keys", 'only "mean" and "std"', sorted(unknown))
    mean = _pair(spec, "mean")
    std = _pair(spec, "std")
    if std[0] < 0 or std[1] < 0:
        raise _bad("std", "a pair of numbers >= 0", spec["std"])
    lo, hi = system.x_bounds
    if not lo <= mean[0] <= hi:
        raise _bad("mean[0] (x0)", f"in the strip [{lo}, {hi}]", mean[0])
    return InitialCondition(system=system, mean=mean, std=std)


def parse_times(times: Any, where: str, *, increasing: bool = True) -> np.ndarray:
    """Validate the output ``times`` of a transient method (shared by all of them).

    Finite numbers ≥ 0, at least one; strictly increasing when ``increasing``.
    Raises ``ValueError`` naming ``times`` and ``where`` (e.g. "fem.transient").
    """
    rule = ("a non-empty, strictly increasing sequence of finite numbers >= 0" if increasing
            else "a non-empty sequence of finite numbers >= 0")
    try:
        t = np.asarray(times, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise invalid(where, "times", rule, times) from None
    if t.size == 0 or not np.all(np.isfinite(t)) or np.any(t < 0) or \
            (increasing and np.any(np.diff(t) <= 0)):
        raise invalid(where, "times", rule, times)
    return t

