"""Figures of response densities (matplotlib, written to files; no screen needed)."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from .solution import Solution

__all__ = ["plot_energy_pdfs"]


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path) -> Path:
    """Lay out, write atomically (creating the directory) and close a figure."""
    from .io import atomic_write
    fig.tight_layout()
    path = Path(path)
    try:
        atomic_write(path, lambda fh: fig.savefig(fh, format=path.suffix.lstrip(".") or "png"))
    finally:
        _pyplot().close(fig)
    return path


def plot_energy_pdfs(curves: Sequence[tuple[str, Solution]], path: str | Path, *,
                     H_max: float | None = None, points: Sequence[tuple[str, np.ndarray,
                     np.ndarray, np.ndarray | None]] = (), title: str = "") -> Path:
    """p(H) of several solutions as lines (and optional points with error bars).

    Parameters
    ----------
    curves : sequence of (label, Solution)
    path : output file (PNG)
    H_max : upper end of the H axis (default: where the widest density falls to 1e-3 of its peak)
    points : sequence of (label, H, p, p_se or None), e.g. Monte Carlo histograms
    """
    plt = _pyplot()
    if H_max is None:
        H_max = 0.0
        for _, sol in curves:
            H = np.linspace(0.0, 50.0 * max(sol.moments()["E_H"], 1e-12), 4001)
            p = sol.pdf_energy(H)
            H_max = max(H_max, float(H[np.nonzero(p > 1e-3 * p.max())[0][-1]]))
    H = np.linspace(0.0, H_max, 1200)[1:]
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    for label, sol in curves:
        ax.plot(H, sol.pdf_energy(H), lw=1.6, label=label)
    for label, Hp, pp, se in points:
        ax.errorbar(Hp, pp, yerr=se, fmt="o", ms=3.5, mfc="none", capsize=2, label=label)
    marks = {g: label for _, sol in curves for g, label in _wall_energies(sol.system)}
    for g, label in sorted(marks.items()):
        ax.axvline(g, color="0.6", ls=":", lw=1)
        ax.text(g, ax.get_ylim()[1] * 0.97, " " + label, va="top", fontsize=8, color="0.4")
    ax.set_xlim(0, H_max)
    ax.set_xlabel(r"energy $H = y^2/2 + G(x)$")
    ax.set_ylabel(r"probability density $p(H)$")
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend(frameon=False, fontsize=9)
    return _save(fig, path)


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
                    color="0.3", xytext=(3 if side == "left" else -3, -2),
                    textcoords="offset points")


_LABELS = {"energy": (r"energy $H$", r"$p(H)$"), "x": (r"displacement $x$", r"$p(x)$"),
           "y": (r"velocity $y$", r"$p(y)$")}
_STYLE = {"exact": dict(color="k", ls="--", lw=1.2), "averaging": dict(color="C0", lw=1.6),
          "fem": dict(color="C3", lw=1.4)}


def scene_figures(solutions: dict, grids: dict, quantities, out_dir, prefix: str,
                  title: str = "") -> list[Path]:
    """Figures of a scene point: one per 1-D quantity with every method overlaid
    (Monte Carlo as histogram points with ±1 standard-error bars), and the joint
    densities as contour plots side by side.  Returns the files written."""
    plt = _pyplot()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for q in [q for q in quantities if q in _LABELS]:
        fig, ax = plt.subplots(figsize=(6.0, 4.2), dpi=110)
        g = grids[q]
        for method, sol in solutions.items():
            if method == "montecarlo":
                edges, dens, se = sol.histogram(q)
                mid = 0.5 * (edges[1:] + edges[:-1])
                keep = (mid >= g[0]) & (mid <= g[-1])
                ax.errorbar(mid[keep], dens[keep], yerr=se[keep], fmt="o", ms=3, mfc="none",
                            color="C2", capsize=1.5, lw=0.8, label="Monte Carlo (±1 SE)")
            else:
                ax.plot(g, getattr(sol, "pdf_" + q)(g), label=method, **_STYLE.get(method, {}))
        sysm = next(iter(solutions.values())).system
        if q == "energy":
            for gw, label in _wall_energies(sysm):
                if gw < g[-1]:
                    ax.axvline(gw, color="0.6", ls=":", lw=1, label=label)
        if q == "x":
            _draw_walls(ax, sysm)
        xl, yl = _LABELS[q]
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(title, fontsize=9)
        ax.legend(frameon=False, fontsize=8)
        written.append(_save(fig, out_dir / f"{prefix}_{q}.png"))
    if "joint" in quantities:
        gx, gy = grids["joint"]
        n = len(solutions)
        fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.8), dpi=110, squeeze=False)
        for ax, (method, sol) in zip(axes[0], solutions.items()):
            P = sol.pdf_joint(gx[None, :], gy[:, None])
            cs = ax.contourf(gx, gy, P, levels=14, cmap="viridis")
            fig.colorbar(cs, ax=ax, label=r"$p(x, y)$")
            _draw_walls(ax, sol.system)
            ax.set_xlabel(r"displacement $x$")
            ax.set_ylabel(r"velocity $y$")
            ax.set_title(method, fontsize=9)
        fig.suptitle(title, fontsize=9)
        written.append(_save(fig, out_dir / f"{prefix}_joint.png"))
    return written


_NAMES = {"exact": "exact (Gibbs)", "averaging": "stochastic averaging",
          "fem": "finite elements", "montecarlo": "Monte Carlo"}


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
                            capsize=1.5, lw=0.8, label=_NAMES[method] + " (±1 SE)")
                top = max(top, float(edges[-1]))
        u = np.linspace(0.0, top or 3.0 * max(
            v.impacts()[side]["mean_speed"] for m, v in solutions.items()
            if m != "montecarlo"), 400)
        for method, sol in solutions.items():
            if method == "montecarlo":
                continue
            try:
                ax.plot(u, sol.impact_speed_pdf(side, u), label=_NAMES.get(method, method),
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
        ax.plot(fp.times, fp.survival, label=f"{_NAMES.get(method, method)}: "
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
    """A moment against time for each method (Monte Carlo with ±2 SE bars).

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
            ax.errorbar(t, v, yerr=2 * se, fmt="o", ms=4, mfc="none", color="C2", capsize=2,
                        label="Monte Carlo (±2 SE)")
        else:
            ax.plot(t, v, marker=".", label=method, **_STYLE.get(method, {}))
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel("time $t$")
    ax.set_ylabel({"E_H": r"$E[H](t)$", "E_x2": r"$E[x^2](t)$", "E_y2": r"$E[y^2](t)$"}.get(key, key))
    ax.set_title(title, fontsize=9)
    ax.legend(frameon=False, fontsize=8)
    return _save(fig, path)


def work_precision(doc: dict, path) -> Path:
    """Error against wall time, log-log, one line per method/setting family."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.6), dpi=110)
    groups: dict[str, list] = {}
    for r in doc["rows"]:
        label = (r["method"].replace("fem", f"FE Q{r['degree']}") if "degree" in r
                 else r["method"].replace("fem", "FE"))
        groups.setdefault(label, []).append(r)
    for i, (label, rows) in enumerate(groups.items()):
        rows = sorted(rows, key=lambda r: r["seconds"])
        # Monte Carlo settings vary paths, time and dt: points, not a curve
        ax.loglog([r["seconds"] for r in rows], [max(r["error"], 1e-16) for r in rows],
                  marker="os^dv"[i % 5], label=label,
                  ls="none" if label == "montecarlo" else "-")
    est = doc["truth"].get("error_estimate", 0.0)
    if est:
        ax.axhline(est, color="0.5", ls=":", lw=1, label="truth's error estimate")
    for tgt in (1e-2, 1e-3, 1e-4):
        ax.axhline(tgt, color="0.85", lw=0.8, zorder=0)
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("max relative error of E[H], E[x²], E[y²]")
    ax.set_title(f"work–precision (truth: {doc['truth']['source']})", fontsize=9)
    ax.legend(frameon=False, fontsize=8)
    return _save(fig, path)


def averaging_map(doc: dict, path) -> Path:
    """Heat maps of the averaging error over (r, c), one row per noise level:
    the L1 distance of p(H) and |E[H] error| against FE."""
    plt = _pyplot()
    rs, cs, noise = doc["r"], doc["c"], doc.get("noise", [1.0])
    fig, axes = plt.subplots(len(noise), 2, figsize=(10, 4.0 * len(noise)), dpi=110,
                             squeeze=False)
    for row, q in zip(axes, noise):
        grid = {k: np.full((len(cs), len(rs)), np.nan) for k in ("L1_pH", "rel_E_H")}
        for cell in doc["cells"]:
            if "error" in cell or cell.get("noise", 1.0) != q:
                continue
            i, j = cs.index(cell["c"]), rs.index(cell["r"])
            grid["L1_pH"][i, j] = cell["L1_pH"]
            grid["rel_E_H"][i, j] = 100 * abs(cell["rel_E_H"])
        for ax, (key, title) in zip(row, (("L1_pH", "L1 distance of p(H), averaging vs FE"),
                                          ("rel_E_H", "|E[H] error| of averaging (%)"))):
            im = ax.imshow(grid[key], origin="lower", aspect="auto", cmap="magma_r")
            ax.set_xticks(range(len(rs)), [f"{r:g}" for r in rs])
            ax.set_yticks(range(len(cs)), [f"{c:g}" for c in cs])
            ax.set_xlabel("restitution r")
            ax.set_ylabel("damping c")
            ax.set_title(f"{title}, noise ×{q:g}", fontsize=9)
            for (i, j), v in np.ndenumerate(grid[key]):
                if np.isfinite(v):
                    ax.text(j, i, f"{v:.2g}", ha="center", va="center", fontsize=7,
                            color="w" if v > np.nanmax(grid[key]) / 2 else "k")
            fig.colorbar(im, ax=ax)
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
