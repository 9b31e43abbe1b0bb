"""The periodic response of a forced run as labelled data (:func:`fpk_vibro.labelled.run_dataset`).

From each entry's ``periodic`` record (:mod:`fpk_vibro.app.periodic_records`):
``phase_<moment>(point, method, phase)`` (E_x, E_x2, E_y2, E_H, P_impact, ...) with
``_se`` (sampled methods) and ``_error_estimate`` (relative, the figures of
:data:`fpk_vibro.keys.ESTIMATE_KEYS`), ``impact_rate(point, method, phase, wall)``
with ``_se``, and the first harmonic of the mean ``mean_x``, ``amplitude``, ``lag``
(point, method) with ``_se`` and ``_error_estimate`` (absolute; lag in radians).
NaN where a point or method has none.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .keys import ESTIMATE_KEYS

__all__ = ["periodic_data"]

HARMONIC_KEYS = ("mean_x", "amplitude", "lag")


def _put(arr: np.ndarray, at: tuple, values: Any) -> None:
    """``values`` (a list, None for no bound: inf) into ``arr[at]``."""
    v = np.array([np.inf if x is None else x for x in values], dtype=float)
    arr[at][:v.size] = v


def periodic_data(points: list, methods: list[str], n_phases: int) -> dict[str, Any]:
    """The variables of the module docstring, for ``xarray.Dataset``."""
    recs = [[(p.get("methods", {}).get(m) or {}).get("periodic") for m in methods]
            for p in points]
    shape = (len(points), len(methods))
    dims = ("point", "method", "phase")
    out: dict[str, Any] = {}
    found = [(i, j, r) for i, row in enumerate(recs) for j, r in enumerate(row) if r]
    keys = list(dict.fromkeys(k for _, _, r in found for k in r.get("moments", {})))
    for key in keys:
        for suffix, field in (("", "moments"), ("_se", "moments_se")):
            arr = np.full(shape + (n_phases,), np.nan)
            for i, j, r in found:
                if key in r.get(field, {}):
                    _put(arr, (i, j), r[field][key])
            if suffix == "" or np.isfinite(arr).any():
                out[f"phase_{key}{suffix}"] = (dims, arr)
    for key in ESTIMATE_KEYS:
        arr = np.full(shape + (n_phases,), np.nan)
        for i, j, r in found:
            per = (r.get("error_estimate") or {}).get("phases") or []
            if per and key in per[0]:
                _put(arr, (i, j), [e.get(key) for e in per])
        if not np.isnan(arr).all():
            out[f"phase_{key}_error_estimate"] = (dims, arr)
    walls = sorted({w for _, _, r in found for w in r.get("impact_rates", {})})
    for suffix in ("", "_se"):
        arr = np.full(shape + (n_phases, len(walls)), np.nan)
        for i, j, r in found:
            for k, w in enumerate(walls):
                vals = r.get(f"impact_rates{suffix}", {}).get(w)
                if vals is not None:
                    arr[i, j, :len(vals), k] = [np.nan if x is None else x for x in vals]
        if walls and not np.isnan(arr).all():
            out[f"impact_rate{suffix}"] = (dims + ("wall",), arr)
    for key in HARMONIC_KEYS:
        for suffix, get in (("", lambda r, k=key: r.get(k)),
                            ("_se", lambda r, k=key: (r.get("harmonic_se") or {}).get(k)),
                            ("_error_estimate",
                             lambda r, k=key: (r.get("error_estimate") or {}).get(k))):
            arr = np.full(shape, np.nan)
            for i, j, r in found:
                v = get(r)
                if isinstance(v, (int, float)):
                    arr[i, j] = v
            if suffix == "" or not np.isnan(arr).all():
                out[f"{key}{suffix}"] = (("point", "method"), arr)
    return out
