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
    Gb = {sol.system.barrier_energy for _, sol in curves if sol.system.has_barrier}
    for g in sorted(Gb):
        ax.axvline(g, color="0.6", ls=":", lw=1)
        ax.text(g, ax.get_ylim()[1] * 0.97, r" $G(\Delta)$", va="top", fontsize=8, color="0.4")
    ax.set_xlim(0, H_max)
    ax.set_xlabel(r"energy $H = y^2/2 + G(x)$")
    ax.set_ylabel(r"probability density $p(H)$")
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend(frameon=False, fontsize=9)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
