"""Labelled data: solutions and runs as xarray Datasets and pandas DataFrames.

``Solution.to_xarray()`` gives the densities of one solution on their grids (H, x, y
and the joint (x, y) grid) with the moments and the provenance (system, method,
package version, options, seed) as attributes; :func:`run_dataset` gathers a whole
run (``results.json`` and ``densities.npz``) into one Dataset with the dimensions
``point``, ``method`` and, for transient scenes, ``time``; :func:`moments_frame`
gives a run's moments as a tidy DataFrame.  Datasets are written as netCDF-4 through
h5netcdf (on the h5py the package already uses).

xarray, pandas and h5netcdf are the optional ``data`` extra
(``pip install 'fpk_vibro[data]'``): the solvers do not need them.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .keys import ESTIMATE_KEYS

__all__ = ["solution_dataset", "run_dataset", "moments_frame", "NETCDF_ENGINE"]

#: netCDF engine of xarray used for every file written here.
NETCDF_ENGINE = "h5netcdf"


def _xarray():
    """The xarray module; an ImportError in one line naming the module that is missing
    (xarray itself, or one it imports: pandas, numpy, ...)."""
    try:
        import xarray
    except ImportError as exc:
        missing = (exc.name or "xarray").split(".")[0]
        why = "" if missing == "xarray" else \
            f" (which xarray imports; {' '.join(str(exc).split())})"
        raise ImportError(f"labelled data needs {missing}{why}: pip install "
                          "'fpk_vibro[data]' (xarray, pandas, h5netcdf)") from None
    return xarray


def _attr(value: Any) -> Any:
    """A value netCDF can hold as an attribute (numbers, strings; the rest as JSON)."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (int, float, str, np.integer, np.floating)):
        return value
    return json.dumps(value, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))


def solution_dataset(sol, grids: dict[str, Any] | None = None):
    """The densities, moments and provenance of ``sol`` as an ``xarray.Dataset``.

    Parameters
    ----------
    sol : fpk_vibro.Solution
    grids : dict, optional
        ``{"energy": H, "x": x, "y": y, "joint": (x, y)}``, each a non-empty 1-D array
        of finite numbers; a missing key (or no dict) takes the grid of a scene run
        (:func:`fpk_vibro.scales.density_grids`).  Anything else (another key, a
        grid of another shape, NaN): one-line :class:`~fpk_vibro._checks.InputError`
        naming the key.

    Returns
    -------
    xarray.Dataset
        Variables ``pdf_energy(H)``, ``pdf_x(x)``, ``pdf_y(y)``, ``pdf_joint(x_joint,
        y_joint)`` and one scalar per moment (``E_H``, ...); attributes ``method``,
        ``system`` (JSON), ``fpk_vibro_version``, ``time`` (transients) and the
        scalar entries of ``sol.info``.
    """
    xr = _xarray()
    from ._version import __version__
    g = _grids(sol, grids)
    data: dict[str, Any] = {}
    try:
        data["pdf_energy"] = (("H",), sol.pdf_energy(g["energy"]))
    except ValueError:            # e.g. FE p(H) where it does not apply
        pass
    data["pdf_x"] = (("x",), sol.pdf_x(g["x"]))
    data["pdf_y"] = (("y",), sol.pdf_y(g["y"]))
    gx, gy = g["joint"]
    data["pdf_joint"] = (("x_joint", "y_joint"), sol.pdf_joint(gx[:, None], gy[None, :]))
    for k, v in sol.moments().items():
        data[k] = ((), float(v))
    if hasattr(sol, "moments_se"):
        for k, v in sol.moments_se().items():
            data[k + "_se"] = ((), float(v))
    coords = {"H": g["energy"], "x": g["x"], "y": g["y"], "x_joint": gx, "y_joint": gy}
    ds = xr.Dataset(data, coords=coords)
    attrs = {"method": sol.kind, "system": sol.system.to_json(),
             "fpk_vibro_version": __version__}
    if getattr(sol, "time", None) is not None:
        attrs["time"] = float(sol.time)
    info = getattr(sol, "info", None)
    if isinstance(info, dict):
        attrs.update({f"info_{k}": _attr(v) for k, v in info.items()
                      if v is not None and isinstance(v, (bool, int, float, str, np.integer,
                                                          np.floating))})
    est = getattr(sol, "_estimate", None)     # an estimate already made (not made here)
    if isinstance(est, dict):
        attrs.update({f"error_estimate_{k}": float(est[k]) for k in ESTIMATE_KEYS if k in est})
    for attr in ("seed_entropy", "n_paths", "dt"):
        v = getattr(sol, attr, None)
        if v is not None and not callable(v):
            attrs[attr] = _attr(v)
    ds.attrs.update(attrs)
    ds["pdf_energy" if "pdf_energy" in ds else "pdf_x"].attrs["long_name"] = "probability density"
    for name, unit in (("H", "J/kg"), ("x", "m"), ("y", "m/s"), ("x_joint", "m"),
                       ("y_joint", "m/s")):
        ds[name].attrs["units"] = unit
    return ds


#: The keys of ``grids`` in :func:`solution_dataset`.
GRID_KEYS = ("energy", "x", "y", "joint")


def _grids(sol, grids: Any) -> dict[str, Any]:
    """``grids`` checked (one line naming the key), the missing ones the defaults."""
    from collections.abc import Mapping

    from ._checks import check_points, closest, invalid
    from .scales import density_grids
    where = "to_xarray"
    if grids is None:
        grids = {}
    if not isinstance(grids, Mapping):
        raise invalid(where, "grids", f"a dict with keys from {list(GRID_KEYS)}", grids)
    for k in grids:
        if k not in GRID_KEYS:
            hint = closest(k, GRID_KEYS)
            raise invalid(where, "grids", f"a dict with keys from {list(GRID_KEYS)}",
                          k, "unknown key" + (f"; {hint[2:-1]}" if hint else ""))

    def axis(name: str, v: Any) -> np.ndarray:
        arr = check_points(name, v, where=where)
        if arr.ndim != 1 or arr.size == 0:
            raise invalid(where, name, "a non-empty 1-D array of finite numbers", v,
                          f"shape {arr.shape}")
        return arr

    out = dict(density_grids(sol.system, sol)) if set(grids) != set(GRID_KEYS) else {}
    for k, v in grids.items():
        if k != "joint":
            out[k] = axis(f"grids[{k!r}]", v)
        elif isinstance(v, (str, bytes)) or not hasattr(v, "__len__") or len(v) != 2:
            raise invalid(where, "grids['joint']", "a pair (x, y) of 1-D arrays", v)
        else:
            out[k] = tuple(axis(f"grids['joint'][{i}]", v[i]) for i in range(2))
    return out


def _records(out_dir: Path) -> dict[str, Any]:
    path = Path(out_dir) / "results.json"
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a readable results file ({exc})") from None


def run_dataset(out_dir: str | Path):
    """A run's results (``out_dir/results.json`` and ``densities.npz``) as one Dataset.

    Dimensions ``point`` (with the swept parameters as coordinates), ``method`` and,
    for transient scenes, ``time``; moments as ``E_H(point, method[, time])`` with
    ``*_se`` for Monte Carlo (NaN where a method has none), each answer's estimate
    as ``<key>_error_estimate`` (inf: no bound follows; NaN: none made); densities, where the run
    wrote them, as ``pdf_<q>(point, method, <q>_index)`` with their grids as the
    coordinate ``<q>_grid(point, <q>_index)`` (grids differ between points).  A
    stationary run's impact quantities where it computed them:
    ``inter_impact_mean(point, method)`` (with ``_se``, ``_one_over_rate``,
    ``_error_estimate``), ``impact_energy_mean(point, method, wall)`` (with ``_se``,
    ``_error_estimate``), their densities ``pdf_inter_impact`` /
    ``pdf_impact_energy(point, method, wall, impact_energy_index)`` on
    ``inter_impact_grid`` / ``impact_energy_grid``, and the first passage
    ``first_passage_mean(point, method)`` (with ``_se``) and ``reliability(point,
    method, reliability_index)`` at ``reliability_time`` (the safe set in the
    attribute ``safe_set``).

    A forced scene's periodic response (results.json ``"periodic": true``) has the
    dimension ``phase`` (radians) besides: the moments above are the period
    averages, and per phase ``phase_E_x``, ``phase_E_x2``, ``phase_E_y2``,
    ``phase_E_H``, ``phase_P_impact`` ... ``(point, method, phase)`` with ``_se`` and
    ``_error_estimate``, ``impact_rate(point, method, phase, wall)`` (with ``_se``),
    the first harmonic of the mean ``mean_x``, ``amplitude``, ``lag(point, method)``
    (with ``_se``, ``_error_estimate``: absolute, radians), and the densities at
    each phase ``phase_pdf_<q>(point, method, phase, <q>_index)`` on
    ``phase_<q>_grid(point, phase, <q>_index)``
    (:mod:`fpk_vibro._labelled_periodic`).  Spectra and crossings on ``omega`` (or
    ``frequency``) and ``level``: :mod:`fpk_vibro._labelled_spectra`.
    """
    xr = _xarray()
    doc = _records(out_dir)
    points = doc["points"]
    methods = sorted({m for p in points for m in p.get("methods", {})})
    transient = not doc.get("stationary", True)
    times = sorted({t for p in points for e in p.get("methods", {}).values()
                    for t in e.get("times", [])}) if transient else []
    keys = sorted({k for p in points for e in p.get("methods", {}).values()
                   for rec in (e.get("at") or [e]) for k in rec.get("moments", {})})
    shape = (len(points), len(methods)) + ((len(times),) if transient else ())
    dims = ("point", "method") + (("time",) if transient else ())
    data: dict[str, Any] = {}
    for key in keys:
        for suffix, field in (("", "moments"), ("_se", "moments_se")):
            arr = np.full(shape, np.nan)
            for i, p in enumerate(points):
                for j, m in enumerate(methods):
                    e = p.get("methods", {}).get(m)
                    if e is None:
                        continue
                    recs = e.get("at") or [e]
                    for k, rec in enumerate(recs):
                        v = rec.get(field, {}).get(key)
                        if v is not None:
                            arr[(i, j, k) if transient else (i, j)] = v
            if suffix == "" or np.isfinite(arr).any():
                data[key + suffix] = (dims, arr)
    for key in ESTIMATE_KEYS:    # the estimates of the run (results.json), NaN where none
        arr = np.full(shape, np.nan)
        for i, p in enumerate(points):
            for j, m in enumerate(methods):
                e = p.get("methods", {}).get(m) or {}
                for k, rec in enumerate(e.get("at") or [e]):
                    est = rec.get("error_estimate") or {}
                    if key in est:      # None in JSON: no bound follows
                        arr[(i, j, k) if transient else (i, j)] = (
                            np.inf if est[key] is None else est[key])
        if not np.isnan(arr).all():
            data[f"{key}_error_estimate"] = (dims, arr)
    params = sorted({k for p in points for k in p.get("parameters", {})})
    coords: dict[str, Any] = {"point": np.arange(len(points)), "method": methods,
                              "status": ("point", [p.get("status", "") for p in points])}
    for k in params:
        coords[f"param_{k}"] = ("point", [p.get("parameters", {}).get(k, np.nan) for p in points])
    if transient:
        coords["time"] = np.asarray(times, dtype=float)
    data.update(_densities(Path(out_dir), points, methods, len(times)))
    periodic = bool(doc.get("periodic"))
    entries = [e for p in points for e in p.get("methods", {}).values()]
    walls = sorted({w for e in entries for w in e.get("impact_energy", {})})
    if periodic:
        from ._labelled_periodic import periodic_data
        coords["phase"] = np.asarray(doc["phases"], dtype=float)
        data.update(periodic_data(points, methods, len(doc["phases"])))
        data.update(_densities(Path(out_dir), points, methods, len(doc["phases"]),
                               tag="ph", dim="phase", prefix="phase_"))
        walls = sorted({w for e in entries for w in (e.get("periodic") or {}).get(
            "impact_rates", {})})
    elif not transient:
        data.update(_impact_data(Path(out_dir), points, methods))
    ds = xr.Dataset(data, coords=coords)
    if "wall" in ds.dims:
        ds = ds.assign_coords(wall=walls)
    safe = next((e["first_passage"]["safe_set"] for e in entries
                 if "safe_set" in e.get("first_passage", {})), None)
    if safe is not None:
        ds.attrs["safe_set"] = _attr(safe)
    from ._labelled_spectra import spectral_dataset
    spectral = spectral_dataset(doc, xr)      # on the coordinates omega/frequency, level
    if spectral is not None:
        ds = xr.merge([ds, spectral], combine_attrs="override", join="outer")
    ds.attrs.update({"name": doc.get("name", ""), "fpk_vibro_version": doc.get("fpk_vibro_version", ""),
                     "status": doc.get("status", ""), "scene": _attr(doc.get("scene", {}))})
    return ds


def _densities(out_dir: Path, points: list, methods: list[str], n_times: int = 0, *,
               tag: str = "t", dim: str = "time", prefix: str = "") -> dict[str, Any]:
    """pdf_<q>(point, method[, time], <q>_index) and <q>_grid(point[, time], <q>_index)
    from densities.npz (grids differ between points and times); the phases of a
    periodic run likewise (``tag`` "ph", ``dim`` "phase", ``prefix`` "phase_")."""
    f = out_dir / "densities.npz"
    if not f.exists():
        return {}
    tags = [f".{tag}{k}" for k in range(n_times)] if n_times else [""]
    out: dict[str, Any] = {}
    with np.load(f) as npz:
        for q in ("energy", "x", "y"):
            found = {(i, k): npz[f"p{i}.{m}.{q}{tag}.grid"] for i in range(len(points))
                     for k, tag in enumerate(tags) for m in methods
                     if f"p{i}.{m}.{q}{tag}.grid" in npz.files}
            if not found:
                continue
            n = max(g.size for g in found.values())
            grid = np.full((len(points), len(tags), n), np.nan)
            pdf = np.full((len(points), len(methods), len(tags), n), np.nan)
            for (i, k), g in found.items():
                grid[i, k, :g.size] = g
                for j, m in enumerate(methods):
                    key = f"p{i}.{m}.{q}{tags[k]}.pdf"
                    if key in npz.files:
                        pdf[i, j, k, :g.size] = npz[key]
            if n_times:
                out[f"{prefix}{q}_grid"] = (("point", dim, f"{q}_index"), grid)
                out[f"{prefix}pdf_{q}"] = (("point", "method", dim, f"{q}_index"), pdf)
            else:
                out[f"{q}_grid"] = (("point", f"{q}_index"), grid[:, 0])
                out[f"pdf_{q}"] = (("point", "method", f"{q}_index"), pdf[:, :, 0])
    return out


def _impact_data(out_dir: Path, points: list, methods: list[str]) -> dict[str, Any]:
    """The impact quantities and first passage of a stationary run (see
    :func:`run_dataset`), NaN where a point or method has none."""
    out: dict[str, Any] = {}
    entries = [[p.get("methods", {}).get(m) or {} for m in methods] for p in points]
    shape = (len(points), len(methods))

    def scalar(name: str, get) -> None:
        arr = np.full(shape, np.nan)
        for i, row in enumerate(entries):
            for j, e in enumerate(row):
                v = get(e)
                if isinstance(v, (int, float)):
                    arr[i, j] = v
        if not np.isnan(arr).all():
            out[name] = (("point", "method"), arr)

    def est(rec: dict) -> Any:      # None in JSON: no bound follows
        e = rec.get("error_estimate") or {}
        return (np.inf if e["mean"] is None else e["mean"]) if "mean" in e else None

    gap = lambda e: e.get("inter_impact") or {}                    # noqa: E731
    scalar("inter_impact_mean", lambda e: gap(e).get("mean"))
    scalar("inter_impact_mean_se", lambda e: gap(e).get("mean_se"))
    scalar("inter_impact_one_over_rate", lambda e: gap(e).get("one_over_rate"))
    scalar("inter_impact_mean_error_estimate", lambda e: est(gap(e)))
    fp = lambda e: e.get("first_passage") or {}                    # noqa: E731
    scalar("first_passage_mean", lambda e: fp(e).get("mean"))
    scalar("first_passage_mean_se", lambda e: fp(e).get("mean_se"))
    walls = sorted({w for row in entries for e in row for w in e.get("impact_energy", {})})
    if walls:
        for name, get in (("impact_energy_mean", lambda r: r.get("mean")),
                          ("impact_energy_mean_se", lambda r: r.get("mean_se")),
                          ("impact_energy_mean_error_estimate", est)):
            arr = np.full(shape + (len(walls),), np.nan)
            for i, row in enumerate(entries):
                for j, e in enumerate(row):
                    for k, w in enumerate(walls):
                        v = get(e.get("impact_energy", {}).get(w) or {})
                        if isinstance(v, (int, float)):
                            arr[i, j, k] = v
            if not np.isnan(arr).all():
                out[name] = (("point", "method", "wall"), arr)
    runs = [(i, j, fp(e)) for i, row in enumerate(entries) for j, e in enumerate(row)
            if fp(e).get("times")]
    if runs:
        n = max(len(r["times"]) for _, _, r in runs)
        t, R = np.full(shape + (n,), np.nan), np.full(shape + (n,), np.nan)
        for i, j, r in runs:
            t[i, j, :len(r["times"])], R[i, j, :len(r["survival"])] = r["times"], r["survival"]
        dims = ("point", "method", "reliability_index")
        out["reliability_time"], out["reliability"] = (dims, t), (dims, R)
    out.update(_impact_densities(out_dir, len(points), methods, walls))
    return out


def _impact_densities(out_dir: Path, n_points: int, methods: list[str], walls: list[str]
                      ) -> dict[str, Any]:
    """pdf_inter_impact(point, method, inter_impact_index) and pdf_impact_energy(point,
    method, wall, impact_energy_index) with their grids, from densities.npz."""
    f = out_dir / "densities.npz"
    if not f.exists():
        return {}
    out: dict[str, Any] = {}
    with np.load(f) as npz:
        for q, sides in (("inter_impact", [""]), ("impact_energy", [f"_{w}" for w in walls])):
            keys = {(i, k, j): f"p{i}.{m}.{q}{side}" for i in range(n_points)
                    for k, side in enumerate(sides) for j, m in enumerate(methods)
                    if f"p{i}.{m}.{q}{side}.grid" in npz.files}
            if not keys:
                continue
            n = max(npz[f"{key}.grid"].size for key in keys.values())
            grid = np.full((n_points, len(sides), n), np.nan)
            pdf = np.full((n_points, len(methods), len(sides), n), np.nan)
            for (i, k, j), key in keys.items():
                g = npz[f"{key}.grid"]
                grid[i, k, :g.size] = g
                pdf[i, j, k, :g.size] = npz[f"{key}.pdf"]
            if q == "inter_impact":
                out["inter_impact_grid"] = (("point", "inter_impact_index"), grid[:, 0])
                out["pdf_inter_impact"] = (("point", "method", "inter_impact_index"),
                                           pdf[:, :, 0])
            else:
                out["impact_energy_grid"] = (("point", "wall", "impact_energy_index"), grid)
                out["pdf_impact_energy"] = (("point", "method", "wall",
                                             "impact_energy_index"), pdf)
    return out


def moments_frame(out_dir: str | Path):
    """A run's moments as a ``pandas.DataFrame``: one row per point, method (and time),
    a column per moment and its standard error (``*_se``, Monte Carlo), and the swept
    parameters (``param_*``) and the point's status."""
    ds = run_dataset(out_dir)      # (a periodic run: the period averages and harmonic)
    moments = [v for v in ds.data_vars if not v.startswith("pdf_") and not v.endswith("_grid")
               and "phase" not in ds[v].dims]
    return ds[moments].to_dataframe().reset_index()
