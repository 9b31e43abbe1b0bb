"""Figures of response densities (matplotlib).

Nothing here touches pyplot or the matplotlib backend: figures are bare
``matplotlib.figure.Figure`` objects written to files, and the public ``plot_*``
functions draw into an ``ax`` the caller gives (a notebook's, say) or a new one, and
return it.  Conventions: methods named in words; Monte Carlo as points with ±1
standard-error bars everywhere; axis labels with units; walls drawn where they are.
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..solution import Solution

__all__ = ["plot_energy_pdfs", "plot_density", "plot_joint", "METHOD_NAMES"]

#: How figures name the methods.
METHOD_NAMES = {"exact": "exact (Gibbs)", "averaging": "stochastic averaging",
                "fem": "finite elements", "montecarlo": "Monte Carlo"}


class _Figures:
    """``subplots`` like pyplot's, on a bare Figure: no backend is chosen or changed."""

    @staticmethod
    def subplots(*args, figsize=None, dpi=None, **kw):
        from matplotlib.figure import Figure
        fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
        return fig, fig.subplots(*args, **kw)


def _pyplot():
    return _Figures


def _save(fig, path) -> Path:
    """Lay out, write atomically (creating the directory) and close a figure."""
    from ..io import atomic_write
    path = Path(path)
    atomic_write(path, lambda fh: fig.savefig(fh, format=path.suffix.lstrip(".") or "png"))
    return path


def plot_energy_pdfs(curves: Sequence[tuple[str, Solution]], path: str | Path | None = None,
                     *, H_max: float | None = None, points: Sequence[tuple[str, np.ndarray,
                     np.ndarray, np.ndarray | None]] = (), title: str = "", ax=None):
    """p(H) of several solutions as lines (and optional points with ±1 SE bars).

    Parameters
    ----------
    curves : sequence of (label, Solution)
    path : str or Path, optional
        Output file (PNG); returned when given (and ``ax`` is not).
    H_max : float, optional
        Upper end of the H axis (default: where the widest density falls to 1e-3 of
        its peak).
    points : sequence of (label, H, p, p_se or None), e.g. Monte Carlo histograms
    ax : matplotlib.axes.Axes, optional
        Draw here (a notebook's axes) and return it.

    Returns
    -------
    Path or matplotlib.axes.Axes
        The file written, or the axes drawn into.
    """
    if H_max is None:
        H_max = 0.0
        for _, sol in curves:
            H = np.linspace(0.0, 50.0 * max(sol.moments()["E_H"], 1e-12), 4001)
            p = sol.pdf_energy(H)
            H_max = max(H_max, float(H[np.nonzero(p > 1e-3 * p.max())[0][-1]]))
    H = np.linspace(0.0, H_max, 1200)[1:]
    given = ax is not None
    if not given:
        fig, ax = _Figures.subplots(figsize=(6.4, 4.4), dpi=120)
    for label, sol in curves:
        ax.plot(H, sol.pdf_energy(H), lw=1.6, label=label)
    for label, Hp, pp, se in points:
        ax.errorbar(Hp, pp, yerr=se, fmt="o", ms=3.5, mfc="none", capsize=2, label=label)
    marks = {g: label for _, sol in curves for g, label in _wall_energies(sol.system)}
    for g, label in sorted(marks.items()):
        ax.axvline(g, color="0.6", ls=":", lw=1)
        ax.text(g, ax.get_ylim()[1] * 0.97, " " + label, va="top", fontsize=8, color="0.4")
    ax.set_xlim(0, H_max)
    ax.set_xlabel(r"energy $H = y^2/2 + G(x)$ (J/kg)")
    ax.set_ylabel(r"probability density $p(H)$ (kg/J)")
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend(frameon=False, fontsize=9)
    if given or path is None:
        return ax
    return _save(ax.figure, path)


def _wall_energies(system) -> list[tuple[float, str]]:
    """(G(x_w), label) of each wall; one label for walls at ±Δ."""
    if system.symmetric and system.has_barrier:
        return [(float(system.potential(system.right.position)), r"$G(\Delta)$")]
    return [(float(system.potential(w.position)), rf"$G(x_{side[0].upper()})$")
            for side, w in system.walls]


def _draw_walls(ax, system) -> None:
    """Each wall as a thick grey line at its position, labelled with its r."""
    for side, w in system.walls:
        ax.axvline(w.position, color="0.35", lw=2.2, zorder=5)
        ax.annotate(f"r = {w.r:g}", (w.position, 1.0), xycoords=("data", "axes fraction"),
                    ha="left" if side == "left" else "right", va="top", fontsize=7,
                    color="0.2", xytext=(3 if side == "left" else -3, -2),
                    textcoords="offset points",
                    bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1})


_LABELS = {"energy": (r"energy $H$", r"$p(H)$"), "x": (r"displacement $x$", r"$p(x)$"),
           "y": (r"velocity $y$", r"$p(y)$")}
_STYLE = {"exact": dict(color="k", ls="--", lw=1.2), "averaging": dict(color="C0", lw=1.6),
          "fem": dict(color="C3", lw=1.4)}


_UNITS = {"energy": (r"energy $H$ (J/kg)", r"$p(H)$ (kg/J)"),
          "x": (r"displacement $x$ (m)", r"$p(x)$ (1/m)"),
          "y": (r"velocity $y$ (m/s)", r"$p(y)$ (s/m)")}


def _reference(solutions: dict) -> str:
    """The method others are compared with: the exact density, else FE, else the first."""
    for m in ("exact", "fem"):
        if m in solutions:
            return m
    return next(iter(solutions))


def plot_density(solutions: dict, quantity: str, grid: np.ndarray, *, ax=None,
                 log: bool = False, difference_from: str | None = None):
    """One marginal density of several methods on ``ax`` (created if None).

    Parameters
    ----------
    solutions : dict
        method name → Solution (Monte Carlo drawn as its histogram, ±1 SE).
    quantity : {"energy", "x", "y"}
    grid : ndarray
        Where the curves are evaluated.
    log : bool
        Logarithmic density axis (tails).
    difference_from : str, optional
        Draw each method minus this method's density instead of the densities.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        _, ax = _Figures.subplots(figsize=(6.0, 4.2), dpi=110)
    ref = solutions.get(difference_from) if difference_from else None
    pdf = "pdf_" + quantity
    for method, sol in solutions.items():
        name = METHOD_NAMES.get(method, method)
        if method == "montecarlo":
            edges, dens, se = sol.histogram(quantity)
            mid = 0.5 * (edges[1:] + edges[:-1])
            keep = (mid >= grid[0]) & (mid <= grid[-1]) & (dens > 0 if log else True)
            base = getattr(ref, pdf)(mid[keep]) if ref is not None else 0.0
            ax.errorbar(mid[keep], dens[keep] - base, yerr=se[keep], fmt="o", ms=2.5,
                        mfc="none", color="C2", capsize=1.2, lw=0.7, label=name + " (±1 SE)")
        elif method != difference_from or ref is None:
            base = getattr(ref, pdf)(grid) if ref is not None else 0.0
            vals = getattr(sol, pdf)(grid) - base
            if log:
                vals = np.where(vals > 0, vals, np.nan)
            ax.plot(grid, vals, label=name, **_STYLE.get(method, {}))
    if ref is not None:
        ax.axhline(0.0, color="0.3", lw=0.8)
    if log:
        ax.set_yscale("log")
    system = next(iter(solutions.values())).system
    if quantity == "energy":
        for gw, label in _wall_energies(system):
            if gw < grid[-1]:
                ax.axvline(gw, color="0.6", ls=":", lw=1)
                ax.annotate(label, (gw, 1.0), xycoords=("data", "axes fraction"), va="top",
                            fontsize=7, color="0.4", xytext=(2, -2), textcoords="offset points")
    if quantity == "x":
        _draw_walls(ax, system)
    xl, yl = _UNITS[quantity]
    ax.set_xlabel(xl)
    ax.set_ylabel(yl if ref is None else f"difference from {METHOD_NAMES.get(difference_from, difference_from)}")
    return ax


def plot_joint(solutions: dict, gx: np.ndarray, gy: np.ndarray, *, axes=None, vmax=None):
    """p(x, y) of each method on one shared colour scale from 0, walls drawn; returns
    the axes (one per method, created if None) and the contour set of the last."""
    if axes is None:
        _, ax_row = _Figures.subplots(1, len(solutions), figsize=(4.2 * len(solutions), 3.8),
                                      dpi=110, squeeze=False)
        axes = ax_row[0]
    P = {m: np.maximum(s.pdf_joint(gx[None, :], gy[:, None]), 0.0) for m, s in solutions.items()}
    top = vmax or max(float(p.max()) for p in P.values())
    levels = np.linspace(0.0, top, 15)
    cs = None
    for ax, (method, p) in zip(axes, P.items()):
        cs = ax.contourf(gx, gy, p, levels=levels, cmap="viridis", extend="max")
        _draw_walls(ax, solutions[method].system)
        ax.set_xlabel(r"displacement $x$ (m)")
        ax.set_ylabel(r"velocity $y$ (m/s)")
        ax.set_title(METHOD_NAMES.get(method, method), fontsize=9)
    return axes, cs


def scene_figures(solutions: dict, grids: dict, quantities, out_dir, prefix: str,
                  title: str = "") -> list[Path]:
    """Figures of a scene point, written to files; returns them.

    Per 1-D quantity three panels: every method on a linear axis, on a logarithmic
    axis (the tails, where averaging and FE part) and the difference from the
    reference method (exact, else FE).  The joint densities side by side on one
    colour scale from 0, with the difference maps from the reference.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    ref = _reference(solutions)
    compare = len(solutions) > 1
    for q in [q for q in quantities if q in _UNITS]:
        n = 3 if compare else 2
        fig, axes = _Figures.subplots(1, n, figsize=(5.0 * n, 3.9), dpi=110)
        g = grids[q]
        plot_density(solutions, q, g, ax=axes[0])
        plot_density(solutions, q, g, ax=axes[1], log=True)
        axes[1].set_title("logarithmic density axis", fontsize=8)
        if compare:
            plot_density(solutions, q, g, ax=axes[2], difference_from=ref)
        axes[0].legend(frameon=False, fontsize=7)
        fig.suptitle(title, fontsize=9)
        written.append(_save(fig, out_dir / f"{prefix}_{q}.png"))
    if "joint" in quantities:
        gx, gy = grids["joint"]
        n = len(solutions)
        others = [m for m in solutions if m != ref] if compare else []
        fig, axes = _Figures.subplots(1 + bool(others), n, figsize=(4.2 * n, 3.8 * (1 + bool(others))),
                                      dpi=110, squeeze=False)
        _, cs = plot_joint(solutions, gx, gy, axes=axes[0])
        fig.colorbar(cs, ax=list(axes[0]), label=r"$p(x, y)$ (s/m²)")
        if others:
            P0 = solutions[ref].pdf_joint(gx[None, :], gy[:, None])
            D = {m: solutions[m].pdf_joint(gx[None, :], gy[:, None]) - P0 for m in others}
            lim = max(float(np.abs(d).max()) for d in D.values()) or 1.0
            for ax, (m, d) in zip(axes[1], D.items()):
                im = ax.contourf(gx, gy, d, levels=np.linspace(-lim, lim, 17), cmap="RdBu_r")
                _draw_walls(ax, solutions[m].system)
                ax.set_title(f"{METHOD_NAMES.get(m, m)} − {METHOD_NAMES.get(ref, ref)}", fontsize=9)
                ax.set_xlabel(r"displacement $x$ (m)")
                ax.set_ylabel(r"velocity $y$ (m/s)")
            for ax in axes[1][len(D):]:
                ax.set_visible(False)
            fig.colorbar(im, ax=list(axes[1]), label="difference of $p(x, y)$")
        fig.suptitle(title, fontsize=9)
        written.append(_save(fig, out_dir / f"{prefix}_joint.png"))
    return written


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
                            capsize=1.5, lw=0.8, label=METHOD_NAMES[method] + " (±1 SE)")
                top = max(top, float(edges[-1]))
        u = np.linspace(0.0, top or 3.0 * max(
            v.impacts()[side]["mean_speed"] for m, v in solutions.items()
            if m != "montecarlo"), 400)
        for method, sol in solutions.items():
            if method == "montecarlo":
                continue
            try:
                ax.plot(u, sol.impact_speed_pdf(side, u), label=METHOD_NAMES.get(method, method),
                        **_STYLE.get(method, {}))
            except NotImplementedError:
                pass
        ax.set_xlabel(r"impact speed $u$ (m/s)")
        ax.set_ylabel(r"probability density $f(u)$ (s/m)")
        ax.set_title(f"{side} wall, r = {getattr(system, side).r:g}", fontsize=9)
        ax.legend(frameon=False, fontsize=8)
    fig.suptitle(title, fontsize=9)
    return _save(fig, path)


def reliability(passages: dict, path, *, title: str = "") -> Path:
    """R(t) = P(T > t) of each method (Monte Carlo with its 95 % band)."""
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
    ax.set_title(f"{title}: first passage of H = {fp0.energy:g}", fontsize=9)
    ax.legend(frameon=False, fontsize=8)
    return _save(fig, path)


def moment_history(entries: dict, path, *, key: str = "E_H", title: str = "") -> Path:
    """A moment against time for each method (Monte Carlo with ±1 SE bars).

    ``entries``: method → {"times": [...], "at": [{"moments": {...}, "moments_se": {...}}]}
    as written in results.json.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.2), dpi=110)
    for method, e in entries.items():
        t = np.asarray(e["times"], dtype=float)
        v = np.array([a["moments"][key] for a in e["at"]])
        if method == "montecarlo":
            se = np.array([a["moments_se"][key] for a in e["at"]])
            ax.errorbar(t, v, yerr=se, fmt="o", ms=4, mfc="none", color="C2", capsize=2,
                        label="Monte Carlo (±1 SE)")
        else:
            ax.plot(t, v, marker=".", label=method, **_STYLE.get(method, {}))
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
            if method == "montecarlo":
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


def sweep_moments(points: list, path, *, keys=("E_H", "E_x2", "E_y2"), title: str = "") -> Path:
    """Moments against the (first) swept parameter, one line per method (Monte Carlo
    ±1 SE); a two-parameter sweep is faceted: one row of panels per value of the
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
                if method == "montecarlo":
                    se = np.array([r.get("moments_se", {}).get(key, np.nan) for r in rec])
                    ax.errorbar(xs, ys, yerr=se, fmt="o", ms=3, mfc="none", capsize=2, lw=0.8,
                                color="C2", label=name + " (±1 SE)")
                else:
                    style = dict(_STYLE.get(method, {}))
                    style.setdefault("color", f"C{mi}")
                    ax.plot(xs, ys, marker=".", label=name, **style)
            ax.set_xlabel(first)
            ax.set_ylabel({"E_H": r"$E[H]$ (J/kg)", "E_x2": r"$E[x^2]$ (m²)",
                           "E_y2": r"$E[y^2]$ (m²/s²)"}.get(key, key))
            if second is not None:
                ax.set_title(f"{second} = {gval:g}", fontsize=8)
    axes[0][0].legend(frameon=False, fontsize=7)
    fig.suptitle(title, fontsize=9)
    return _save(fig, path)
