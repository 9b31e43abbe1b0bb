"""Power spectral density and correlation of the stationary response: one result
type for every method (``fem.spectrum``, ``montecarlo.spectrum``,
``averaging.spectrum``).

Convention (docs/theory.md, §Spectra and crossings): for q = x or y with mean m,
the correlation is R(τ) = E[(q(t) − m)(q(t + τ) − m)] and the spectral density is
two-sided in rad/s,

    S(ω) = (1/π) ∫₀^∞ R(τ) cos ωτ dτ,   so that   ∫_{−∞}^{∞} S(ω) dω = R(0) = Var q.

With E[ξ(t) ξ(t + τ)] = 2 D1 δ(τ) the linear oscillator without walls has
S_xx(ω) = (D1/π) / ((a − ω²)² + c²ω²).  The one-sided density is G(ω) = 2 S(ω) on
ω ≥ 0; per Hz, densities are multiplied by 2π (``density_in``).

A :class:`Spectrum` holds S on the requested ω (ascending, ≥ 0), its standard error
where sampled, R(τ) on a grid of lags from 0, the variance the method computed, and
the method's error estimate.  The engines compute them and pass them in; this module
knows no method.  Saved as one ``.npz`` (arrays plus a JSON header).

Examples
--------
>>> import numpy as np
>>> from fpk_vibro import VibroImpactSystem
>>> s = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none")
>>> w = np.linspace(0.0, 3.0, 3001)
>>> S = s.D1 / np.pi / ((s.a - w**2) ** 2 + (s.c * w) ** 2)
>>> sp = Spectrum("exact", s, "x", w, S, variance=s.D1 / (s.a * s.c))
>>> round(sp.integral() / sp.variance, 3), round(sp.peak_frequency(), 3)
(0.999, 0.997)
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Callable

import numpy as np
from scipy.integrate import trapezoid

from ._checks import InputError, check_choice, invalid
from .io import atomic_savez, strict
from .model import VibroImpactSystem

__all__ = ["Spectrum", "SPECTRUM_FORMAT", "SIGNALS", "check_omega", "check_signal"]

SPECTRUM_FORMAT = "fpk_vibro.spectrum"
SPECTRUM_VERSION = 1
#: The signals a spectrum can be asked of: displacement and velocity.
SIGNALS = ("x", "y")
UNITS = ("rad/s", "Hz")
SIDES = ("two", "one")


def check_signal(where: str, of: Any) -> str:
    """``of`` as one of :data:`SIGNALS` (one-line error otherwise)."""
    return check_choice("of", of, SIGNALS, where=where)


def check_omega(where: str, omega: Any) -> np.ndarray:
    """Angular frequencies in rad/s: a finite, non-negative, strictly increasing 1-D
    array of at least one value (a number is one value)."""
    try:
        if np.asarray(omega).dtype.kind not in "iuf":       # no text, booleans, objects
            raise TypeError
        w = np.atleast_1d(np.asarray(omega, dtype=float))
    except (TypeError, ValueError):
        raise invalid(where, "omega", "finite frequencies >= 0 in rad/s", omega) from None
    if w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise invalid(where, "omega", "a 1-D array of finite frequencies >= 0 in rad/s",
                      omega)
    if np.any(np.diff(w) <= 0):
        raise invalid(where, "omega", "strictly increasing", omega)
    return w


class Spectrum:
    """S(ω) and R(τ) of one method for one signal (module docstring).

    Parameters
    ----------
    method : str
        The method that made it ("fem", "montecarlo", "averaging", ...).
    system : VibroImpactSystem
    of : {"x", "y"}
        The signal.
    omega : array_like
        Frequencies in rad/s (:func:`check_omega`).
    density : array_like
        The two-sided S(ω) at ``omega`` (same length, finite).
    variance : float
        Var q as the method computed it (what ∫ S dω over the real line should give).
    se : array_like, optional
        Standard error of ``density`` (sampling methods).
    lags, correlation : array_like, optional
        R(τ) on lags 0 = τ0 < τ1 < ...; default: the cosine transform of S on the ω
        grid (only as good as that grid's reach).
    estimate : dict or callable, optional
        The error estimate (see :meth:`error_estimate`), or a function making it on
        first demand.
    info : dict, optional
        The engine's record (options, timings).
    mean : float
        E[q].
    """

    def __init__(self, method: str, system: VibroImpactSystem, of: str, omega: Any,
                 density: Any, *, variance: float, se: Any = None, lags: Any = None,
                 correlation: Any = None, estimate: dict | Callable[[], dict] | None = None,
                 info: dict | None = None, mean: float = 0.0) -> None:
        where = "Spectrum"
        self.method = str(method)
        self.system = system
        self.of = check_signal(where, of)
        self.omega = check_omega(where, omega)
        self.density = _same(where, "density", density, self.omega.size)
        self.se = None if se is None else _same(where, "se", se, self.omega.size)
        self.variance = float(variance)
        self.mean = float(mean)
        if (lags is None) != (correlation is None):
            raise invalid(where, "lags", "given together with correlation", lags)
        if lags is None:
            lags, correlation = self._cosine_transform()
        self.lags = np.asarray(lags, dtype=float)
        if self.lags.ndim != 1 or self.lags.size < 2 or self.lags[0] != 0 \
                or np.any(np.diff(self.lags) <= 0) or not np.all(np.isfinite(self.lags)):
            raise invalid(where, "lags", "increasing finite lags from 0", lags)
        self._correlation = _same(where, "correlation", correlation, self.lags.size)
        self._estimate = estimate
        self.info = dict(info or {})

    # -- the density ----------------------------------------------------------------
    def density_in(self, units: str = "rad/s", sided: str = "two"
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(frequency, density, se)`` in ``units`` ("rad/s" or "Hz") and ``sided``
        ("two": S with ∫_{−∞}^{∞}; "one": G = 2S on f ≥ 0).  Per Hz, f = ω/2π and
        the densities are 2π times those per rad/s, so their integrals agree."""
        where = "Spectrum.density_in"
        units = check_choice("units", units, UNITS, where=where)
        sided = check_choice("sided", sided, SIDES, where=where)
        scale = (2.0 if sided == "one" else 1.0) * (2 * math.pi if units == "Hz" else 1.0)
        freq = self.omega / (2 * math.pi) if units == "Hz" else self.omega.copy()
        se = None if self.se is None else scale * self.se
        return freq, scale * self.density, se

    def one_sided(self) -> np.ndarray:
        """G(ω) = 2 S(ω) on ω ≥ 0 (∫₀^∞ G dω = Var q)."""
        return 2.0 * self.density

    def integral(self) -> float:
        """∫ S dω over the real line as far as the ω grid reaches (2 × the trapezoid
        rule on [ω0, ω_last]); compare with :attr:`variance`."""
        return float(2.0 * trapezoid(self.density, self.omega)) if self.omega.size > 1 \
            else 0.0

    def peak_frequency(self) -> float:
        """The ω of the largest S, refined by a parabola through the three grid
        values around it (the grid value at an end)."""
        i = int(np.argmax(self.density))
        if i == 0 or i == self.omega.size - 1:
            return float(self.omega[i])
        w, s = self.omega[i - 1:i + 2], self.density[i - 1:i + 2]
        a, b, _ = np.polyfit(w - w[1], s, 2)
        return float(w[1] - b / (2 * a)) if a < 0 else float(w[1])

    # -- the correlation ------------------------------------------------------------
    def correlation(self, tau: Any) -> np.ndarray:
        """R(τ) at ``tau`` (R is even: R(−τ) = R(τ)), interpolated on :attr:`lags`;
        a |τ| beyond the last lag raises."""
        t = np.abs(np.asarray(tau, dtype=float))
        if not np.all(np.isfinite(t)) or np.any(t > self.lags[-1] * (1 + 1e-12)):
            raise invalid(f"{self.method}.spectrum.correlation", "tau",
                          f"finite lags with |tau| <= {self.lags[-1]:.6g} (what was "
                          "computed)", tau)
        return np.interp(t, self.lags, self._correlation)

    def _cosine_transform(self) -> tuple[np.ndarray, np.ndarray]:
        w, S = self.omega, self.density
        if w.size < 2:
            raise invalid("Spectrum", "omega", "at least two frequencies when no "
                          "correlation is given", w)
        dw = float(np.min(np.diff(w)))
        lags = np.linspace(0.0, math.pi / dw, 257)
        R = 2.0 * trapezoid(S[None, :] * np.cos(np.outer(lags, w)), w, axis=1)
        return lags, R

    # -- estimate and files ---------------------------------------------------------
    def error_estimate(self) -> dict[str, Any]:
        """The method's estimate: ``"density"`` (absolute error of S at each ω, an
        array), ``"relative"`` (its largest value over the largest S), ``"variance"``
        (relative error of Var q), ``"correlation"`` (largest absolute error of R over
        R(0)) and ``"assumes"``; other keys as the method reports."""
        est = self._estimate
        if callable(est):
            est = self._estimate = dict(est())
        if est is None:
            raise ValueError(f"{self.method}.spectrum: no error estimate was made")
        return {k: (np.array(v) if isinstance(v, np.ndarray) else v) for k, v in est.items()}

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able summary (for results.json)."""
        out: dict[str, Any] = {
            "method": self.method, "of": self.of, "omega": self.omega,
            "density": self.density, "variance": self.variance, "mean": self.mean,
            "integral": self.integral(), "peak_frequency": self.peak_frequency()}
        if self.se is not None:
            out["se"] = self.se
        if self._estimate is not None and not callable(self._estimate):
            out["estimate"] = self._estimate
        out["info"] = _scalars(self.info)
        return strict(out)

    def save(self, path: str | os.PathLike) -> Path:
        """Write one ``.npz`` (atomically; ``.npz`` is appended when missing)."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        est = self._estimate if not callable(self._estimate) else None
        arrays = {"omega": self.omega, "density": self.density, "lags": self.lags,
                  "correlation": self._correlation}
        if self.se is not None:
            arrays["se"] = self.se
        scalars = {}
        for k, v in (est or {}).items():
            if isinstance(v, np.ndarray):
                arrays[f"estimate_{k}"] = v
            else:
                scalars[k] = v
        header = {"format": SPECTRUM_FORMAT, "version": SPECTRUM_VERSION,
                  "method": self.method, "of": self.of, "system": self.system.to_dict(),
                  "variance": self.variance, "mean": self.mean,
                  "estimate": None if est is None else _json_floats(scalars),
                  "info": strict(_scalars(self.info))}
        arrays["header"] = np.array(json.dumps(header))
        return atomic_savez(path, arrays)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Spectrum":
        """Read a file written by :meth:`save`; any problem is one line naming it."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
            h = json.loads(str(data.pop("header")))
            if not isinstance(h, dict) or h.get("format") != SPECTRUM_FORMAT:
                raise ValueError("not a spectrum (header format)")
            if h.get("version") != SPECTRUM_VERSION:
                raise ValueError(f"version {h.get('version')!r}, expected {SPECTRUM_VERSION}")
            est = h.get("estimate")
            if est is not None:
                est = {k: (float(v) if v in ("inf", "-inf", "nan") else
                           math.nan if v is None else v) for k, v in est.items()}
                est.update({k[len("estimate_"):]: v for k, v in data.items()
                            if k.startswith("estimate_")})
            return cls(h["method"], VibroImpactSystem.from_dict(h["system"]), h["of"],
                       data["omega"], data["density"], variance=h["variance"],
                       se=data.get("se"), lags=data["lags"],
                       correlation=data["correlation"], estimate=est,
                       info=h.get("info") or {}, mean=h.get("mean", 0.0))
        except InputError as exc:
            raise InputError(f"{path}: {exc}", where=str(path), name="path") from None
        except (OSError, ValueError, KeyError, TypeError, AttributeError,
                EOFError) as exc:
            problem = " ".join(str(exc).split())
            raise InputError(f"{path}: {type(exc).__name__}: {problem}", where=str(path),
                             name="path") from None

    def __repr__(self) -> str:
        return (f"Spectrum(method={self.method!r}, of={self.of!r}, n_omega={self.omega.size}, "
                f"peak_frequency={self.peak_frequency():.6g}, variance={self.variance:.6g})")


def _same(where: str, name: str, value: Any, n: int) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise invalid(where, name, f"{n} finite numbers", value) from None
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise invalid(where, name, f"{n} finite numbers (one per grid point)", value)
    return a


def _json_floats(est: dict) -> dict:
    """Scalars as JSON, a non-finite float ("no bound": inf) as its name."""
    out = strict(est)
    for k, v in est.items():
        if isinstance(v, (float, np.floating)) and not math.isfinite(v):
            out[k] = repr(float(v))
    return out


def _scalars(d: dict) -> dict:
    return {k: v for k, v in d.items()
            if isinstance(v, (int, float, str, bool, np.floating, np.integer)) or v is None}
