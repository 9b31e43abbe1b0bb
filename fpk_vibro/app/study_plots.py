"""Figures of the studies (``fpk-vibro study``): work–precision and the averaging map."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .plotting import _pyplot, _save

__all__ = ["work_precision", "averaging_map"]


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
