"""Figures of the impact quantities of a run: the density of the time between impacts
and of the energy one impact dissipates, every method overlaid (Monte Carlo as its
histogram with ±1 SE bars), from the arrays of :mod:`fpk_vibro.app.impact_records`.

The conventions of :mod:`fpk_vibro.app.plotting` hold.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .plotting import _STYLE, METHOD_NAMES, _pyplot, _save

__all__ = ["point_figures", "inter_impact", "impact_energy", "law_label"]


def law_label(wall: Any) -> str:
    """A wall's restitution in words: ``r = 0.8``, ``r(u) = 0.9 − 0.2 tanh(u/1)``."""
    law = wall.law
    if law is None:
        return f"r = {wall.r:g}"
    if law.constant is not None:
        return f"r = {law.constant:g}"
    if law.kind == "tanh":
        return f"r(u) = {law.r0:g} − {law.r1:g} tanh(u/{law.u0:g})"
    if law.kind == "table":
        return f"r(u) from {law.values[0]:g} to {law.values[-1]:g} (table)"
    return "r(u) (a function)"


def _curves(ax, arrays: dict, key: str, mark: dict[str, float],
            notes: dict[str, str] | None = None) -> None:
    """Every method's density of ``p{i}.{method}.{key}`` on ``ax``, its mean ``mark``
    dotted (and named in the legend with ``notes``)."""
    for name in sorted(k for k in arrays if k.endswith(f".{key}.pdf")):
        method = name.split(".")[1]
        base = name[:-4]
        label = METHOD_NAMES.get(method, method)
        if method in mark:
            label += f" (mean {mark[method]:.4g}{(notes or {}).get(method, '')})"
        if f"{base}.hist" in arrays:
            e, h, se = arrays[f"{base}.edges"], arrays[f"{base}.hist"], arrays[f"{base}.se"]
            mid = 0.5 * (e[1:] + e[:-1])
            keep = mid <= arrays[f"{base}.grid"][-1]
            ax.errorbar(mid[keep], h[keep], yerr=np.nan_to_num(se[keep]), fmt="o", ms=3,
                        mfc="none", color="C2", capsize=1.5, lw=0.8, label=label + ", ±1 SE")
            color = "C2"
        else:
            line, = ax.plot(arrays[f"{base}.grid"], arrays[name], label=label,
                            **_STYLE.get(method, {}))
            color = line.get_color()
        if method in mark:
            ax.axvline(mark[method], color=color, ls=":", lw=0.9)
    ax.set_ylim(bottom=0.0)
    ax.legend(frameon=False, fontsize=7)


def inter_impact(arrays: dict, entries: dict, path, *, title: str = "") -> Path:
    """The density of the time between successive impacts (any wall), each method's
    mean dotted and, in the legend, beside 1/ν of its own impact rate (the identity
    the means meet)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.2, 4.2), dpi=110)
    gaps = {m: e["inter_impact"] for m, e in entries.items()
            if "mean" in e.get("inter_impact", {})}
    _curves(ax, arrays, "inter_impact", {m: g["mean"] for m, g in gaps.items()},
            {m: f", 1/ν {g['one_over_rate']:.4g}" for m, g in gaps.items()
             if g.get("one_over_rate")})
    ax.set_xlabel(r"time between impacts $T$ (s)")
    ax.set_ylabel(r"probability density $f(T)$ (1/s)")
    ax.set_title(f"{title}: time between successive impacts (any wall)", fontsize=9)
    return _save(fig, path)


def impact_energy(arrays: dict, entries: dict, system: Any, path, *, title: str = "") -> Path:
    """The density of the energy one impact dissipates, one panel per wall that
    dissipates (its law in the title), each method's mean dotted."""
    plt = _pyplot()
    walls = [(s, w) for s, w in system.walls
             if any(k.endswith(f".impact_energy_{s}.pdf") for k in arrays)]
    fig, axes = plt.subplots(1, len(walls), figsize=(5.0 * len(walls), 3.8), dpi=110,
                             squeeze=False)
    for ax, (side, wall) in zip(axes[0], walls):
        means = {m: e["impact_energy"][side]["mean"] for m, e in entries.items()
                 if "mean" in e.get("impact_energy", {}).get(side, {})}
        _curves(ax, arrays, f"impact_energy_{side}", means)
        ax.set_xlabel(r"energy dissipated per impact $e = (1 - r(u)^2)\,u^2/2$ (J/kg)")
        ax.set_ylabel(r"probability density $p(e)$ (kg/J)")
        ax.set_title(f"{side} wall at x = {wall.position:g}, {law_label(wall)}", fontsize=8)
    fig.suptitle(f"{title}: energy per impact", fontsize=9)
    return _save(fig, path)


def point_figures(arrays: dict, entries: dict, system: Any, out_dir: Path, index: int,
                  title: str) -> list[Path]:
    """The figures of one point whose arrays hold the densities."""
    out = []
    if any(k.endswith(".inter_impact.pdf") for k in arrays):
        out.append(inter_impact(arrays, entries, out_dir / f"p{index}_inter_impact.png",
                                title=title))
    if any(".impact_energy_" in k and k.endswith(".pdf") for k in arrays):
        out.append(impact_energy(arrays, entries, system,
                                 out_dir / f"p{index}_impact_energy.png", title=title))
    return out
