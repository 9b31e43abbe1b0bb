"""The records of the quantities "spectra" and "crossings" of one method at one point.

- ``"spectra"``: per signal (``spectra.of``) the method's
  :class:`~fpk_vibro.spectrum.Spectrum` as :meth:`~fpk_vibro.spectrum.Spectrum.to_dict`
  (ω in rad/s, S two-sided, ``se`` where sampled, ``variance``, ``integral``,
  ``peak_frequency``: a sampled method's own, with ``peak_frequency_se``, where it
  gives one, the grid's then ``peak_frequency_on_grid``) with its ``error_estimate``
  (``density`` per ω, ``relative``, ``variance``, ``correlation``, ``assumes``;
  skipped with ``study.error_estimates = "none"``) and, when ``spectra.units``/``sided`` ask for other than rad/s two-sided,
  ``requested`` (``frequency``, ``density``, ``se`` in those);
- ``"crossings"``: ``levels``, ``upcrossing_rate`` ν⁺(b) and ``peak_rate`` from the
  method's stationary solution (``*_se`` where the solution gives them), Monte Carlo's
  ``counted`` rates (with standard errors) where ``montecarlo.crossings`` exists,
  ``walls`` (per wall: ν⁺ there beside the impact rate, the identity they meet, and
  the energy G(x_w) above which a path reaches it) and ``rice``: the band, the Rice
  rate ν⁺(x_hi) + ν⁻(x_lo), and with ``crossings.rice_times`` the estimate
  exp(−rate t) beside the true reliability ``true`` of the method's first passage out
  of the band from the stationary state.

What a method cannot give is recorded as ``not_computed`` with the reason; the run
goes on.  The Spectrum objects and first passages are kept (``keep``) for the figures
and the arrays of :mod:`fpk_vibro.app.spectral_point`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .._checks import InputError
from ..io import strict
from ..registry import methods
from .plan import first_passage_kwargs
from .scene_spectra import passage_methods, rice_band, spectrum_kwargs

__all__ = ["spectra_record", "crossings_record", "NOT_GIVEN"]

#: What a method that cannot give a quantity raises (recorded, the run goes on).
NOT_GIVEN = (NotImplementedError, ValueError, RuntimeError)


def _not_given(exc: BaseException) -> dict[str, Any]:
    return {"not_computed": " ".join(f"{type(exc).__name__}: {exc}".split())}


def _supported(method: str, system: Any, mode: str, q: tuple = ()) -> dict[str, Any] | None:
    try:
        methods()[method].supports(system, mode, list(q))
    except InputError as exc:
        return _not_given(exc)
    return None


def _spectrum_record(sp: Any, scene: Any) -> dict[str, Any]:
    rec = sp.to_dict()
    for k in ("method", "of"):
        rec.pop(k, None)
    own = rec.get("info") or {}
    if own.get("peak_frequency") is not None and own.get("peak_frequency_se") is not None:
        # a sampled method's own peak (its fine grid, SE between batches) beats the
        # parabola through three noisy values of the scene's grid on a flat top
        rec["peak_frequency_on_grid"] = rec["peak_frequency"]
        rec["peak_frequency"] = float(own["peak_frequency"])
        rec["peak_frequency_se"] = float(own["peak_frequency_se"])
    given = rec.pop("estimate", None)
    if scene.error_estimates != "none" or given is not None:
        try:
            rec["error_estimate"] = strict(sp.error_estimate())
        except NOT_GIVEN as exc:
            rec["error_estimate"] = _not_given(exc)
    units, sided = scene.spectra["units"], scene.spectra["sided"]
    if (units, sided) != ("rad/s", "two"):
        f, d, se = sp.density_in(units, sided)
        rec["requested"] = strict({"units": units, "sided": sided, "frequency": f,
                                   "density": d, **({} if se is None else {"se": se})})
    return rec


def spectra_record(scene: Any, method: str, system: Any, keep: dict) -> dict[str, Any]:
    """``{of: record}`` of one method (module docstring), or ``not_computed``; each
    Spectrum into ``keep[method][of]``."""
    m = methods()[method]
    if m.spectrum is None:
        return {"not_computed": f"{method}: gives no spectrum"}
    refused = _supported(method, system, "stationary", ("spectra",))
    if refused:
        return refused
    fn = m.spectrum()
    kw = spectrum_kwargs(scene, method, fn)
    omega = np.asarray(scene.spectra["omega"], dtype=float)
    out: dict[str, Any] = {}
    for of in scene.spectra["of"]:
        try:
            sp = fn(system, omega, of=of, **kw)
        except NOT_GIVEN as exc:
            out[of] = _not_given(exc)
            continue
        keep.setdefault(method, {})[of] = sp
        out[of] = _spectrum_record(sp, scene)
    return out


def _rates(sol: Any, levels: np.ndarray) -> dict[str, Any]:
    return {"levels": levels,
            "upcrossing_rate": np.asarray(sol.upcrossing_rate(levels), float),
            "peak_rate": np.asarray(sol.peak_rate(levels), float)}


def _counted(scene: Any, system: Any, levels: np.ndarray) -> dict[str, Any] | None:
    """Monte Carlo's counted rates (``montecarlo.crossings``) of the levels inside
    the walls (None: there are none)."""
    from ..montecarlo import crossings as count
    kw = spectrum_kwargs(scene, "montecarlo", count)
    inside = levels[system.in_strip(levels)]       # (beyond a wall nothing crosses)
    if inside.size == 0:
        return None
    try:
        got = count(system, inside, **kw)
    except NOT_GIVEN as exc:
        return _not_given(exc)
    return strict({k: v for k, v in got.to_dict().items() if k != "system"})


def _walls(sol: Any, system: Any) -> dict[str, Any]:
    try:
        impacts = sol.impacts()
    except NOT_GIVEN:
        impacts = {}
    out = {}
    for side, wall in system.walls:
        nu = float(sol.upcrossing_rate(wall.position))
        rec = {"position": wall.position, "upcrossing_rate": nu,
               "threshold_energy": float(system.potential(wall.position))}
        rate = (impacts.get(side) or {}).get("rate")
        if rate is not None:
            rec["impact_rate"] = float(rate)
            if rate > 0:
                rec["identity"] = abs(nu / rate - 1.0)
            if "rate_se" in impacts[side]:
                rec["impact_rate_se"] = float(impacts[side]["rate_se"])
        out[side] = rec
    return out


def _rice(scene: Any, method: str, system: Any, sol: Any, keep: dict) -> dict[str, Any]:
    from ..crossings import downcrossing_rate, rice_reliability
    band = rice_band(scene.crossings, system)
    if band is None:
        return {"not_computed": "no level of crossings.levels lies inside the walls"}
    rate = float(sol.upcrossing_rate(band[1])) + float(downcrossing_rate(sol, band[0]))
    out: dict[str, Any] = {"band": list(band), "rate": rate}
    times = scene.crossings.get("rice_times")
    if times is None:
        return out
    t = np.asarray(times, dtype=float)
    out["times"], out["estimate"] = t, rice_reliability(sol, t, displacement=band)
    if method not in passage_methods(scene):
        return out
    refused = _supported(method, system, "first_passage")
    if refused:
        out["true"] = refused
        return out
    try:
        fp = methods()[method].solver("first_passage")(
            system, displacement=band, start="stationary", times=tuple(times),
            **first_passage_kwargs(scene, method))
    except NOT_GIVEN as exc:
        out["true"] = _not_given(exc)
        return out
    keep.setdefault("passages", {})[method] = fp
    out["true"] = {"survival": fp.reliability(t), "mean": fp.mean, "mean_se": fp.mean_se}
    return out


def crossings_record(scene: Any, method: str, system: Any, sol: Any, keep: dict
                     ) -> dict[str, Any]:
    """The ``"crossings"`` record of one method (module docstring), or
    ``not_computed``."""
    refused = _supported(method, system, "stationary", ("crossings",))
    if refused:
        return refused
    levels = np.asarray(scene.crossings["levels"], dtype=float)
    try:
        out = _rates(sol, levels)
        out["walls"] = _walls(sol, system)
        out["rice"] = _rice(scene, method, system, sol, keep)
    except NOT_GIVEN as exc:
        return _not_given(exc)
    if method == "montecarlo":
        counted = _counted(scene, system, levels)
        if counted is not None:
            out["counted"] = counted
    return strict(out)
