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

#: How figures name the built-in methods (another registered method: by its name).
METHOD_NAMES = {"exact": "exact (Gibbs)", "averaging": "stochastic averaging",
                "fem": "finite elements", "montecarlo": "Monte Carlo"}


def _sampled(method: str) -> bool:
    """True for a method whose results are samples (drawn as histograms ± SE)."""
    from ..registry import methods
    m = methods().get(method)
    return bool(m is not None and m.sampled)


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
        its peak); the axis starts at the lowest energy on the strips (0, or the
        bottom of a double well's wells).
    points : sequence of (label, H, p, p_se or None), e.g. Monte Carlo histograms
    ax : matplotlib.axes.Axes, optional
        Draw here (a notebook's axes) and return it.

    Returns
    -------
    Path or matplotlib.axes.Axes
        The file written, or the axes drawn into.
    """
    from ..scales import potential_min
    H_min = min((potential_min(sol.system) for _, sol in curves), default=0.0)
    if H_max is None:
        H_max = H_min
        for _, sol in curves:
            H = np.linspace(H_min, H_min + 50.0 * max(sol.moments()["E_H"] - H_min, 1e-12),
                            4001)
            p = sol.pdf_energy(H)
            H_max = max(H_max, float(H[np.nonzero(p > 1e-3 * p.max())[0][-1]]))
    H = np.linspace(H_min, H_max, 1200)[1:]
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
    ax.set_xlim(H_min, H_max)
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
        ax.annotate(f"r = {w.r:g}" if w.law is None else "r(u)", (w.position, 1.0), xycoords=("data", "axes fraction"),
                    ha="left" if side == "left" else "right", va="top", fontsize=7,
                    color="0.2", xytext=(3 if side == "left" else -3, -2),
                    textcoords="offset points",
                    bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1})


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
        if _sampled(method):
            edges, dens, se = sol.histogram(quantity)
            mid = 0.5 * (edges[1:] + edges[:-1])
            keep = (mid >= grid[0]) & (mid <= grid[-1]) & (dens > 0 if log else True)
            base = getattr(ref, pdf)(mid[keep]) if ref is not None else 0.0
            bias = _estimated(sol, "bias")
            yerr = se[keep] + bias * dens[keep]
            ax.errorbar(mid[keep], dens[keep] - base, yerr=yerr, fmt="o", ms=2.5,
                        mfc="none", color="C2", capsize=1.2, lw=0.7,
                        label=name + (" (±1 SE + bias)" if bias else " (±1 SE)"))
        elif method != difference_from or ref is None:
            base = getattr(ref, pdf)(grid) if ref is not None else 0.0
            dens = getattr(sol, pdf)(grid)
            vals = dens - base
            if log:
                vals = np.where(vals > 0, vals, np.nan)
            line, = ax.plot(grid, vals, label=name, **_STYLE.get(method, {}))
            err = _estimated(sol, "error")
            if err > 0 and np.isfinite(err):       # the estimate as a relative band
                ax.fill_between(grid, vals - err * dens, vals + err * dens, lw=0,
                                color=line.get_color(), alpha=0.2,
                                label=f"{name}: estimated error {err:.1g}")
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


def _estimated(sol: Solution, what: str) -> float:
    """From an error estimate already made (figures never compute one): ``"error"``
    the largest relative moment figure, ``"bias"`` Monte Carlo's largest relative
    time-step bias; 0 where there is none."""
    est = getattr(sol, "_estimate", None)
    if not isinstance(est, dict):
        return 0.0
    if what == "bias":
        bias = est.get("bias")
        return max((abs(v) for v in bias.values()), default=0.0) if isinstance(bias, dict) \
            else 0.0
    from ..keys import JUDGED
    vals = [float(est[k]) for k in JUDGED if k in est]
    return max(vals, default=0.0)


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
