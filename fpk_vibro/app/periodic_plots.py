"""Figures of the periodic response to harmonic plus random excitation (a forced
scene): the moments against phase, the joint density at four phases, the impact
rates against phase and, over a sweep of the forcing, the response curve.

The phase is φ = (Ωt + φ0) mod 2π, where the forcing is F cos φ.  The conventions of
:mod:`fpk_vibro.app.plotting` hold: bare figures written to files, methods named in
words, Monte Carlo as points with ±1 standard-error bars, the others as lines with
a band of their own estimate where the record holds one.  Everything is drawn from
the records of results.json (:mod:`fpk_vibro.app.periodic_records`), except the
joint densities, drawn from the solutions.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..keys import moment_scale
from .periodic_records import four_phases
from .plotting import _STYLE, METHOD_NAMES, _draw_walls, _pyplot, _sampled, _save

__all__ = ["phase_moments", "joint_phases", "impact_rates", "response_curve",
           "phase_label"]

TWO_PI = 2.0 * math.pi
_YLABEL = {"E_x": r"mean $E[x]$ (m)", "E_x2": r"$E[x^2]$ (m²)", "E_y2": r"$E[y^2]$ (m²/s²)",
           "E_H": r"$E[H]$ (J/kg)", "P_impact": r"$P_{impact}$"}


def phase_label(phi: float) -> str:
    """A phase in words: a multiple of π/4 as such, else in radians.

    >>> phase_label(0.0), phase_label(math.pi / 2), phase_label(3 * math.pi / 4), phase_label(1.0)
    ('0', 'π/2', '3π/4', '1 rad')
    """
    k = phi / (math.pi / 4)
    if abs(k - round(k)) > 1e-9:
        return f"{phi:.3g} rad"
    num, den = int(round(k)), 4
    if num == 0:
        return "0"
    g = math.gcd(num, den)
    num, den = num // g, den // g
    top = "π" if num == 1 else f"{num}π"
    return top if den == 1 else f"{top}/{den}"


def _phase_axis(ax) -> None:
    ax.set_xlim(-0.1, TWO_PI + 0.1)
    ax.set_xticks([k * math.pi / 2 for k in range(5)], ["0", "π/2", "π", "3π/2", "2π"])
    ax.set_xlabel(r"phase $\varphi = \Omega t + \varphi_0$ (rad)")


def _array(values: Any) -> np.ndarray:
    """A record's list (None where not finite) as floats (NaN)."""
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def _closed(ph: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted by phase, the first point repeated one period on (a closed period)."""
    o = np.argsort(ph)
    return np.append(ph[o], ph[o][0] + TWO_PI), np.append(v[o], v[o][0])


def _series(ax, method: str, ph: np.ndarray, v: np.ndarray, se: np.ndarray | None,
            half: np.ndarray | None, index: int) -> str:
    """One method's values against phase; the colour used."""
    name = METHOD_NAMES.get(method, method)
    if _sampled(method):
        ax.errorbar(ph, v, yerr=None if se is None else np.nan_to_num(se), fmt="o", ms=3.5,
                    mfc="none", color="C2", capsize=2, lw=0.8,
                    label=name + (" (±1 SE)" if se is not None else ""))
        return "C2"
    style = dict(_STYLE.get(method, {}))
    style.setdefault("color", f"C{index}")
    x, y = _closed(ph, v)
    line, = ax.plot(x, y, marker=".", label=name, **style)
    if half is not None and np.isfinite(half).any():
        _, h = _closed(ph, np.where(np.isfinite(half), half, 0.0))
        ax.fill_between(x, y - h, y + h, color=line.get_color(), alpha=0.2, lw=0)
    return line.get_color()


def _estimate_half(per: dict, key: str, v: np.ndarray) -> np.ndarray | None:
    """The half-width of a method's band: its relative estimate per phase × the scale."""
    phases = (per.get("error_estimate") or {}).get("phases")
    if not phases or key not in phases[0]:
        return None
    rel = _array([e.get(key) for e in phases])
    return rel * np.array([moment_scale(key, x) for x in v])


def phase_moments(entries: dict, system: Any, path, *, title: str = "") -> Path:
    """E[x], E[x²], E[y²], E[H] (and P_impact with walls) against phase, every method.

    The E[x] panel adds each method's first harmonic x̄ + A cos(φ − θ) (dotted, A
    and θ in the legend) and the forcing F cos φ on its right axis (grey dashes):
    the lag θ is read between the two.  ``entries``: method → the results.json entry
    (with its ``periodic`` record).
    """
    plt = _pyplot()
    keys = ["E_x", "E_x2", "E_y2", "E_H"] + (["P_impact"] if system.has_barrier else [])
    ncols = 3 if len(keys) > 4 else 2
    fig, axes = plt.subplots(2, ncols, figsize=(4.6 * ncols, 7.0), dpi=110, squeeze=False)
    phi = np.linspace(0.0, TWO_PI, 241)
    for ax, key in zip(axes.flat, keys):
        for i, (method, e) in enumerate(entries.items()):
            per = e.get("periodic")
            if not per or key not in per["moments"]:
                continue
            ph, v = np.asarray(per["phases"], float), _array(per["moments"][key])
            se = per.get("moments_se", {}).get(key)
            color = _series(ax, method, ph, v, None if se is None else _array(se),
                            _estimate_half(per, key, v), i)
            if key == "E_x":
                A, th = per["amplitude"], per["lag"]
                ax.plot(phi, per["mean_x"] + A * np.cos(phi - th), ls=":", lw=1.0,
                        color=color, label=f"{METHOD_NAMES.get(method, method)}: x̄ + A "
                        f"cos(φ − θ), A = {A:.3g}, θ = {th:.3g}")
        if key == "E_x" and system.forcing is not None:
            twin = ax.twinx()
            twin.plot(phi, system.forcing.amplitude * np.cos(phi), color="0.6", ls="--",
                      lw=0.8)
            twin.set_ylabel(r"forcing $F\cos\varphi$ (m/s², dashed)", color="0.45",
                            fontsize=8)
        _phase_axis(ax)
        ax.set_ylabel(_YLABEL.get(key, key))
    handles, labels = axes[0][0].get_legend_handles_labels()
    spare = list(axes.flat)[len(keys):]
    for ax in spare:
        ax.axis("off")
    if spare:                  # the legend where a panel is free, else below them all
        spare[0].legend(handles, labels, loc="center", frameon=False, fontsize=8)
    else:
        fig.legend(handles, labels, loc="outside lower center", ncols=2, frameon=False,
                   fontsize=8)
    fig.suptitle(f"{title}: moments against phase", fontsize=9)
    return _save(fig, path)


def joint_phases(response: Any, gx: np.ndarray, gy: np.ndarray, path, *, method: str = "",
                 title: str = "") -> Path:
    """The joint density p(x, y) of one method at four phases spread over the period
    (0, π/2, π, 3π/2 of the default eight: :func:`~fpk_vibro.app.periodic_records.four_phases`),
    a 2×2 panel on one colour scale from 0, walls drawn."""
    plt = _pyplot()
    idx = four_phases(response.phases)
    fig, axes = plt.subplots(2, 2, figsize=(8.6, 7.4), dpi=110, squeeze=False)
    P = [np.maximum(response.at(i).pdf_joint(gx[None, :], gy[:, None]), 0.0) for i in idx]
    top = max(float(p.max()) for p in P) or 1.0
    levels = np.linspace(0.0, top, 15)
    F = response.system.forcing.amplitude if response.system.forcing is not None else 0.0
    cs = None
    for ax, i, p in zip(axes.flat, idx, P):
        ph = float(response.phases[i])
        cs = ax.contourf(gx, gy, p, levels=levels, cmap="viridis", extend="max")
        _draw_walls(ax, response.system)
        ax.set_xlabel(r"displacement $x$ (m)")
        ax.set_ylabel(r"velocity $y$ (m/s)")
        force = F * math.cos(ph)
        ax.set_title(f"φ = {phase_label(ph)}: forcing F cos φ = "
                     f"{0.0 if abs(force) < 1e-12 * F else force:+.3g}", fontsize=9)
    for ax in list(axes.flat)[len(idx):]:
        ax.set_visible(False)
    fig.colorbar(cs, ax=list(axes.flat), label=r"$p(x, y)$ (s/m²)")
    name = METHOD_NAMES.get(method or response.method, method or response.method)
    fig.suptitle(f"{title}: joint density at four phases, {name}", fontsize=9)
    return _save(fig, path)


def impact_rates(entries: dict, system: Any, path, *, title: str = "") -> Path:
    """Impacts per unit time on each wall against phase, every method (one panel per
    wall)."""
    plt = _pyplot()
    walls = [side for side, _ in system.walls]
    fig, axes = plt.subplots(1, len(walls), figsize=(5.0 * len(walls), 3.8), dpi=110,
                             squeeze=False)
    for ax, side in zip(axes[0], walls):
        for i, (method, e) in enumerate(entries.items()):
            per = e.get("periodic") or {}
            rates = per.get("impact_rates", {}).get(side)
            if rates is None:
                continue
            se = per.get("impact_rates_se", {}).get(side)
            _series(ax, method, np.asarray(per["phases"], float), _array(rates),
                    None if se is None else _array(se), None, i)
        _phase_axis(ax)
        ax.set_ylim(bottom=0.0)
        ax.set_ylabel("impacts per unit time (1/s)")
        ax.set_title(f"{side} wall at x = {getattr(system, side).position:g}", fontsize=9)
        ax.legend(frameon=False, fontsize=7)
    fig.suptitle(f"{title}: impact rate against phase", fontsize=9)
    return _save(fig, path)


#: The response curve's panels: (label, how to read a method's entry: value, SE, estimate).
_CURVES = (
    (r"amplitude $A$ of $E[x](t)$ (m)", "amplitude"),
    (r"lag $\theta$ of $E[x]$ behind the forcing (rad)", "lag"),   # in (−π/2, 3π/2]
    (r"period-averaged $E[x^2]$ (m²)", "E_x2"),
)


def _curve_values(entry: dict, key: str) -> tuple[float, float, float]:
    """(value, standard error, estimate as an absolute half-width) of one entry."""
    per = entry.get("periodic") or {}
    if key == "E_x2":
        v = entry["moments"]["E_x2"]
        se = entry.get("moments_se", {}).get("E_x2", math.nan)
        rel = (entry.get("error_estimate") or {}).get("E_x2")
        return v, se, math.nan if rel is None else rel * abs(v)
    se = (per.get("harmonic_se") or {}).get(key)
    est = (per.get("error_estimate") or {}).get(key)
    v = per[key]
    if key == "lag":           # a lag just below 0 is not one just below 2π
        v = (v + math.pi / 2) % TWO_PI - math.pi / 2
    return (v, math.nan if se is None else se, math.nan if est is None else est)


def response_curve(points: list, path, *, title: str = "") -> Path:
    """The stochastic frequency response: the amplitude A and lag θ of the mean and the
    period-averaged E[x²] against the swept forcing frequency Ω (else the first swept
    parameter), one line per method (Monte Carlo ±1 SE); a second swept parameter
    gives one row of panels per value.  Against Ω the amplitude of the linear
    oscillator without walls or noise, F/√((a − Ω²)² + (cΩ)²), is drawn for reference
    (grey): where the walls bend the resonance."""
    done = [p for p in points if p.get("status") == "done"]
    if not done or not done[0]["parameters"]:
        raise ValueError("response_curve: the run has no finished sweep point")
    params = list(done[0]["parameters"])
    first = "forcing.frequency" if "forcing.frequency" in params else params[0]
    second = next((p for p in params if p != first), None)
    methods = [m for m in done[0]["methods"] if "periodic" in done[0]["methods"][m]]
    groups = sorted({p["parameters"][second] for p in done}) if second else [None]
    fig, axes = _pyplot().subplots(len(groups), len(_CURVES), figsize=(
        4.6 * len(_CURVES), 3.5 * len(groups)), dpi=110, squeeze=False)
    for row, gval in zip(axes, groups):
        sel = sorted((p for p in done if second is None or p["parameters"][second] == gval),
                     key=lambda p: p["parameters"][first])
        xs = np.array([p["parameters"][first] for p in sel])
        for ax, (label, key) in zip(row, _CURVES):
            top = 0.0
            for mi, method in enumerate(methods):
                rec = [p["methods"][method] for p in sel if method in p["methods"]]
                if len(rec) != len(sel):
                    continue
                v, se, est = (np.array(c, dtype=float) for c in
                              zip(*(_curve_values(r, key) for r in rec)))
                top = max(top, float(np.nanmax(v + np.nan_to_num(se))))
                name = METHOD_NAMES.get(method, method)
                if _sampled(method):
                    ax.errorbar(xs, v, yerr=np.nan_to_num(se), fmt="o", ms=3.5, mfc="none",
                                capsize=2, lw=0.8, color="C2", label=name + " (±1 SE)")
                    continue
                style = dict(_STYLE.get(method, {}))
                style.setdefault("color", f"C{mi}")
                line, = ax.plot(xs, v, marker=".", label=name, **style)
                if np.isfinite(est).any():
                    h = np.where(np.isfinite(est), est, 0.0)
                    ax.fill_between(xs, v - h, v + h, color=line.get_color(), alpha=0.2, lw=0)
            if key == "amplitude" and first == "forcing.frequency" and top > 0:
                _linear_reference(ax, sel, xs, top)
            ax.set_xlabel(r"forcing frequency $\Omega$ (rad/s)" if first == "forcing.frequency"
                          else first)
            ax.set_ylabel(label)
            if second is not None:
                ax.set_title(f"{second} = {gval:g}", fontsize=8)
    axes[0][0].legend(frameon=False, fontsize=7)
    fig.suptitle(f"{title}: response curve" if first != "forcing.frequency" else
                 f"{title}: stochastic frequency response", fontsize=9)
    return _save(fig, path)


def _linear_reference(ax, sel: list, xs: np.ndarray, top: float) -> None:
    """F/√((a − Ω²)² + (cΩ)²) of the point's system over the swept Ω, clipped to the
    data (the walls keep the response far below the linear peak)."""
    s = sel[0]["system"]
    F = (s.get("forcing") or {}).get("amplitude")
    if F is None:
        return
    W = np.linspace(xs.min(), xs.max(), 400)
    A = F / np.sqrt((s["a"] - W ** 2) ** 2 + (s["c"] * W) ** 2)
    ax.plot(W, A, color="0.55", lw=0.9, ls="--",
            label="linear, no walls or noise: F/√((a − Ω²)² + (cΩ)²)")
    ax.set_ylim(0.0, 1.4 * top)
