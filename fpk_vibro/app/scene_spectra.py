"""The scene side of the quantities "spectra" and "crossings": their tables resolved
(defaults that depend on the systems of the sweep), checked per point, and the
keywords each method's spectrum is called with.

- ``[spectra]`` (:data:`~fpk_vibro.app.spectral_keys.SPECTRA_KEYS`): ``omega`` (rad/s;
  default 301 values from 0 to 3 ω0, the largest ω0 of the sweep's systems, so every
  point shares one grid), ``of``, ``units``, ``sided``;
- ``[crossings]`` (:data:`~fpk_vibro.app.spectral_keys.CROSSINGS_KEYS`): ``levels``
  (default: 41 levels over the strips of the sweep's systems, every wall position
  among them, one grid for every point), ``displacement`` (the band of the Rice
  estimate; default |x| < the highest level inside the point's walls) and
  ``rice_times``.

A table without its quantity is refused, as ``[first_passage]`` is.
"""
from __future__ import annotations

import inspect
import math
from typing import Any, Callable

import numpy as np

from .._checks import InputError, show
from ..model import VibroImpactSystem
from ..registry import methods
from ..scales import amplitude_scale, omega0
from .scene_keys import SceneError

__all__ = ["spectral_tables", "check_spectral", "rice_band", "spectrum_kwargs",
           "passage_methods", "N_OMEGA", "N_LEVELS", "OMEGA_SPAN", "LEVEL_SCALES"]

#: The default ω grid: this many values from 0 to OMEGA_SPAN × the largest ω0.
N_OMEGA = 301
OMEGA_SPAN = 3.0
#: The default levels: this many over the strips, plus the walls.
N_LEVELS = 41
#: Where a side has no wall, the levels reach the amplitude at this many energy scales.
LEVEL_SCALES = 8.0


def _default_omega(points: list) -> tuple[float, ...]:
    top = OMEGA_SPAN * max(omega0(s) for _, s in points)
    return tuple(float(w) for w in np.linspace(0.0, top, N_OMEGA))


def _strip(system: VibroImpactSystem) -> tuple[float, float]:
    lo, hi = system.x_bounds
    A = amplitude_scale(system, LEVEL_SCALES)
    return (lo if math.isfinite(lo) else -A), (hi if math.isfinite(hi) else A)


def _default_levels(points: list) -> tuple[float, ...]:
    systems = [s for _, s in points]
    ends = [_strip(s) for s in systems]
    grid = np.linspace(min(e[0] for e in ends), max(e[1] for e in ends), N_LEVELS)
    walls = [w.position for s in systems for _, w in s.walls]
    return tuple(float(b) for b in np.unique(np.round(np.concatenate([grid, walls]), 12)))


def spectral_tables(clean: dict[str, dict[str, Any]], quantities: tuple[str, ...],
                    points: Callable[[], list]
                    ) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    """``(spectra, crossings)`` of a scene, each None without its quantity; a table
    given without its quantity is refused in one line naming it.  ``points()`` gives
    the sweep's ``[(parameters, system)]`` (asked only for a default grid)."""
    out: list[dict[str, Any] | None] = []
    for q in ("spectra", "crossings"):
        given = clean.get(q) or {}
        if q not in quantities:
            if given:
                raise SceneError(f"{q}: only used with the quantity \"{q}\" in "
                                 "study.quantities", name=q)
            out.append(None)
            continue
        if q == "spectra":
            out.append({"omega": given.get("omega") or _default_omega(points()),
                        "of": given.get("of", ("x",)), "units": given.get("units", "rad/s"),
                        "sided": given.get("sided", "two")})
        else:
            out.append({"levels": given.get("levels") or _default_levels(points()),
                        "displacement": given.get("displacement"),
                        "rice_times": given.get("rice_times")})
    return out[0], out[1]


def rice_band(crossings: dict[str, Any], system: VibroImpactSystem
              ) -> tuple[float, float] | None:
    """(x_lo, x_hi) of the Rice comparison at this point: ``displacement`` as given
    (b: (−b, b)), else |x| < the highest level b with −b and b inside the walls; None
    when no level is."""
    band = crossings.get("displacement")
    if band is not None:
        return tuple(band) if isinstance(band, (tuple, list)) else (-float(band), float(band))
    lo, hi = system.x_bounds
    inside = [abs(b) for b in crossings["levels"] if b != 0 and lo < -abs(b) and abs(b) < hi]
    return (-max(inside), max(inside)) if inside else None


def passage_methods(scene: Any) -> list[str]:
    """The scene's methods that give the true reliability of the Rice comparison: a
    first passage out of a displacement band (only with ``rice_times``)."""
    if scene.crossings is None or scene.crossings.get("rice_times") is None:
        return []
    return [m for m in scene.methods if "first_passage" in methods()[m].modes
            and "displacement" in methods()[m].safe_sets]


def spectrum_kwargs(scene: Any, method: str, fn: Any) -> dict[str, Any]:
    """The keywords of ``method``'s spectrum: the scene's options of its table that the
    function takes (all stationary ones when it takes ``**keywords``), and none else."""
    given = dict(scene.numerics.get(method, {}))
    params = inspect.signature(fn).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        Options = methods()[method].options_class()
        declared = Options.declared() if Options is not None else {}
        return {k: v for k, v in given.items()
                if k in declared and "stationary" in declared[k].modes and k != "progress"}
    return {k: v for k, v in given.items()
            if k in params and k not in ("system", "omega", "of")}


def _givers(scene: Any, system: VibroImpactSystem, q: str) -> tuple[list[str], list[str]]:
    """(methods of the scene that give ``q`` for ``system``, the reasons of the others)."""
    ok, why = [], []
    for m in scene.methods:
        method = methods()[m]
        if q == "spectra" and method.spectrum is None:
            why.append(f"{m}: gives no spectrum")
            continue
        try:
            method.supports(system, "stationary", [q])
        except InputError as exc:
            why.append(str(exc))
            continue
        ok.append(m)
    return ok, why


def check_spectral(scene: Any, system: VibroImpactSystem, at: str) -> None:
    """Per point: some method of the scene gives each of "spectra" and "crossings" for
    this system, the Rice band lies on the strip, and the first passages of the Rice
    comparison pass their checks; one SceneError naming the key."""
    from ..safe_sets import parse_safe_set
    for q in ("spectra", "crossings"):
        if q in scene.quantities:
            ok, why = _givers(scene, system, q)
            if not ok:
                raise SceneError(f"study.quantities: {q!r} is given by none of study.methods "
                                 f"for this system{at} ({'; '.join(why)})",
                                 name="study.quantities")
    if scene.crossings is None:
        return
    band = rice_band(scene.crossings, system)
    key = "crossings.displacement"
    if band is None:
        if scene.crossings.get("rice_times") is not None:
            raise SceneError(f"{key}: no level of crossings.levels lies inside the walls{at}; "
                             "give the band of the Rice comparison", name=key)
        return
    try:
        parse_safe_set("crossings", system, displacement=band)
    except InputError as exc:
        raise SceneError(exc.keyed(key, at), name=key) from None
    for m in passage_methods(scene):
        Options = methods()[m].options_class()
        if Options is None:
            continue
        from .plan import first_passage_kwargs
        try:
            Options.prepare(system, "first_passage", first_passage_kwargs(scene, m),
                            probe=True)
        except InputError as exc:
            raise SceneError(f"crossings.rice_times: {m}: {exc.rule}{at} (the first "
                             f"passage out of {show(list(band))})",
                             name="crossings.rice_times") from None
