"""The per-block sums of a Monte Carlo run reduced to a :class:`MonteCarloSolution`:
ratio estimates and their standard errors between blocks (batches)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..model import VibroImpactSystem
from ._flight import LEFT, RIGHT, W_N, W_Q, W_U
from ._histograms import Histograms
from ._sampling import (M_H, M_N, M_OVH, M_OVJ, M_OVX, M_OVY, M_PIMP, M_X, M_X2, M_X4,
                        M_Y2, M_Y4)
from .solution import MonteCarloSolution

SCHEME = "BAOAB splitting, impacts located exactly in the free-flight sub-steps"


def _ratio(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ratio estimate Σ num_b / Σ den_b over batches b, and its standard error."""
    tot = den.sum()
    shape = (-1,) + (1,) * (num.ndim - 1)
    if tot <= 0:
        nan = np.full(num.shape[1:], np.nan)
        return nan, nan.copy()
    est = num.sum(axis=0) / tot
    B = den.size
    if B < 2:
        return est, np.full_like(est, np.nan)
    w = (den / tot).reshape(shape)
    with np.errstate(invalid="ignore", divide="ignore"):
        dev = np.where(w > 0, num / np.where(den > 0, den, 1.0).reshape(shape) - est, 0.0)
    se = np.sqrt(B / (B - 1) * np.sum((w * dev) ** 2, axis=0))
    return est, se


def _wall_statistics(system: VibroImpactSystem, wimp: np.ndarray, time: np.ndarray
                     ) -> dict[str, dict[str, float]]:
    """Per wall: impacts, rate, mean and mean-square speed before impact and energy
    removed per unit time, each with its standard error between batches.

    ``wimp[b, side]`` holds batch b's count, Σu and Σu² (:mod:`._flight`), ``time``
    the path-time each batch simulated.
    """
    out = {}
    for side, wall in system.walls:
        # the loss of an impact is ∝ u²: Σ loss(u) = loss(1) Σ u²
        n, su, sq = (wimp[:, LEFT if side == "left" else RIGHT, c]
                     for c in (W_N, W_U, W_Q))
        d = {"count": int(n.sum())}
        for key, num, den in (("rate", n, time), ("mean_speed", su, n),
                              ("mean_square_speed", sq, n),
                              ("energy_rate", wall.loss(1.0) * sq, time)):
            est, se = _ratio(num, den)
            d[key], d[f"{key}_se"] = float(est), float(se)
        out[side] = d
    return out


def _impact_speeds(system: VibroImpactSystem, hist: Histograms, wimp: np.ndarray,
                   arrays: dict[str, np.ndarray]) -> dict[str, float]:
    """Each wall's impact-speed density and its standard error between batches (into
    ``arrays``); returns the fraction of impacts beyond the last bin per wall."""
    overflow = {}
    for side, _ in system.walls:
        s = LEFT if side == "left" else RIGHT
        edges = hist.edges[f"edges_u_{side}"]
        n_b = wimp[:, s, W_N]
        d, se = _ratio(hist.hu[:, s, :-1] / np.diff(edges), n_b)
        arrays[f"density_u_{side}"] = np.nan_to_num(d, nan=0.0)   # never hit: 0 ± NaN
        arrays[f"se_u_{side}"] = se
        total = n_b.sum()
        overflow[f"impacts_{side}"] = float(hist.hu[:, s, -1].sum() / total) if total else 0.0
    return overflow


def _reduce(system: VibroImpactSystem, hist: Histograms, mom: np.ndarray,
            imp: np.ndarray, xext: np.ndarray, dt: float, meta: dict[str, Any],
            wimp: np.ndarray) -> MonteCarloSolution:
    n_b = mom[:, M_N]
    arrays: dict[str, np.ndarray] = dict(hist.edges)
    cols = [M_H, M_X2, M_Y2, M_X4, M_Y4, M_PIMP]
    est, se = _ratio(mom[:, cols], n_b)
    arrays["moments"], arrays["moments_se"] = est, se
    for q, counts, keys in (("energy", hist.hH, ("edges_H",)), ("x", hist.hx, ("edges_x",)),
                            ("y", hist.hy, ("edges_y",)),
                            ("joint", hist.hj, ("edges_jx", "edges_jy"))):
        if q not in meta["quantities"]:
            continue
        if len(keys) == 1:
            vol = np.diff(hist.edges[keys[0]])
        else:
            vol = np.outer(np.diff(hist.edges[keys[0]]), np.diff(hist.edges[keys[1]]))
        d, s = _ratio(counts / vol, n_b)
        arrays[f"density_{q}"], arrays[f"se_{q}"] = d, s
    overflow_u = _impact_speeds(system, hist, wimp, arrays) \
        if "impacts" in meta["quantities"] else {}
    rate, rate_se = _ratio(imp[:, 0], imp[:, 1] * dt)
    mean_x, mean_x_se = _ratio(mom[:, M_X], n_b)
    total = float(n_b.sum())
    meta = dict(meta)
    meta.update(
        impact_rate=float(rate), impact_rate_se=float(rate_se), n_samples=int(total),
        impacts=_wall_statistics(system, wimp, imp[:, 1] * dt),
        mean_x=float(mean_x), mean_x_se=float(mean_x_se),
        overflow={q: float(mom[:, c].sum() / total) if total else 0.0
                  for q, c in (("energy", M_OVH), ("x", M_OVX), ("y", M_OVY),
                               ("joint", M_OVJ)) if q in meta["quantities"]} | overflow_u,
        x_seen=[float(xext[:, 0].min()), float(xext[:, 1].max())],
        scheme=SCHEME, dt=float(dt))
    return MonteCarloSolution(system, meta, arrays)


def _check_finite(mode: str, mom: np.ndarray, xs: np.ndarray, ys: np.ndarray, dt: float,
                  sample_every: int) -> None:
    """Raise, naming the cause, where a moment would be NaN: no sample, or a path
    whose state is no longer finite."""
    where = f"montecarlo.{mode}"
    if mom[:, M_N].sum() == 0:
        raise RuntimeError(f"{where}: no sample was taken (the sampled time is shorter than "
                           f"one sampling interval sample_every*dt = {sample_every * dt:.3g}"
                           " s): give a longer t_sample or a smaller sample_every")
    bad = ~(np.isfinite(xs) & np.isfinite(ys))
    if bad.any() or not np.all(np.isfinite(mom)):
        raise FloatingPointError(
            f"{where}: {int(bad.sum())} of {xs.size} paths left every bound (a non-finite "
            f"state) at dt = {dt:.3g} s: the step is too coarse for this system's fastest "
            "time scale (give a smaller dt)")
