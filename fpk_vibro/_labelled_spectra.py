"""The quantities "spectra" and "crossings" of a run as labelled data (netCDF).

From results.json (the document: its ``"spectra"`` and ``"crossings"`` settings and
each entry's records, :mod:`fpk_vibro.app.spectral_records`), an ``xarray.Dataset``
with the dimensions ``point``, ``method`` and:

- ``signal`` ("x", "y") and the frequency: coordinate ``omega`` (rad/s) or, with
  ``spectra.units = "Hz"``, ``frequency`` (Hz); ``spectral_density(point, method,
  signal, omega)`` in the units and sides the scene asked for (attributes ``units``,
  ``sided``), with ``_se`` (sampled) and ``_error`` (the absolute estimate per
  frequency), and per signal ``peak_frequency`` (same units; ``_se`` where
  sampled), ``spectrum_variance``
  (Var q as the method computed it), ``spectrum_integral`` (∫ S over the real line on
  the grid) and ``spectrum_error_estimate`` (relative);
- ``level`` (b, m): ``upcrossing_rate(point, method, level)`` and ``peak_rate`` with
  ``_se`` where given, Monte Carlo's ``counted_upcrossing_rate`` and
  ``counted_peak_rate`` (with ``_se``); per wall ``wall_upcrossing_rate`` and
  ``wall_impact_rate(point, method, wall)``;
- the Rice comparison: ``rice_rate``, ``rice_x_lo``, ``rice_x_hi(point, method)`` and,
  with times, ``rice_estimate`` and ``rice_true_reliability(point, method,
  rice_time)``.

NaN where a point or method has none.  Points share one ω grid and one set of levels
(the scene resolves them once, :mod:`fpk_vibro.app.scene_spectra`); a value found on
another grid is placed by its coordinate.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["spectral_dataset"]


def _num(v: Any) -> float:
    return np.nan if v is None else float(v)


def _index(values: list[float]) -> tuple[np.ndarray, dict[float, int]]:
    grid = np.unique(np.asarray(values, dtype=float))
    return grid, {float(v): i for i, v in enumerate(grid)}


def _spectra(points: list, methods: list[str], settings: dict) -> tuple[dict, dict]:
    units = settings.get("units", "rad/s")
    fdim = "frequency" if units == "Hz" else "omega"
    recs = {(i, j, of): r for i, p in enumerate(points) for j, m in enumerate(methods)
            for of, r in ((p.get("methods", {}).get(m) or {}).get("spectra") or {}).items()
            if "density" in r}
    if not recs:
        return {}, {}
    signals = sorted({of for _, _, of in recs})
    src = {k: (r.get("requested") or r) for k, r in recs.items()}
    freq, at = _index([f for s in src.values() for f in s.get("frequency", s.get("omega"))])
    scale = (2.0 if settings.get("sided") == "one" else 1.0) * (
        2 * np.pi if units == "Hz" else 1.0)
    shape = (len(points), len(methods), len(signals))
    full = {n: np.full(shape + (freq.size,), np.nan) for n in ("", "_se", "_error")}
    scal = {n: np.full(shape, np.nan) for n in ("peak_frequency", "peak_frequency_se",
                                                 "spectrum_variance",
                                                 "spectrum_integral",
                                                 "spectrum_error_estimate")}
    for (i, j, of), r in recs.items():
        s, k = src[(i, j, of)], signals.index(of)
        cols = [at[float(f)] for f in s.get("frequency", s.get("omega"))]
        full[""][i, j, k, cols] = [_num(v) for v in s["density"]]
        if s.get("se") is not None:
            full["_se"][i, j, k, cols] = [_num(v) for v in s["se"]]
        est = r.get("error_estimate") or {}
        if isinstance(est.get("density"), list):
            full["_error"][i, j, k, cols] = [scale * _num(v) for v in est["density"]]
        peak = _num(r.get("peak_frequency"))
        scal["peak_frequency"][i, j, k] = peak / (2 * np.pi) if units == "Hz" else peak
        se = _num(r.get("peak_frequency_se"))
        scal["peak_frequency_se"][i, j, k] = se / (2 * np.pi) if units == "Hz" else se
        scal["spectrum_variance"][i, j, k] = _num(r.get("variance"))
        scal["spectrum_integral"][i, j, k] = _num(r.get("integral"))
        scal["spectrum_error_estimate"][i, j, k] = _num(est.get("relative"))
    dims = ("point", "method", "signal")
    data = {f"spectral_density{n}": (dims + (fdim,), a) for n, a in full.items()
            if n == "" or np.isfinite(a).any()}
    data.update({n: (dims, a) for n, a in scal.items() if np.isfinite(a).any()})
    return data, {"signal": signals, fdim: freq}


def _crossings(points: list, methods: list[str]) -> tuple[dict, dict]:
    recs = {(i, j): r for i, p in enumerate(points) for j, m in enumerate(methods)
            for r in [(p.get("methods", {}).get(m) or {}).get("crossings") or {}]
            if "levels" in r}
    if not recs:
        return {}, {}
    level, at = _index([b for r in recs.values() for b in r["levels"]])
    walls = sorted({w for r in recs.values() for w in r.get("walls") or {}})
    times = sorted({t for r in recs.values() for t in (r.get("rice") or {}).get("times", [])})
    shape = (len(points), len(methods))
    data: dict[str, Any] = {}

    def put(name: str, dims: tuple, size: tuple, fill) -> None:
        arr = np.full(shape + size, np.nan)
        for (i, j), r in recs.items():
            fill(arr, i, j, r)
        if np.isfinite(arr).any():
            data[name] = (("point", "method") + dims, arr)

    for name, get in (("upcrossing_rate", lambda r: r), ("peak_rate", lambda r: r),
                      ("counted_upcrossing_rate", lambda r: r.get("counted") or {}),
                      ("counted_peak_rate", lambda r: r.get("counted") or {})):
        key = name.removeprefix("counted_")
        for suffix in ("", "_se"):
            def fill(arr, i, j, r, get=get, k=key + suffix):
                values = get(r).get(k)
                levels = get(r).get("levels", r["levels"])
                if values is not None and len(values) == len(levels):
                    arr[i, j, [at[float(b)] for b in levels if float(b) in at]] = [
                        _num(v) for b, v in zip(levels, values) if float(b) in at]
            put(name + suffix, ("level",), (level.size,), fill)
    for name, key in (("wall_upcrossing_rate", "upcrossing_rate"),
                      ("wall_impact_rate", "impact_rate")):
        def fill(arr, i, j, r, key=key):
            for k, w in enumerate(walls):
                arr[i, j, k] = _num(((r.get("walls") or {}).get(w) or {}).get(key))
        put(name, ("wall",), (len(walls),), fill)
    for name, get in (("rice_rate", lambda q: q.get("rate")),
                      ("rice_x_lo", lambda q: (q.get("band") or [None])[0]),
                      ("rice_x_hi", lambda q: (q.get("band") or [None, None])[1])):
        def fill(arr, i, j, r, get=get):
            arr[i, j] = _num(get(r.get("rice") or {}))
        put(name, (), (), fill)
    for name, get in (("rice_estimate", lambda q: q.get("estimate")),
                      ("rice_true_reliability",
                       lambda q: (q.get("true") or {}).get("survival"))):
        def fill(arr, i, j, r, get=get):
            q = r.get("rice") or {}
            values = get(q)
            if values is not None:
                arr[i, j, [times.index(t) for t in q["times"]]] = [_num(v) for v in values]
        put(name, ("rice_time",), (len(times),), fill)
    coords: dict[str, Any] = {"level": level}
    if walls:
        coords["wall"] = walls
    if times:
        coords["rice_time"] = np.asarray(times, dtype=float)
    return data, coords


def spectral_dataset(doc: dict[str, Any], xr: Any):
    """The variables of the module docstring as an ``xr.Dataset`` (``xr``: the
    xarray module; with the coordinates ``point`` and ``method`` of
    :func:`fpk_vibro.labelled.run_dataset`), or None when the run computed neither
    quantity."""
    points = doc.get("points", [])
    methods = sorted({m for p in points for m in p.get("methods", {})})
    data, coords = _spectra(points, methods, doc.get("spectra") or {})
    more, more_coords = _crossings(points, methods)
    data.update(more)
    coords.update(more_coords)
    if not data:
        return None
    coords.update({"point": np.arange(len(points)), "method": methods})
    ds = xr.Dataset(data, coords=coords)
    settings = doc.get("spectra") or {}
    if "spectral_density" in ds:
        ds["spectral_density"].attrs.update(units=settings.get("units", "rad/s"),
                                            sided=settings.get("sided", "two"))
    for name, unit in (("omega", "rad/s"), ("frequency", "Hz"), ("level", "x units"),
                       ("rice_time", "s")):
        if name in ds.coords:
            ds[name].attrs["units"] = unit
    return ds
