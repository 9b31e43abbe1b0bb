"""Figures of the quantities "spectra" and "crossings", drawn from the records of
:mod:`fpk_vibro.app.spectral_records` (what results.json holds):

- :func:`spectra`: S(ω) per method on a log axis, one panel per signal, in the
  scene's units and sides; Monte Carlo with its ±2 SE band, the others with the band
  of their error estimate where it was made; each method's peak frequency in the legend;
- :func:`crossings`: ν⁺(b) against b per method, the walls as vertical lines with the
  energy G(x_w) above which a path reaches each, and each method's impact rate on a
  wall as a point on that line (ν⁺(wall) = impact rate); beside it the rate of peaks
  above b;
- :func:`rice`: the Rice estimate exp(−(ν⁺(x_hi) + ν⁻(x_lo)) t) of each method beside
  the true reliability R(t) of the first passage out of the band;
- :func:`sweep_peak_frequency`: the peak frequency against the swept parameter.

The conventions of :mod:`fpk_vibro.app.plotting` hold (bare figures, methods in words,
Monte Carlo in green with its standard errors).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .plotting import _STYLE, METHOD_NAMES, _Figures, _sampled, _save

__all__ = ["spectra", "crossings", "rice", "sweep_peak_frequency"]

_SIGNAL = {"x": ("x", "m"), "y": ("y", "m/s")}


def _name(method: str) -> str:
    return METHOD_NAMES.get(method, method)


def _style(method: str, k: int) -> dict[str, Any]:
    style = dict(_STYLE.get(method, {}))
    style.setdefault("color", "C2" if _sampled(method) else f"C{(k + 4) % 10}")
    return style


def _curve(rec: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(frequency, density, se) of a spectrum record, as the scene asked them."""
    src = rec.get("requested") or rec
    freq = np.asarray(src.get("frequency", src.get("omega")), dtype=float)
    se = src.get("se")
    return (freq, np.asarray(src["density"], dtype=float),
            None if se is None else np.asarray(se, dtype=float))


def _axis_labels(of: str, units: str, sided: str) -> tuple[str, str]:
    sym, unit = _SIGNAL[of]
    f = r"frequency $f$ (Hz)" if units == "Hz" else r"angular frequency $\omega$ (rad/s)"
    per = "Hz" if units == "Hz" else "(rad/s)"
    name = "G" if sided == "one" else "S"
    arg = "f" if units == "Hz" else r"\omega"
    side = "one-sided" if sided == "one" else "two-sided"
    return f, rf"${name}_{{{sym}{sym}}}({arg})$ ({unit}²/{per}, {side})"


def spectra(entries: dict, spec: dict[str, Any], path, *, title: str = "") -> Path:
    """S(ω) of every method (module docstring); ``spec`` is the scene's resolved
    ``[spectra]`` table."""
    signals = list(spec["of"])
    fig, axes = _Figures.subplots(1, len(signals), figsize=(6.0 * len(signals), 4.2),
                                  dpi=110, squeeze=False)
    scale = (2.0 if spec["sided"] == "one" else 1.0) * (
        2 * np.pi if spec["units"] == "Hz" else 1.0)
    to_freq = 1 / (2 * np.pi) if spec["units"] == "Hz" else 1.0
    order = sorted(entries.items(), key=lambda me: not _sampled(me[0]))   # samples below
    for ax, of in zip(axes[0], signals):
        for k, (method, entry) in enumerate(order):
            rec = (entry.get("spectra") or {}).get(of) or {}
            if "density" not in rec:
                continue
            f, d, se = _curve(rec)
            style = _style(method, k)
            label = f"{_name(method)}: peak at {rec['peak_frequency'] * to_freq:.4g}"
            positive = d > 0
            if se is not None:
                lo = np.maximum(d - 2 * se, d / 20)
                ax.fill_between(f, lo, d + 2 * se, color=style["color"], alpha=0.25, lw=0)
                label += ", ±2 SE"
            else:
                err = (rec.get("error_estimate") or {}).get("density")
                if isinstance(err, list) and len(err) == d.size:
                    e = scale * np.asarray([np.nan if v is None else v for v in err])
                    ax.fill_between(f, np.maximum(d - e, d / 20), d + e,
                                    color=style["color"], alpha=0.2, lw=0)
                    label += ", ± estimate"
            ax.plot(f[positive], d[positive], label=label, **style)
        ax.set_yscale("log")
        xl, yl = _axis_labels(of, spec["units"], spec["sided"])
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.legend(frameon=False, fontsize=7)
    fig.suptitle(f"{title}: power spectral density", fontsize=9)
    return _save(fig, path)


def _walls(ax, system: Any) -> None:
    for side, wall in system.walls:
        G = float(system.potential(wall.position))
        ax.axvline(wall.position, color="0.3", lw=1.0, ls="-",
                   label=f"{side} wall x = {wall.position:g}: G(x_w) = {G:.4g} J/kg "
                   "(impact energy threshold)")


def crossings(entries: dict, system: Any, path, *, title: str = "") -> Path:
    """ν⁺(b) and the rate of peaks above b (module docstring)."""
    fig, axes = _Figures.subplots(1, 2, figsize=(11.0, 4.2), dpi=110, squeeze=False)
    ax_up, ax_pk = axes[0]
    for k, (method, entry) in enumerate(sorted(entries.items(),
                                               key=lambda me: not _sampled(me[0]))):
        rec = entry.get("crossings") or {}
        if "levels" not in rec:
            continue
        b = np.asarray(rec["levels"], dtype=float)
        style = _style(method, k)
        for ax, key in ((ax_up, "upcrossing_rate"), (ax_pk, "peak_rate")):
            y = np.asarray([np.nan if v is None else v for v in rec[key]], dtype=float)
            se = rec.get(f"{key}_se")
            counted = rec.get("counted") or {}
            if key in counted:          # Monte Carlo's counted rates, ±1 SE
                ax.errorbar(b, counted[key], yerr=counted.get(f"{key}_se"), fmt="o",
                            ms=3, mfc="none", capsize=1.5, lw=0.8, color=style["color"],
                            label=f"{_name(method)} (counted, ±1 SE)")
            if se is not None:
                ax.errorbar(b, y, yerr=se, fmt=".", ms=3, capsize=1.5, lw=0.8,
                            color=style["color"], label=f"{_name(method)} (±1 SE)")
            else:
                ax.plot(b, y, label=_name(method), **style)
        walls = [w for w in (rec.get("walls") or {}).values()
                 if w.get("impact_rate") is not None]
        if walls:
            se = [w.get("impact_rate_se", 0.0) for w in walls]
            ax_up.errorbar([w["position"] for w in walls], [w["impact_rate"] for w in walls],
                           yerr=se if any(se) else None, fmt="D", ms=5, mfc="none",
                           color=style["color"], label=f"{_name(method)}: impact rates")
    _walls(ax_up, system)
    ax_up.set_ylabel(r"upcrossing rate $\nu^+(b)$ (1/s)")
    ax_pk.set_ylabel(r"rate of peaks above $b$ (1/s)")
    for ax in (ax_up, ax_pk):
        ax.set_xlabel(r"level $b$ (m)")
        ax.set_ylim(bottom=0.0)
        ax.legend(frameon=False, fontsize=6)
    fig.suptitle(f"{title}: level crossings (at a wall ν⁺ = the impact rate)", fontsize=9)
    return _save(fig, path)


def rice(entries: dict, passages: dict, path, *, title: str = "") -> Path:
    """Rice estimates beside the true reliability (module docstring); ``passages``:
    method → its FirstPassage out of the band."""
    fig, ax = _Figures.subplots(figsize=(6.2, 4.2), dpi=110)
    band = None
    for k, (method, entry) in enumerate(entries.items()):
        r = (entry.get("crossings") or {}).get("rice") or {}
        if "estimate" not in r:
            continue
        band = r["band"]
        style = _style(method, k)
        fp = passages.get(method)
        if fp is not None:
            if fp.survival_band is not None:
                ax.fill_between(fp.times, *fp.survival_band, color=style["color"],
                                alpha=0.25, lw=0)
            ax.plot(fp.times, fp.survival, label=f"{_name(method)}: true R(t), τ = "
                    f"{fp.mean:.4g}", **style)
        t_end = max([float(r["times"][-1])] + ([float(fp.times[-1])] if fp is not None else []))
        t = np.linspace(0.0, t_end, 200)
        ax.plot(t, np.exp(-r["rate"] * t), color=style["color"], ls=":", lw=1.4,
                label=f"{_name(method)}: Rice exp(−ν t), ν = {r['rate']:.4g}")
        ax.plot(r["times"], r["estimate"], "x", ms=4, color=style["color"])
    ax.set_xlabel("time $t$ (s)")
    ax.set_ylabel(r"reliability $R(t) = P(T > t)$")
    where = "" if band is None else f" out of {band[0]:g} < x < {band[1]:g}"
    ax.set_title(f"{title}: first passage{where} from the stationary state", fontsize=9)
    ax.set_ylim(0.0, 1.02)
    ax.legend(frameon=False, fontsize=7)
    return _save(fig, path)


def sweep_peak_frequency(points: list, path, *, title: str = "",
                         units: str = "rad/s") -> Path:
    """The peak frequency of each method's spectrum against the (first) swept
    parameter, one panel per signal (a second parameter: one line per value)."""
    from .run_plots import _swept_label
    done = [p for p in points if p.get("status") == "done"]
    params = list(done[0]["parameters"]) if done else []
    if not params:
        raise ValueError("sweep_peak_frequency: the run has no swept parameter")
    first, second = params[0], (params[1] if len(params) > 1 else None)
    signals = sorted({of for p in done for e in p["methods"].values()
                      for of, r in (e.get("spectra") or {}).items() if "density" in r})
    fig, axes = _Figures.subplots(1, max(len(signals), 1), figsize=(5.2 * max(len(signals), 1),
                                  3.8), dpi=110, squeeze=False)
    to_freq = 1 / (2 * np.pi) if units == "Hz" else 1.0
    groups = sorted({p["parameters"][second] for p in done}) if second else [None]
    for ax, of in zip(axes[0], signals):
        for k, method in enumerate(done[0]["methods"]):
            for g, gval in enumerate(groups):
                sel = sorted((p for p in done if second is None
                              or p["parameters"][second] == gval),
                             key=lambda p: p["parameters"][first])
                xs, ys, se = [], [], []
                for p in sel:
                    r = (p["methods"].get(method, {}).get("spectra") or {}).get(of) or {}
                    if r.get("peak_frequency") is not None:
                        xs.append(p["parameters"][first])
                        ys.append(r["peak_frequency"] * to_freq)
                        se.append((r.get("peak_frequency_se") or 0.0) * to_freq)
                if not xs:
                    continue
                style = {k2: v for k2, v in _style(method, k).items() if k2 != "ls"}
                label = _name(method) + ("" if gval is None else f", {second} = {gval:g}")
                if any(se):
                    ax.errorbar(xs, ys, yerr=se, fmt="o", ms=4, mfc="none", capsize=2,
                                ls=["-", "--", ":", "-."][g % 4], label=label + " (±1 SE)",
                                **style)
                else:
                    ax.plot(xs, ys, marker=".", ls=["-", "--", ":", "-."][g % 4],
                            label=label, **style)
        ax.set_xlabel(_swept_label(first))
        ax.set_ylabel("peak frequency " + ("$f$ (Hz)" if units == "Hz" else
                                           r"$\omega$ (rad/s)") + f" of $S_{{{of}{of}}}$")
        ax.legend(frameon=False, fontsize=7)
    fig.suptitle(f"{title}: where the spectrum peaks", fontsize=9)
    return _save(fig, path)
