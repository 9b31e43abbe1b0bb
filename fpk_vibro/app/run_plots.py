"""Figures of a run beyond the densities (``fpk-vibro run``): impact speeds, first
passage, moments in time and the sweep overlays.

The conventions of :mod:`fpk_vibro.app.plotting` hold: bare figures written to
files, methods named in words, Monte Carlo with ±1 standard-error bars.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..keys import moment_scale
from .impact_plots import law_label
from .plotting import _STYLE, METHOD_NAMES, _Figures, _pyplot, _sampled, _save

__all__ = ["impact_speeds", "reliability", "moment_history", "sweep_overlay", "sweep_moments"]

#: Short axis labels of the sweep overlays.
_LABELS = {"energy": (r"energy $H$", r"$p(H)$"), "x": (r"displacement $x$", r"$p(x)$"),
           "y": (r"velocity $y$", r"$p(y)$")}


def impact_speeds(solutions: dict, path, *, title: str = "") -> Path:
    """The density of the speed just before impact, one panel per wall, every method
    (Monte Carlo as a histogram with ±1 SE bars when it recorded the speeds)."""
    plt = _pyplot()
    system = next(iter(solutions.values())).system
    walls = [side for side, _ in system.walls]
    fig, axes = plt.subplots(1, len(walls), figsize=(5.0 * len(walls), 3.8), dpi=110,
                             squeeze=False)
    for ax, side in zip(axes[0], walls):
        top = 0.0
        for method, sol in solutions.items():
            hist = getattr(sol, "impact_speed_histogram", None)
            if hist is not None:
                try:
                    edges, dens, se = hist(side)
                except (ValueError, KeyError):
                    continue
                mid = 0.5 * (edges[1:] + edges[:-1])
                ax.errorbar(mid, dens, yerr=se, fmt="o", ms=3, mfc="none", color="C2",
                            capsize=1.5, lw=0.8, label=METHOD_NAMES.get(method, method) + " (±1 SE)")
                top = max(top, float(edges[-1]))
        u = np.linspace(0.0, top or 3.0 * max(
            v.impacts()[side]["mean_speed"] for m, v in solutions.items()
            if not _sampled(m)), 400)
        for method, sol in solutions.items():
            if _sampled(method):
                continue
            try:
                ax.plot(u, sol.impact_speed_pdf(side, u), label=METHOD_NAMES.get(method, method),
                        **_STYLE.get(method, {}))
            except NotImplementedError:
                pass
        ax.set_xlabel(r"impact speed $u$ (m/s)")
        ax.set_ylabel(r"probability density $f(u)$ (s/m)")
        ax.set_title(f"{side} wall, {law_label(getattr(system, side))}", fontsize=9)
        ax.legend(frameon=False, fontsize=8)
    fig.suptitle(title, fontsize=9)
    return _save(fig, path)


def reliability(passages: dict, path, *, title: str = "") -> Path:
    """R(t) = P(T > t) of each method (Monte Carlo with its 95 % band); the title names
    the safe set (:meth:`fpk_vibro.safe_sets.SafeSet.describe`)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.2), dpi=110)
    t_end = max(float(fp.times[-1]) for fp in passages.values())
    for method, fp in passages.items():
        if fp.survival_band is not None:
            ax.fill_between(fp.times, *fp.survival_band, color="C2", alpha=0.25, lw=0)
        ax.plot(fp.times, fp.survival, label=f"{METHOD_NAMES.get(method, method)}: "
                f"τ = {fp.mean:.4g}" + (f" ± {fp.mean_se:.2g}" if fp.mean_se else ""),
                **_STYLE.get(method, {"color": "C2"}))
    ax.set_xlim(0, t_end)
    ax.set_xlabel("time $t$ (s)")
    ax.set_ylabel(r"reliability $R(t) = P(T > t)$")
    fp0 = next(iter(passages.values()))
    safe = getattr(fp0, "safe_set", None)
    where = safe.describe() if safe is not None else f"H < {fp0.energy:g}"
    ax.set_title(f"{title}: first passage out of {where}", fontsize=9)
    ax.legend(frameon=False, fontsize=8)
    return _save(fig, path)


def _relative(est: dict | None, key: str) -> float:
    """A record's relative estimate of ``key``: NaN where none was made."""
    if not est or key not in est:
        return math.nan
    return math.inf if est[key] is None else float(est[key])


def moment_history(entries: dict, path, *, key: str = "E_H", title: str = "") -> Path:
    """A moment against time for each method: Monte Carlo with bars of its estimate
    (±1 SE where it has none), the others with a band of their estimate where the
    record holds one.

    ``entries``: method → {"times": [...], "at": [{"moments": {...}, "moments_se": {...},
    "error_estimate": {...}}]} as written in results.json.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.2), dpi=110)
    for method, e in entries.items():
        t = np.asarray(e["times"], dtype=float)
        v = np.array([a["moments"][key] for a in e["at"]])
        # relative estimate → absolute half-width (NaN: none made, inf: unbounded)
        rel = np.array([_relative(a.get("error_estimate"), key) for a in e["at"]])
        scale = np.array([moment_scale(key, x) for x in v])
        if _sampled(method):
            se = np.array([a["moments_se"][key] for a in e["at"]])
            has = np.isfinite(rel)
            bar = np.where(has, rel * scale, se)
            ax.errorbar(t, v, yerr=bar, fmt="o", ms=4, mfc="none", color="C2", capsize=2,
                        label="Monte Carlo (±estimate)" if has.all() else "Monte Carlo (±1 SE)")
        else:
            style = _STYLE.get(method, {})
            line, = ax.plot(t, v, marker=".", label=method, **style)
            if np.isfinite(rel).any():
                half = np.where(np.isfinite(rel), rel * scale, 0.0)
                ax.fill_between(t, v - half, v + half, color=line.get_color(), alpha=0.2,
                                lw=0)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel("time $t$")
    ax.set_ylabel({"E_H": r"$E[H](t)$", "E_x2": r"$E[x^2](t)$", "E_y2": r"$E[y^2](t)$"}.get(key, key))
    ax.set_title(title, fontsize=9)
    ax.legend(frameon=False, fontsize=8)
    return _save(fig, path)


def sweep_overlay(arrays: dict, points: list, quantity: str, path, *, title: str = "") -> Path:
    """One figure with a density of every sweep point and method (the paper's Fig. 3 style).

    ``arrays``: the merged densities.npz content; ``points``: the results.json points.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=110)
    for i, point in enumerate(points):
        if "error" in point:
            continue
        label = ", ".join(f"{k} = {v:g}" for k, v in point["parameters"].items())
        color = f"C{i % 10}"
        for method in point["methods"]:
            key = f"p{point['index']}.{method}.{quantity}"
            if f"{key}.grid" not in arrays:
                continue
            if _sampled(method):
                e, h, se = arrays[f"{key}.edges"], arrays[f"{key}.hist"], arrays[f"{key}.se"]
                mid = 0.5 * (e[1:] + e[:-1])
                keep = mid <= arrays[f"{key}.grid"][-1]
                ax.errorbar(mid[keep], h[keep], yerr=se[keep], fmt="o", ms=3, mfc="none",
                            color=color, capsize=1.5, lw=0.7, label=f"Monte Carlo, {label}")
            else:
                ax.plot(arrays[f"{key}.grid"], arrays[f"{key}.pdf"], color=color,
                        ls={"fem": "--", "exact": ":"}.get(method, "-"), lw=1.4,
                        label=f"{method}, {label}")
    xl, yl = _LABELS[quantity]
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title(title, fontsize=9)
    ax.legend(frameon=False, fontsize=7)
    return _save(fig, path)


def _swept_label(p: str) -> str:
    """A swept parameter with its unit: ``external.tau (s)``, ``D1``."""
    from .scene_keys import sweep_option
    try:
        unit = sweep_option(p).unit
    except KeyError:
        unit = ""
    return f"{p} ({unit})" if unit else p


def sweep_moments(points: list, path, *, keys=("E_H", "E_x2", "E_y2"), title: str = "") -> Path:
    """Moments against the (first) swept parameter (any of them: ``D1``,
    ``forcing.frequency``, ``external.tau``), one line per method (Monte Carlo ±1 SE);
    a two-parameter sweep is faceted: one row of panels per value of the
    second parameter."""
    done = [p for p in points if p.get("status") == "done"]
    params = list(done[0]["parameters"]) if done else []
    if not params:
        raise ValueError("sweep_moments: the run has no swept parameter")
    first, second = params[0], (params[1] if len(params) > 1 else None)
    methods = list(done[0]["methods"])
    groups = sorted({p["parameters"][second] for p in done}) if second else [None]
    fig, axes = _Figures.subplots(len(groups), len(keys), figsize=(4.6 * len(keys),
                                  3.4 * len(groups)), dpi=110, squeeze=False)
    for row, gval in zip(axes, groups):
        sel = sorted((p for p in done if second is None or p["parameters"][second] == gval),
                     key=lambda p: p["parameters"][first])
        xs = np.array([p["parameters"][first] for p in sel])
        for ax, key in zip(row, keys):
            for mi, method in enumerate(methods):
                rec = [p["methods"][method] for p in sel if method in p["methods"]]
                if len(rec) != len(sel):
                    continue
                ys = np.array([r["moments"].get(key, np.nan) for r in rec])
                name = METHOD_NAMES.get(method, method)
                if _sampled(method):
                    se = np.array([r.get("moments_se", {}).get(key, np.nan) for r in rec])
                    ax.errorbar(xs, ys, yerr=se, fmt="o", ms=3, mfc="none", capsize=2, lw=0.8,
                                color="C2", label=name + " (±1 SE)")
                else:
                    style = dict(_STYLE.get(method, {}))
                    style.setdefault("color", f"C{mi}")
                    ax.plot(xs, ys, marker=".", label=name, **style)
            ax.set_xlabel(_swept_label(first))
            ax.set_ylabel({"E_H": r"$E[H]$ (J/kg)", "E_x2": r"$E[x^2]$ (m²)",
                           "E_y2": r"$E[y^2]$ (m²/s²)"}.get(key, key))
            if second is not None:
                ax.set_title(f"{second} = {gval:g}", fontsize=8)
    axes[0][0].legend(frameon=False, fontsize=7)
    fig.suptitle(title, fontsize=9)
    return _save(fig, path)
