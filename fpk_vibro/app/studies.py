"""Studies: what accuracy costs in time, and where the averaging assumptions hold.

``fpk-vibro study convergence SCENE`` — error against the best available truth
versus wall time for every method setting (work–precision).  Truth: the exact Gibbs
density where it exists (r = 1 or no barrier, D2 = 0), else the finest FE solution
(Q2) with its error estimated from the two finest levels, cross-checked with Monte
Carlo.  The error measure is the largest relative error of E[H], E[x²], E[y²].

For a transient scene (``[study] times``, ``[initial]``) the error is the largest
relative error of those moments over the scene's times, and the truth is the finest FE
transient (Q2, tight time tolerance), its error estimated from two levels.

``fpk-vibro study averaging SCENE`` — the averaging error (L1 distance of p(H),
relative errors of the moments and of the mean first-passage time from rest to
H_c = 3 E[H], FE as truth) over a grid of r and c.
"""
from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..model import VibroImpactSystem
from ..io import atomic_write_text
from .scenes import Scene

__all__ = ["convergence_study", "transient_convergence_study", "averaging_study",
           "cost_of_accuracy"]

KEYS = ("E_H", "E_x2", "E_y2")
#: The averaging study's first-passage level, in units of the FE E[H].
FIRST_PASSAGE_LEVEL = 3.0


def _err(m: dict[str, float], truth: dict[str, float]) -> float:
    return max(abs(m[k] / truth[k] - 1) for k in KEYS)


def _timed(f: Callable[[], Any]) -> tuple[Any, float]:
    t0 = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t0


def _add_row(rows: list, log, widths: tuple[int, int], method: str, setting: str,
             error: float, seconds: float, judged: list, **extra: Any) -> None:
    """One work–precision row, logged; with ``judged`` (the answer's solutions, one per
    time of a transient) the answer's own estimate, its largest over them and
    :data:`KEYS`, and the effectivity (true error / estimate) beside it."""
    row = {"method": method, "setting": setting, "error": error, "seconds": seconds, **extra}
    note = ""
    if judged:
        e = max(float(s.error_estimate()[k]) for s in judged for k in KEYS)
        row.update(estimate=e, effectivity=error / e if e > 0 else None)
        note = f"  estimate {e:.2e}"
    rows.append(row)
    log(f"  {method:<{widths[0]}s} {setting:<{widths[1]}s} error {error:.2e}{note}  "
        f"{seconds:7.2f} s")


def _truth(system: VibroImpactSystem, quick: bool, log) -> dict[str, Any]:
    from .. import exact, fem
    try:
        m = exact.gibbs(system).moments()
        return {"source": "exact Gibbs", "moments": m, "error_estimate": 0.0}
    except ValueError:
        pass
    levels = (24, 48) if quick else (64, 128)
    sols = [fem.stationary(system, degree=2, nx=n, positivity=False).moments() for n in levels]
    est = _err(sols[0], sols[1]) / 3.0            # order 2: e_fine ≈ |fine − coarse|/3
    log(f"  truth: FE Q2 nx={levels[1]} (error estimate {est:.1e})")
    return {"source": f"FE Q2 nx={levels[1]}", "moments": sols[1], "error_estimate": est}


def convergence_study(scene: Scene, *, quick: bool = False, log=print) -> dict[str, Any]:
    """Work–precision table of every method of the scene's (first) system, with each
    answer's own error estimate beside its true error (``effectivity`` = true /
    estimate; ≤ 1 where the estimate is honest)."""
    from .. import averaging, fem, montecarlo
    if scene.mode == "transient":
        return transient_convergence_study(scene, quick=quick, log=log)
    system = scene.points()[0][1]
    truth = _truth(system, quick, log)
    T = truth["moments"]
    rows: list[dict[str, Any]] = []

    def add(method: str, setting: str, moments: dict[str, float], seconds: float,
            sol: Any = None, **extra):
        _add_row(rows, log, (11, 26), method, setting, _err(moments, T), seconds,
                 [sol] if sol is not None else [], **extra)

    methods = [m for m in scene.methods if m != "exact"]
    if "fem" in methods:
        fem.stationary(system, nx=8)          # warm-up: imports and caches are not the cost
        q1 = (16, 32, 64) if quick else (16, 32, 64, 128, 256)
        q2 = (8, 16) if quick else (8, 16, 32, 64)
        for label, kw, degree, levels in (("fem (default)", {}, 1, q1),
                                          ("fem (Galerkin)", {"positivity": False}, 1, q1),
                                          ("fem (positive)", {"positivity": True}, 1, q1),
                                          ("fem (Galerkin)", {"positivity": False}, 2, q2)):
            for nx in levels:
                sol, dt = _timed(lambda: fem.stationary(system, degree=degree, nx=nx, **kw))
                add(label, f"Q{degree} nx={nx} ({sol.dofs.size} dofs)", sol.moments(), dt,
                    sol=sol, degree=degree, nx=nx, min_density=sol.min_density / sol.dofs.max(),
                    discretisation=sol.info.get("discretisation", ""))
    if "montecarlo" in methods:
        montecarlo.stationary(system, n_paths=64, t_sample=10.0, seed=0, progress=False)

        def mc(label: str, **kw) -> None:
            sol, dt = _timed(lambda: montecarlo.stationary(
                system, seed=1, quantities=("energy",), progress=False, **kw))
            add("montecarlo", f"{label} (dt={sol.dt:.3g})", sol.moments(), dt, sol=sol,
                se=_err({k: sol.moments()[k] + sol.moments_se()[k] for k in KEYS}, sol.moments()))
        # sampled time (paths × time) at the default dt ...
        for rse in ((1e-2, 3e-3) if quick else (1e-2, 3e-3, 1e-3, 3e-4)):
            mc(f"target SE {rse:g}", target_rse=rse)
        # ... the number of paths at a fixed sampled time per path ...
        for n in ((256, 1024) if quick else (256, 1024, 4096)):
            mc(f"{n} paths, t_sample 400", n_paths=n, t_sample=400.0)
        # ... and the time step (its bias), at a fixed target SE
        dt0 = montecarlo.stationary(system, n_paths=64, t_sample=10.0, seed=0, progress=False).dt
        for f in ((2.0, 0.5) if quick else (4.0, 2.0, 0.5)):
            mc(f"dt × {f:g}, target SE {3e-3 if quick else 1e-3:g}", dt=f * dt0,
               target_rse=3e-3 if quick else 1e-3)
    if "averaging" in methods:
        ref = averaging.stationary(system, n_theta=96, n_panel=48).moments()
        for nt, npan in ((6, 4), (8, 6), (12, 8), (24, 16), (48, 24)):
            sol, dt = _timed(lambda: averaging.stationary(system, n_theta=nt, n_panel=npan))
            add("averaging", f"n_theta={nt} n_panel={npan}", sol.moments(), dt, sol=sol)
            # its own convergence: against the finest quadrature, not the truth
            rows.append({"method": "averaging (quadrature)", "setting": rows[-1]["setting"],
                         "error": _err(sol.moments(), ref), "seconds": dt})
    return {"system": system.to_dict(), "truth": truth, "rows": rows,
            "cost": cost_of_accuracy(rows)}


def _moments_over_time(sols) -> dict[str, np.ndarray]:
    return {k: np.array([s.moments()[k] for s in sols]) for k in KEYS}


def _err_t(m: dict[str, np.ndarray], truth: dict[str, np.ndarray]) -> float:
    return max(float(np.max(np.abs(m[k] / truth[k] - 1))) for k in KEYS)


def transient_convergence_study(scene: Scene, *, quick: bool = False, log=print
                                ) -> dict[str, Any]:
    """Work–precision of the transient methods from the scene's initial density.

    Error: the largest relative error of E[H], E[x²], E[y²] over the scene's times.
    Truth: FE Q2 with a tight time tolerance at two meshes, the finer one the truth and
    a third of their difference its error estimate (second order in space).  Beside
    it, each method's own estimate (the largest over the times) and the effectivity
    (true / estimate): for the FE default's rows (quick: its finest), averaging at
    its default cells and every Monte Carlo row.
    """
    from .. import averaging, fem, montecarlo
    system = scene.points()[0][1]
    init, times = scene.initial, list(scene.times)

    def fe(**kw):
        return fem.transient(system, initial=init, times=times, progress=False, **kw)

    levels = (32, 48) if quick else (64, 96)
    fine = [_moments_over_time(fe(degree=2, nx=n, tol=1e-5)) for n in levels]
    est = _err_t(fine[0], fine[1]) / 3.0
    T = fine[1]
    log(f"  truth: FE Q2 nx={levels[1]}, tol=1e-5 (error estimate {est:.1e})")
    rows: list[dict[str, Any]] = []

    def add(method: str, setting: str, sols: list, seconds: float, estimate: bool = False,
            **extra):
        _add_row(rows, log, (15, 28), method, setting,
                 _err_t(_moments_over_time(sols), T), seconds, sols if estimate else [],
                 **extra)

    methods = [m for m in scene.methods if m != "exact"]
    if "fem" in methods:
        fe(nx=8, degree=1)                # warm-up: imports and caches are not the cost
        grid = ((("fem (default, Q2)", {}, (16, 24, 32)),
                 ("fem (Q1)", {"degree": 1}, (32, 64)),
                 ("fem (Q2, tol 1e-3)", {"tol": 1e-3}, (24,)))
                if quick else
                (("fem (default, Q2)", {}, (24, 32, 48, 64)),
                 ("fem (Q1)", {"degree": 1}, (48, 96, 128)),
                 ("fem (Q2, tol 1e-3)", {"tol": 1e-3}, (32, 48)),
                 ("fem (Q2, tol 1e-4)", {"tol": 1e-4}, (48,))))
        for label, kw, nxs in grid:
            for nx in nxs:
                sols, dt = _timed(lambda: fe(nx=nx, **kw))
                # the default's estimate (one richer transient each: quick, the finest)
                add(label, f"nx={nx} ({sols[0].dofs.size} dofs)", sols, dt,
                    estimate=not kw and (not quick or nx == nxs[-1]),
                    steps=sols[-1].info.get("steps"))
    if "averaging" in methods:
        cells = (100, 400) if quick else (100, 200, 400, 800)
        for n in cells:
            sols, dt = _timed(lambda: averaging.transient(system, initial=init, times=times,
                                                          n_cells=n))
            # its model error (an FE transient at rtol 1e-2): once, at the default cells
            add("averaging", f"n_cells={n}", sols, dt, estimate=n == 400)
    if "montecarlo" in methods:
        for n in ((1024, 4096) if quick else (1024, 4096, 16384)):
            sols, dt = _timed(lambda: montecarlo.transient(
                system, initial=init, times=times, n_paths=n, seed=1,
                quantities=("energy",), progress=False))
            se = max(float(np.max(np.abs(np.array([s.moments_se()[k] for s in sols])
                                          / T[k]))) for k in KEYS)
            add("montecarlo", f"{n} paths", sols, dt, estimate=True, se=se)
    return {"system": system.to_dict(), "times": times,
            "truth": {"source": f"FE Q2 nx={levels[1]} tol=1e-5", "error_estimate": est,
                      "moments": {k: v.tolist() for k, v in T.items()}},
            "rows": rows, "cost": cost_of_accuracy(rows)}


def cost_of_accuracy(rows: list[dict[str, Any]], targets=(1e-2, 1e-3, 1e-4)) -> dict[str, Any]:
    """Fastest setting of each method reaching each relative-error target (None: not reached).

    For Monte Carlo the criterion is max(error, 2 standard errors) ≤ target.
    """
    out: dict[str, Any] = {}
    for method in sorted({r["method"] for r in rows}):
        mine = [r for r in rows if r["method"] == method]
        out[method] = {}
        for tgt in targets:
            # a Monte Carlo error is random: it counts as reached when 2 SE reach it too
            ok = [r for r in mine if max(r["error"], 2 * r.get("se", 0.0)) <= tgt]
            best = min(ok, key=lambda r: r["seconds"]) if ok else None
            out[method][f"{tgt:g}"] = None if best is None else {
                "seconds": best["seconds"], "setting": best["setting"]}
    return out


def averaging_study(scene: Scene, *, quick: bool = False, log=print) -> dict[str, Any]:
    """Averaging error against FE over a grid of r, c and the noise level.

    The noise level multiplies both D1 and D2 of the scene's system (×1, ×4).
    """
    from .. import averaging, fem
    base = scene.points()[0][1]
    rs = (1.0, 0.8, 0.5, 0.2) if quick else (1.0, 0.98, 0.92, 0.8, 0.6, 0.4, 0.2, 0.05)
    cs = (0.025, 0.1) if quick else (0.01, 0.025, 0.05, 0.1, 0.2)
    noise = (1.0,) if quick else (1.0, 4.0)
    nx = 32 if quick else 64
    cells = []
    for q, c, r in ((q, c, r) for q in noise for c in cs for r in rs):
        s = base.replace(r=r, c=c, D1=q * base.D1, D2=q * base.D2)
        try:
            a = averaging.stationary(s)
        except ValueError as exc:
            cells.append({"r": r, "c": c, "noise": q, "error": str(exc)})
            continue
        f = fem.stationary(s, degree=2, nx=nx)
        ma, mf = a.moments(), f.moments()
        H = np.linspace(0.0, 12 * mf["E_H"], 2401)
        l1 = float(np.trapezoid(np.abs(a.pdf_energy(H) - f.pdf_energy(H)), H))
        est = a.error_estimate(reference=f)         # the model error beside the measured
        cell = {"r": r, "c": c, "noise": q, "L1_pH": l1,
                **{f"rel_{k}": ma[k] / mf[k] - 1 for k in KEYS},
                **{f"est_{k}": est[k] for k in KEYS if k in est},
                "weakest": a.validity()["weakest"]}
        # reliability: mean first-passage time from rest to H_c = 3 E[H] (FE truth)
        Hc = FIRST_PASSAGE_LEVEL * mf["E_H"]
        tf = fem.first_passage(s, energy=Hc, nx=nx // 2).mean
        ta = averaging.first_passage(s, energy=Hc).mean
        cell.update(H_c=Hc, tau_fem=tf, tau_averaging=ta, rel_tau=ta / tf - 1)
        cells.append(cell)
        log(f"  noise×{q:<3g} c={c:<6g} r={r:<5g} L1 p(H) {l1:.3f}  E[H] {cell['rel_E_H']:+.3%}"
            f" (estimated {cell['est_E_H']:.2%})  τ {cell['rel_tau']:+.3%}")
    return {"system": base.to_dict(), "r": list(rs), "c": list(cs), "noise": list(noise),
            "cells": cells}


def write_study(kind: str, doc: dict[str, Any], out: Path) -> list[Path]:
    """results JSON and the plot of a study; returns the files written."""
    from . import study_plots as plotting
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / f"{kind}.json", json.dumps(doc, indent=1, default=float))
    if kind == "convergence":
        return [out / f"{kind}.json", plotting.work_precision(doc, out / "work_precision.png")]
    return [out / f"{kind}.json", plotting.averaging_map(doc, out / "averaging_error.png")]


def markdown_table(doc: dict[str, Any]) -> str:
    """The convergence table and the cost of 1 % / 0.1 % / 0.01 % as Markdown."""
    lines = [f"Truth: {doc['truth']['source']}.", "",
             "| method | setting | max rel. error (E[H], E[x²], E[y²]) | its estimate | "
             "true / estimate | MC std. error | seconds |",
             "|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        se = f"{r['se']:.1e}" if "se" in r else ""
        est = f"{r['estimate']:.1e}" if "estimate" in r else ""
        eff = f"{r['effectivity']:.2f}" if r.get("effectivity") is not None else ""
        lines.append(f"| {r['method']} | {r['setting']} | {r['error']:.2e} | {est} | {eff} | "
                     f"{se} | {r['seconds']:.3f} |")
    lines += ["", "Cost of an accuracy (fastest setting reaching it; Monte Carlo: error and 2 SE):", "",
              "| method | 1 % | 0.1 % | 0.01 % |", "|---|---|---|---|"]
    for method, costs in doc["cost"].items():
        cells = [("—" if v is None else f"{v['seconds']:.3g} s ({v['setting']})")
                 for v in costs.values()]
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def averaging_table(doc: dict[str, Any], key: str = "rel_E_H") -> str:
    """The averaging study as Markdown: the relative error ``key`` (%) of averaging
    against FE ("rel_E_H"; "rel_tau": mean first-passage time) per (noise, c) row and
    r column."""
    rs = doc["r"]
    lines = ["| noise | c | " + " | ".join(f"r = {r:g}" for r in rs) + " |",
             "|---|---|" + "---|" * len(rs)]
    for q in doc.get("noise", [1.0]):
        for c in doc["c"]:
            cells = []
            for r in rs:
                cell = next(x for x in doc["cells"] if x["r"] == r and x["c"] == c
                            and x.get("noise", 1.0) == q)
                cells.append("error" if "error" in cell else f"{100 * cell[key]:+.2f} %")
            lines.append(f"| ×{q:g} | {c:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)

