"""The per-block sums of a Monte Carlo run reduced to a :class:`MonteCarloSolution`:
ratio estimates and their standard errors between blocks (batches)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..model import VibroImpactSystem
from ._flight import LEFT, NX, RIGHT, W_N, W_Q, W_U, X_E, X_G0, X_GL, X_GR, X_TL, X_TR
from ._histograms import Histograms
from ._params import kick_gain
from ._sampling import (M_H, M_N, M_OVH, M_OVJ, M_OVX, M_OVY, M_PIMP, M_X, M_X2, M_X4,
                        M_Y2, M_Y4, M_Z2, M_ZY)
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


def _wall_statistics(system: VibroImpactSystem, wimp: np.ndarray, extra: np.ndarray,
                     time: np.ndarray) -> dict[str, dict[str, float]]:
    """Per wall: impacts, rate, mean and mean-square speed before impact, energy
    removed per unit time and per impact, each with its standard error between
    batches.

    ``wimp[b, side]`` holds batch b's count, Σu and Σu², ``extra[b, side]`` its Σ of
    the energy each impact removed, ½ (1 − r(u)²) u² (:mod:`._flight`); ``time`` the path-time each batch simulated.
    """
    out = {}
    for side, _ in system.walls:
        s = LEFT if side == "left" else RIGHT
        n, su, sq = (wimp[:, s, c] for c in (W_N, W_U, W_Q))
        se_ = extra[:, s, X_E]
        d = {"count": int(n.sum())}
        for key, num, den in (("rate", n, time), ("mean_speed", su, n),
                              ("mean_square_speed", sq, n), ("energy_rate", se_, time),
                              ("mean_energy", se_, n)):
            est, se = _ratio(num, den)
            d[key], d[f"{key}_se"] = float(est), float(se)
        out[side] = d
    return out


def _inter_impact(system: VibroImpactSystem, hist: Histograms, wimp: np.ndarray,
                  extra: np.ndarray, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """The time between successive impacts of a path, from the gap before each impact
    sampled (its start may lie before the sampling, in the burn-in).

    Every impact of the sampled window is one gap of the stationary impact process,
    taken at its end: by stationarity its law is the Palm law of the gaps, with no
    length bias and no censoring by the window's end (a gap is complete once its
    impact is seen).  Only impacts with no earlier impact since the path started
    (``unseen``: a path not yet hit in the burn-in) have no gap; they are left out,
    a bias of at most that fraction.  Mean and density are ratio estimates over the
    batches; per wall pair (previous wall → this wall) the count, the fraction of all
    gaps and the mean.
    """
    lr = ("left", "right")
    n = extra[:, :, [X_GL, X_GR]].sum(axis=(1, 2))
    tot = extra[:, :, [X_TL, X_TR]].sum(axis=(1, 2))
    mean, mean_se = _ratio(tot, n)
    impacts = wimp[:, :, W_N].sum()
    out: dict[str, Any] = {"count": int(n.sum()), "mean": float(mean),
                           "mean_se": float(mean_se),
                           "unseen": float(extra[:, :, X_G0].sum() / impacts) if impacts
                           else 0.0, "pairs": {}}
    for a, (cn, ct) in zip(lr, ((X_GL, X_TL), (X_GR, X_TR))):
        for b_, side in zip(lr, (LEFT, RIGHT)):
            if a not in dict(system.walls) or b_ not in dict(system.walls):
                continue
            cnt, sm = extra[:, side, cn], extra[:, side, ct]
            m, m_se = _ratio(sm, cnt)
            f, f_se = _ratio(cnt, n)
            out["pairs"][f"{a}->{b_}"] = {
                "count": int(cnt.sum()), "fraction": float(f), "fraction_se": float(f_se),
                "mean": float(m), "mean_se": float(m_se)}
    if "edges_g" in hist.edges:
        edges = hist.edges["edges_g"]
        d, se = _ratio(hist.hg[:, 0, :-1] / np.diff(edges), n)
        arrays["density_g"] = np.nan_to_num(d, nan=0.0)
        arrays["se_g"] = se
        out["overflow"] = float(hist.hg[:, 0, -1].sum() / n.sum()) if n.sum() else 0.0
    return out


def _impact_energies(system: VibroImpactSystem, hist: Histograms, wimp: np.ndarray,
                     arrays: dict[str, np.ndarray]) -> dict[str, float]:
    """Each wall's density of the energy one impact removes, with its standard error
    between batches (into ``arrays``); the fraction beyond the last bin per wall."""
    overflow = {}
    for side, _ in system.walls:
        s = LEFT if side == "left" else RIGHT
        edges = hist.edges[f"edges_e_{side}"]
        n_b = wimp[:, s, W_N]
        d, se = _ratio(hist.he[:, s, :-1] / np.diff(edges), n_b)
        arrays[f"density_e_{side}"] = np.nan_to_num(d, nan=0.0)
        arrays[f"se_e_{side}"] = se
        total = n_b.sum()
        overflow[f"impact_energy_{side}"] = float(hist.he[:, s, -1].sum() / total) \
            if total else 0.0
    return overflow


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
            wimp: np.ndarray, extra: np.ndarray | None = None) -> MonteCarloSolution:
    """The solution of a run's per-block sums; ``extra`` (``[b, side, X_*]``,
    :mod:`._flight`) holds each wall's Σ of the impact losses (and the gaps); an
    engine without it (None) gets ½ (1 − r²) Σu² for a constant r, NaN for a law."""
    if extra is None:
        extra = np.zeros(wimp.shape[:2] + (NX,))
        for side, wall in system.walls:
            s = LEFT if side == "left" else RIGHT
            const = wall.law is None or wall.law.constant is not None
            extra[:, s, X_E] = wall.loss(1.0) * wimp[:, s, W_Q] if const else np.nan
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
    if "impact_energy" in meta["quantities"]:
        overflow_u |= _impact_energies(system, hist, wimp, arrays)
    gaps = _inter_impact(system, hist, wimp, extra, arrays) \
        if "inter_impact" in meta["quantities"] else None
    rate, rate_se = _ratio(imp[:, 0], imp[:, 1] * dt)
    mean_x, mean_x_se = _ratio(mom[:, M_X], n_b)
    total = float(n_b.sum())
    meta = dict(meta)
    meta.update(
        impact_rate=float(rate), impact_rate_se=float(rate_se), n_samples=int(total),
        impacts=_wall_statistics(system, wimp, extra, imp[:, 1] * dt),
        mean_x=float(mean_x), mean_x_se=float(mean_x_se),
        overflow={q: float(mom[:, c].sum() / total) if total else 0.0
                  for q, c in (("energy", M_OVH), ("x", M_OVX), ("y", M_OVY),
                               ("joint", M_OVJ)) if q in meta["quantities"]} | overflow_u,
        x_seen=[float(xext[:, 0].min()), float(xext[:, 1].max())],
        scheme=SCHEME, dt=float(dt))
    if system.external is not None:
        # E[ζ²], and E[ζ y] (the power the coloured force puts in) as κ E[ζ_k y_k]: the
        # force the kicks apply is κ ζ (:func:`._params.kick_gain`)
        est, se = _ratio(mom[:, [M_Z2, M_ZY]], n_b)
        kz = kick_gain(dt, system.external.tau)
        meta["coloured"] = {"E_zeta2": float(est[0]), "E_zeta2_se": float(se[0]),
                            "E_zeta_y": float(kz * est[1]), "E_zeta_y_se": float(kz * se[1])}
    if gaps is not None:
        if "overflow" in gaps:
            meta["overflow"]["inter_impact"] = gaps.pop("overflow")
        meta["inter_impact"] = gaps
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
