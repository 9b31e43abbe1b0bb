"""The time-step bias run of ``error_estimate()``, paired: paths at h and at 2h driven
by the same Brownian increments (docs/theory.md, §Monte Carlo).

Each path is simulated twice from one start: at step h with normals z₁, z₂, … and at
step 2h with one normal per pair,

    z_c = (e^{−ch} z₁ + z₂) / sqrt(1 + e^{−2ch}),

the exact coupling of the Ornstein–Uhlenbeck part: over 2h the fine path's noise is
σ_h (e^{−ch} z₁ + z₂) and the coarse one's σ_{2h} z_c, the same increment.  Both are
sampled at the same times, so a batch's difference m_b(h) − m_b(2h) has the noise of
the difference of two coupled paths (of the order of the bias itself), not that of two
independent runs, and the standard error of the bias is that of the batch
differences (:func:`differences`).

:func:`paired_cpu` is the CPU engine's compiled kernel (the scalar step of
:mod:`._kernel`, one block of paths per thread, a fixed order per block, so the result
does not depend on the number of threads); the GPU has its own
(:func:`._cuda_engine.paired_bias`).  Both return the per-batch sums
{"fine": ..., "coarse": ...} (``mom``, ``imp``, ``walls`` [b, side, (n, Σu, Σu², Σ
loss)], ``xext``) that :func:`differences` turns into the bias of each estimate.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._checks import InputError
from . import _setup as S
from ._kernel import CHUNK, _step_full
from ._rng import FASTMATH, _normal
from ._sampling import M_H, M_N, M_PIMP, M_X2, M_Y2, NM, _sample
from ._threads import run_blocks

__all__ = ["paired_cpu", "differences", "stationary_pairs", "MOMENT_COLUMNS"]

#: The judged moments and their columns in ``mom``.
MOMENT_COLUMNS = {"E_H": M_H, "E_x2": M_X2, "E_y2": M_Y2, "P_impact": M_PIMP}


@njit(nogil=True, cache=True, fastmath=FASTMATH)
def _paired_block(b, xs, ys, xcs, ycs, rng, starts, n_steps, sample_every, pf, pc, has_d2, maxk,
                  law, speeds, momf, momc, impf, impc, wf, wc, xef, xec, hH, hx, hy, hj):
    """Block b: ``n_steps`` fine steps (even) and n_steps/2 coarse ones of every path
    of the block from (xs, ys), sampled after fine step k when (k + 1) %
    sample_every == 0 (even; 0: never), from and back to (xs, ys) and (xcs, ycs)."""
    a = pf.a
    bcub = pf.b
    hh = pf.hh
    hh2 = pc.hh
    ec = pf.ec
    cz1 = ec / math.sqrt(1.0 + ec * ec)
    cz2 = 1.0 / math.sqrt(1.0 + ec * ec)
    hu = speeds[b]
    s0 = rng[b, 0]
    s1 = rng[b, 1]
    s2 = rng[b, 2]
    s3 = rng[b, 3]
    xf = np.empty(CHUNK)
    yf = np.empty(CHUNK)
    ff = np.empty(CHUNK)
    xc = np.empty(CHUNK)
    yc = np.empty(CHUNK)
    fc = np.empty(CHUNK)
    wsf = np.zeros((2, 4))
    wsc = np.zeros((2, 4))
    end = starts[b + 1]
    for i0 in range(starts[b], end, CHUNK):
        n = min(CHUNK, end - i0)
        for j in range(n):
            x = xs[i0 + j]
            xf[j] = x
            yf[j] = ys[i0 + j]
            ff[j] = -(a + bcub * x * x) * x
            x = xcs[i0 + j]
            xc[j] = x
            yc[j] = ycs[i0 + j]
            fc[j] = -(a + bcub * x * x) * x
        for k2 in range(n_steps // 2):
            for j in range(n):
                z1, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                z2, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                x = xf[j]
                y = yf[j]
                f = ff[j]
                for z in (z1, z2):
                    x, y, f, nl, nr, ul, ur, ql, qr, el, er, um = _step_full(
                        x, y, f, z, hh, ec, pf.sd0, pf.d1s2, pf.d2s2, a, bcub, pf.lo,
                        pf.hi, pf.f_lo, pf.f_hi, pf.r_left, pf.r_right, has_d2, maxk,
                        pf.lo, pf.hi, hu, 0.0, 0.0, law, None, 0.0, i0 + j)
                    if nl + nr > 0:
                        wsf[0, 0] += nl
                        wsf[1, 0] += nr
                        wsf[0, 1] += ul
                        wsf[1, 1] += ur
                        wsf[0, 2] += ql
                        wsf[1, 2] += qr
                        wsf[0, 3] += el
                        wsf[1, 3] += er
                xf[j] = x
                yf[j] = y
                ff[j] = f
                x, y, f, nl, nr, ul, ur, ql, qr, el, er, um = _step_full(
                    xc[j], yc[j], fc[j], cz1 * z1 + cz2 * z2, hh2, pc.ec, pc.sd0, pc.d1s2,
                    pc.d2s2, a, bcub, pf.lo, pf.hi, pf.f_lo, pf.f_hi, pf.r_left,
                    pf.r_right, has_d2, maxk, pf.lo, pf.hi, hu, 0.0, 0.0, law, None, 0.0,
                    i0 + j)
                if nl + nr > 0:
                    wsc[0, 0] += nl
                    wsc[1, 0] += nr
                    wsc[0, 1] += ul
                    wsc[1, 1] += ur
                    wsc[0, 2] += ql
                    wsc[1, 2] += qr
                    wsc[0, 3] += el
                    wsc[1, 3] += er
                xc[j] = x
                yc[j] = y
                fc[j] = f
            if sample_every > 0 and (2 * k2 + 2) % sample_every == 0:
                _sample(xf, yf, n, 0.0, pf, b, momf, xef, hH, hx, hy, hj)
                _sample(xc, yc, n, 0.0, pf, b, momc, xec, hH, hx, hy, hj)
        for j in range(n):
            xs[i0 + j] = xf[j]
            ys[i0 + j] = yf[j]
            xcs[i0 + j] = xc[j]
            ycs[i0 + j] = yc[j]
    npaths = float(end - starts[b])
    impf[b, 0] += wsf[0, 0] + wsf[1, 0]
    impc[b, 0] += wsc[0, 0] + wsc[1, 0]
    impf[b, 1] += npaths * n_steps
    impc[b, 1] += npaths * (n_steps // 2)
    for s in range(2):
        for c in range(4):
            wf[b, s, c] += wsf[s, c]
            wc[b, s, c] += wsc[s, c]
    rng[b, 0] = s0
    rng[b, 1] = s1
    rng[b, 2] = s2
    rng[b, 3] = s3


def _sums(nb: int) -> dict[str, np.ndarray]:
    return {"mom": np.zeros((nb, NM)), "imp": np.zeros((nb, 2)),
            "walls": np.zeros((nb, 2, 4)), "xext": np.tile([np.inf, -np.inf], (nb, 1))}


def paired_cpu(system, xs: np.ndarray, ys: np.ndarray, dt: float, rng: np.ndarray,
               starts: np.ndarray, n_burn: int, n_sample: int, sample_every: int,
               max_impacts: int = 64, threads: int | None = None, progress=None) -> dict[str, dict[str, np.ndarray]]:
    """Paths at dt and 2 dt from the same states and the same increments (module
    docstring), on the CPU threads: a burn-in of ``n_burn`` fine steps, then
    ``n_sample`` sampled every ``sample_every`` (each rounded up to even).

    Both paths start from (xs, ys) and stay coupled through burn-in and sampling
    (with damping, common noise pulls them together again after an impact has set
    them apart; what is left shows in the spread of the batch differences, the
    standard error reported).

    ``rng`` (uint64[nb, 4]) and ``starts`` as the engine's kernels take them;
    ``progress(fraction)`` after each chunk (Ctrl-C between chunks:
    :class:`KeyboardInterrupt` propagates).  Returns {"fine": sums, "coarse": sums}: ``mom``, ``imp``
    (impacts, path-steps of its own step), ``walls``, ``xext`` per batch.
    """
    n_burn += n_burn % 2
    n_sample += n_sample % 2
    sample_every += sample_every % 2
    nb = rng.shape[0]
    pf, ip = S.step_params(system, dt, max_impacts)
    pc, _ = S.step_params(system, 2.0 * dt, max_impacts)
    law = S.wall_laws(system)
    speeds = np.zeros((nb, 2, 0))
    e1, e3 = np.zeros((nb, 0)), np.zeros((nb, 0, 0))
    xs, ys = np.array(xs, dtype=float), np.array(ys, dtype=float)
    xcs, ycs = xs.copy(), ys.copy()
    fine, coarse = _sums(nb), _sums(nb)
    scratch = [_sums(nb), _sums(nb)]
    total = n_burn + n_sample
    chunk = max(2, S.CHUNK_PATH_STEPS // max(xs.size, 1))
    chunk = max(sample_every, chunk // sample_every * sample_every)
    done = 0
    for n_all, every, (f, c) in ((n_burn, 0, scratch), (n_sample, sample_every,
                                                         (fine, coarse))):
        k = 0
        while k < n_all:
            m = min(chunk, n_all - k)
            run_blocks(_paired_block, nb, (xs, ys, xcs, ycs, rng, starts, m, every, pf, pc,
                                           bool(ip.has_d2), int(ip.max_impacts), law,
                                           speeds, f["mom"], c["mom"], f["imp"], c["imp"],
                                           f["walls"], c["walls"], f["xext"], c["xext"],
                                           e1, e1, e1, e3), threads)
            k += m
            done += m
            if progress is not None:
                progress(done / max(total, 1))
    return {"fine": fine, "coarse": coarse}


def _diff_ratio(nf: np.ndarray, df: np.ndarray, nc: np.ndarray, dc: np.ndarray
                ) -> tuple[float, float, float]:
    """Σnf/Σdf − Σnc/Σdc over batches, its standard error from the batch spread
    (linearised: residual per batch (nf − R_f df)/Σdf − (nc − R_c dc)/Σdc), and the
    fine estimate R_f."""
    Df, Dc = float(df.sum()), float(dc.sum())
    if Df <= 0 or Dc <= 0:
        return math.nan, math.nan, math.nan
    Rf, Rc = float(nf.sum()) / Df, float(nc.sum()) / Dc
    res = (nf - Rf * df) / Df - (nc - Rc * dc) / Dc
    B = res.size
    se = math.sqrt(B / (B - 1) * float(np.sum(res * res))) if B > 1 else math.nan
    return Rf - Rc, se, Rf


def differences(system, fine: dict, coarse: dict, dt_fine: float,
                keys=("E_H", "E_x2", "E_y2", "P_impact"), inter_impact: bool = False
                ) -> dict[str, tuple[float, float]]:
    """m(fine) − m(coarse) and its standard error per figure, from the batch sums of a
    paired run: the judged moments (``keys``), ``mean_impact_energy_<side>`` (each wall
    that removes energy) and, with ``inter_impact``, ``mean_inter_impact_time`` (path
    time per impact: the inter-impact estimator's bias is that of 1/rate)."""
    out: dict[str, tuple[float, float]] = {}
    mf, mc = fine["mom"], coarse["mom"]
    for k in keys:
        if k == "P_impact" and not system.walls:
            continue
        col = MOMENT_COLUMNS[k]
        d, se, _ = _diff_ratio(mf[:, col], mf[:, M_N], mc[:, col], mc[:, M_N])
        out[k] = (d, se)
    for side, wall in system.walls:
        s = 0 if side == "left" else 1
        if wall.elastic:
            continue
        wf, wc = fine["walls"], coarse["walls"]
        d, se, _ = _diff_ratio(wf[:, s, 3], wf[:, s, 0], wc[:, s, 3], wc[:, s, 0])
        out[f"mean_impact_energy_{side}"] = (d, se)
    if inter_impact:
        tf = fine["imp"][:, 1] * dt_fine
        tc = coarse["imp"][:, 1] * 2.0 * dt_fine
        out["mean_inter_impact_time"] = _diff_ratio(tf, fine["imp"][:, 0], tc,
                                                    coarse["imp"][:, 0])[:2]
    return out


def _coarse_allowed(system, dt: float) -> bool:
    """Whether 2 dt is a step the engine takes: within the stability limit and within
    ``COARSE`` × each time scale's default step (:meth:`.options.Options.validate_for`)."""
    from .options import COARSE
    if 2.0 * dt > S.dt_limit(system):
        return False
    return all(2.0 * dt <= COARSE * allowed for name, (_, allowed)
               in S.step_bounds(system).items() if name != "period")


def stationary_pairs(sol, device: str = "cpu"):
    """The paired bias run of a stationary :class:`MonteCarloSolution`: the same paths,
    burn-in, sampled time, sampling interval and batches at (dt, 2 dt), or at (dt/2,
    dt) where 2 dt is refused or its paths blow up; on ``device`` ("cpu" or "cuda").

    Returns
    -------
    (dict, str)
        Per figure ``(m(dt) − m(other), its SE)`` (:func:`differences`) and "2 dt" or
        "dt/2".
    """
    system, dt = sol.system, float(sol.dt)
    if system.external is not None:
        raise InputError("MonteCarloSolution.error_estimate: paired=True is for white "
                         "external noise (the twins share the noise of y, which coloured "
                         "noise moves to ζ); use error_estimate() (its bias run at 2 dt)",
                         where="MonteCarloSolution.error_estimate", name="paired")
    nb, n_paths = int(sol.n_batches), int(sol.n_paths)
    every = max(1, int(sol.sample_every))
    inter = "inter_impact" in sol.quantities
    entropy = sol.seed_entropy
    if device != "cpu":
        from ._device import available
        device = "cuda" if available()[0] else "cpu"
    steps = (("2 dt", dt),) if _coarse_allowed(system, dt) else ()
    steps += (("dt/2", 0.5 * dt),)
    prog = S.Progress(getattr(sol, "_progress", False), "stationary")
    last = None
    for label, h in steps:
        f = 1 if label == "2 dt" else 2         # fine steps per step of the run estimated
        ss = np.random.SeedSequence(entropy, spawn_key=(0x5a17,))
        children = ss.spawn(nb + 1)
        gen = np.random.default_rng(children[nb])
        xs = np.full(n_paths, S.initial_x(system))
        ys = math.sqrt(S.energy_scale(system)) * gen.standard_normal(n_paths)
        n_burn = f * math.ceil(sol.t_burn / dt - 1e-9)
        n_sample = f * max(1, round(sol.t_sample / dt))
        tag = f"bias run at {label}, paired"
        try:
            if device == "cuda":
                from . import _cuda_engine
                from ._cuda_rng import seed_of
                prog.update(0.0, tag)
                out = _cuda_engine.paired_bias(system, xs, ys, h, seed_of(children[0]), nb,
                                               n_burn, n_sample, f * every)
            else:
                out = paired_cpu(system, xs, ys, h, S.rng_states(children[:nb]),
                                 S.block_starts(n_paths, nb), n_burn, n_sample, f * every,
                                 progress=lambda g: prog.update(g, tag))
        except KeyboardInterrupt:
            prog.close()
            raise
        d = differences(system, out["fine"], out["coarse"], h, inter_impact=inter)
        if all(math.isfinite(v) for v, _ in d.values()) or label == "dt/2":
            last = (d, label)
            if all(math.isfinite(v) for v, _ in d.values()):
                break
    prog.close()
    d, label = last
    if label == "dt/2":                          # the pair is (dt/2, dt): m(dt) − m(dt/2)
        d = {k: (-v, e) for k, (v, e) in d.items()}
    return d, label
