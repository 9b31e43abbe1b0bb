"""The periodic response to harmonic plus random excitation: one result type for
every method (``fem.periodic``, ``montecarlo.periodic``).

Under F cos(Ωt + φ0) the density does not settle to a stationary one but to a
periodic one, p(x, y, t + 2π/Ω) = p(x, y, t) (docs/theory.md, §Harmonic forcing).
A :class:`PeriodicResponse` holds that state at the requested phases φ = (Ωt + φ0)
mod 2π, each as a stationary-like :class:`~fpk_vibro.solution.Solution` (moments,
densities, impacts, error estimate), the period-averaged density, and the first
harmonic of the mean, E[x](t) ≈ x̄ + A cos(Ωt + φ0 − θ) (``mean_x``, ``amplitude``,
``lag``).  The engines compute the solutions and the harmonic (and their estimates)
and pass them in; this module knows no method.

Saved as a directory: ``manifest.json`` (format, system, phases, harmonic, its
estimate, info, file names) beside one solution file per phase and the average's,
each written by :meth:`Solution.save <fpk_vibro.solution.Solution.save>` (with the
estimate it had made) and read back by ``Solution.load``.

Examples
--------
>>> import numpy as np
>>> from fpk_vibro import VibroImpactSystem, Harmonic, exact
>>> s = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none")
>>> sol = exact.gibbs(s)
>>> r = PeriodicResponse("exact", s.replace(forcing=Harmonic(0.1, 0.9)),
...                      [0.0, np.pi], [sol, sol], sol, amplitude=0.5, lag=0.3, mean_x=0.0)
>>> r.phases.tolist(), r.amplitude, r.at(1) is sol
([0.0, 3.141592653589793], 0.5, True)
"""
from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ._checks import InputError, invalid
from .forcing import TWO_PI, check_phases
from .io import _sync_dir, atomic_json, strict
from .model import VibroImpactSystem
from .solution import Solution

__all__ = ["PeriodicResponse", "PERIODIC_FORMAT", "PHASE_KEYS"]

PERIODIC_FORMAT = "fpk_vibro.periodic"
PERIODIC_VERSION = 1
#: The phase-resolved moments of :meth:`PeriodicResponse.moments_vs_phase`.
PHASE_KEYS = ("E_x", "E_x2", "E_y2", "E_H")
#: The harmonic's scalars (and the keys of their estimates).
HARMONIC_KEYS = ("mean_x", "amplitude", "lag")


class PeriodicResponse:
    """The periodic steady state at ``phases`` (module docstring).

    Parameters
    ----------
    method : str
        The method that made it ("fem", "montecarlo", ...).
    system : VibroImpactSystem
        The forced system.
    phases : sequence of float
        Phases in radians in [0, 2π), in the order of ``solutions``.
    solutions : sequence of Solution
        The density at each phase (stationary-like: moments, pdf_*, impacts).
    average : Solution
        The period-averaged density.
    amplitude, lag, mean_x : float
        A ≥ 0, θ in [0, 2π) and x̄ of E[x](t) ≈ x̄ + A cos(Ωt + φ0 − θ).
    estimate : dict or callable, optional
        Estimated errors of ``mean_x``, ``amplitude`` (absolute) and ``lag`` (radians),
        or a function returning them, called once on first demand.
    info : dict, optional
        The engine's record (options, levels, timings).
    moments : dict, optional
        Precomputed :meth:`moments_vs_phase` (arrays of len(phases)); else computed
        from the solutions on first demand.
    """

    def __init__(self, method: str, system: VibroImpactSystem, phases: Any,
                 solutions: Any, average: Solution, *, amplitude: float, lag: float,
                 mean_x: float, estimate: dict | Callable[[], dict] | None = None,
                 info: dict | None = None, moments: dict | None = None) -> None:
        self.method = str(method)
        self.system = system
        self.phases = check_phases("PeriodicResponse", phases)
        self._solutions = list(solutions)
        if len(self._solutions) != self.phases.size:
            raise invalid("PeriodicResponse", "solutions", f"one per phase "
                          f"({self.phases.size})", f"{len(self._solutions)} solutions")
        self._average = average
        self.amplitude = float(amplitude)
        self.lag = float(lag) % TWO_PI
        self.mean_x = float(mean_x)
        self._harmonic_estimate = estimate
        self.info = dict(info or {})
        self._moments = None if moments is None else {
            k: np.asarray(v, float) for k, v in moments.items()}
        self.partial = False

    # -- access ----------------------------------------------------------------------
    def __len__(self) -> int:
        return self.phases.size

    def at(self, i: int) -> Solution:
        """The density at phase ``phases[i]`` (a stationary-like Solution)."""
        n = self.phases.size
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -n <= i < n:
            raise invalid("PeriodicResponse.at", "i", f"an integer index in [0, {n})", i)
        return self._solutions[int(i)]

    def average(self) -> Solution:
        """The period-averaged density (1/T ∫ p(x, y, t) dt over one period)."""
        return self._average

    def mean_at(self, phi: Any) -> np.ndarray:
        """The first harmonic of the mean at phases ``phi``: x̄ + A cos(φ − θ)."""
        return self.mean_x + self.amplitude * np.cos(np.asarray(phi, float) - self.lag)

    # -- phase-resolved statistics -----------------------------------------------------
    def moments_vs_phase(self) -> dict[str, np.ndarray]:
        """E_x, E_x2, E_y2, E_H at each phase (arrays in the order of ``phases``)."""
        if self._moments is None:
            out = {k: np.empty(self.phases.size) for k in PHASE_KEYS}
            for i, sol in enumerate(self._solutions):
                m = sol.moments()
                out["E_x"][i] = sol.mean_x()
                for k in PHASE_KEYS[1:]:
                    out[k][i] = m[k]
            self._moments = out
        return {k: v.copy() for k, v in self._moments.items()}

    def impact_rates(self) -> dict[str, np.ndarray]:
        """Impacts per unit time on each wall ("left"/"right") at each phase (the
        instantaneous rate: the impacting flux of that phase's density)."""
        sides = [side for side, _ in self.system.walls]
        out = {side: np.empty(self.phases.size) for side in sides}
        for i, sol in enumerate(self._solutions):
            imp = sol.impacts() if sides else {}
            for side in sides:
                out[side][i] = imp[side]["rate"]
        return out

    def error_estimate(self) -> dict[str, Any]:
        """Estimated errors: ``phases`` (each phase's ``error_estimate()``, a list),
        ``average`` (the average's), and ``mean_x``, ``amplitude`` (absolute) and
        ``lag`` (radians) of the first harmonic."""
        est = self._harmonic_estimate
        if callable(est):
            est = self._harmonic_estimate = dict(est())
        est = dict(est or {})
        out: dict[str, Any] = {k: float(est.get(k, math.nan)) for k in HARMONIC_KEYS}
        out.update({k: v for k, v in est.items() if k not in HARMONIC_KEYS})
        out["phases"] = [sol.error_estimate() for sol in self._solutions]
        out["average"] = self._average.error_estimate()
        return out

    # -- results -----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary for results.json: method, phases, harmonic (with its
        estimate where one was made), moments and impact rates against phase."""
        out: dict[str, Any] = {"method": self.method, "phases": self.phases.tolist(),
                               "mean_x": self.mean_x, "amplitude": self.amplitude,
                               "lag": self.lag}
        if self._harmonic_estimate is not None:
            est = self._harmonic_estimate
            if callable(est):
                est = self._harmonic_estimate = dict(est())
            out["estimate"] = {k: v for k, v in est.items()
                               if isinstance(v, (int, float, str, bool))}
        out["moments"] = {k: v.tolist() for k, v in self.moments_vs_phase().items()}
        if self.system.has_barrier:
            out["impact_rates"] = {k: v.tolist() for k, v in self.impact_rates().items()}
        out["average"] = dict(self._average.moments())
        out["info"] = {k: v for k, v in self.info.items()
                       if isinstance(v, (int, float, str, bool)) or v is None}
        return strict(out)

    def save(self, path: str | os.PathLike) -> Path:
        """Write to the directory ``path`` (created; an existing one is replaced only
        if it holds a periodic response): ``manifest.json``, ``phase_NNN.npz`` and
        ``average.npz``.  Written beside it first, then renamed into place."""
        where = "PeriodicResponse.save"
        path = Path(path)
        if path.exists() and not (path.is_dir() and (path / "manifest.json").is_file()):
            raise invalid(where, "path", "a new directory or one a PeriodicResponse wrote",
                          str(path))
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
        try:
            files = [sol.save(tmp / f"phase_{i:03d}.npz").name
                     for i, sol in enumerate(self._solutions)]
            avg = self._average.save(tmp / "average.npz").name
            est = self._harmonic_estimate
            if callable(est):
                est = None                      # not made: not stored
            manifest = {"format": PERIODIC_FORMAT, "version": PERIODIC_VERSION,
                        "method": self.method, "system": self.system.to_dict(),
                        "phases": self.phases.tolist(), "mean_x": self.mean_x,
                        "amplitude": self.amplitude, "lag": self.lag,
                        "estimate": None if est is None else _floats(est),
                        "info": {k: v for k, v in self.info.items()
                                 if isinstance(v, (int, float, str, bool)) or v is None},
                        "files": files, "average": avg,
                        "moments": {k: v.tolist() for k, v in self.moments_vs_phase().items()}}
            (tmp / "manifest.json").write_text(json.dumps(manifest, indent=1))
            if path.exists():
                shutil.rmtree(path)
            os.replace(tmp, path)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        _sync_dir(path.parent)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "PeriodicResponse":
        """Read a directory written by :meth:`save`; any problem is one line
        naming the directory."""
        path = Path(path)
        try:
            m = json.loads((path / "manifest.json").read_text())
            if not isinstance(m, dict) or m.get("format") != PERIODIC_FORMAT:
                raise ValueError("not a periodic response (manifest format)")
            if m.get("version") != PERIODIC_VERSION:
                raise ValueError(f"version {m.get('version')!r}, expected {PERIODIC_VERSION}")
            system = VibroImpactSystem.from_dict(m["system"])
            files = m["files"]
            if not isinstance(files, list) or len(files) != len(m["phases"]) or any(
                    not isinstance(f, str) or Path(f).name != f for f in files + [m["average"]]):
                raise ValueError("manifest 'files' do not name one file per phase")
            sols = [Solution.load(path / f) for f in files]
            avg = Solution.load(path / m["average"])
            est = m.get("estimate")
            out = cls(m["method"], system, m["phases"], sols, avg, amplitude=m["amplitude"],
                      lag=m["lag"], mean_x=m["mean_x"],
                      estimate=None if est is None else _unfloats(est),
                      info=m.get("info") or {},
                      moments=m.get("moments"))
        except InputError as exc:
            raise InputError(f"{path}: {exc}", where=str(path), name="path") from None
        except (OSError, ValueError, KeyError, TypeError) as exc:
            problem = " ".join(str(exc).split())
            raise InputError(f"{path}: {type(exc).__name__}: {problem}", where=str(path),
                             name="path") from None
        return out

    def __repr__(self) -> str:
        return (f"PeriodicResponse(method={self.method!r}, phases={self.phases.size}, "
                f"amplitude={self.amplitude:.6g}, lag={self.lag:.6g})")


def _floats(est: dict) -> dict:
    """Estimate values as JSON (non-finite floats as strings, to the bit otherwise)."""
    out = {}
    for k, v in est.items():
        if isinstance(v, (bool, str)) or v is None:
            out[k] = v
        elif isinstance(v, (int, float, np.floating, np.integer)):
            v = float(v)
            out[k] = v if math.isfinite(v) else repr(v)
    return out


def _unfloats(est: dict) -> dict:
    return {k: float(v) if v in ("inf", "-inf", "nan") else v for k, v in est.items()}
