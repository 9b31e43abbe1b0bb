"""Power spectral density and correlation of the stationary response by Monte Carlo:
:func:`spectrum` (docs/theory.md, §Spectra and crossings).

Paths start and burn in as :func:`~fpk_vibro.montecarlo.stationary`'s (6 relaxation
times 6/λ by default), then are sampled every Δ (an even number of steps) and
streamed into Welch averages (:mod:`._welch`): Hann-windowed segments of T = N Δ,
overlapping by half, transformed by ``scipy.fft``, their |X|² averaged over segments
and paths.  The batches of paths (independent streams) give a standard error at
every frequency.

- **Convention.**  S(ω) is two-sided in rad/s, ∫_{−∞}^{∞} S dω = Var q
  (:mod:`fpk_vibro.spectrum`).  The Welch grid is ω_j = 2π j/T up to the Nyquist
  frequency π/Δ; S at the requested ω is the cubic spline through the grid values
  (its error is ~(2π/(T w))⁴ of a peak of width w: nil beside the window's own), the
  standard error interpolated linearly.
- **x** is sampled at points; its aliasing is S_xx beyond π/Δ folded back, ~ω⁻⁴
  (Δ defaults to π/(4 max(ω_max, ω0)): the band ends at a quarter of the Nyquist
  frequency).  **y** is taken as the mean velocity over each interval, (x_{k+1} − x_k)/Δ
  (exact: x is continuous through impacts), whose density is S_yy(ω) sinc²(ωΔ/2),
  divided out; its aliases fall like ω⁻⁴ too, where point samples of y would alias
  like ω⁻² (S_yy(ω) ~ D/(πω²)).  R_yy and Var y come from point samples of y.
- **Mean.**  E[y] = 0 in the stationary state; E[x] = 0 for a symmetric system,
  otherwise the sample mean of the whole run, subtracted exactly from every segment
  after the fact (:mod:`._welch`).
- **Resolution.**  The window smooths S over ~2π/T: at a peak of half-power width w
  the relative bias is about −(16π²/3)/(w T)².  The default T = :data:`SEGMENT`/λ
  (λ the slowest energy relaxation rate, a lower bound of every peak's width) keeps
  it below 5e-3 (the linear oscillator, w = c = λ; the peaks of a system with walls
  are wider: the paper's case needs T ≳ 20/λ); ``segment`` sets T.
- **R(τ)** is the inverse transform of the mean |X|² over the window's own
  autocorrelation, on lags kΔ up to T/2.

Error estimate (``error_estimate()``), per ω: 2 SE + the resolution bias (the same
samples in half-length segments: bias(T) ≈ (S_{T/2} − S_T)/3, the bias being
O(1/T²)) and twice its SE + the aliasing bound (S at the Nyquist frequency) + the
time-step bias from a second run at 2 dt (the same paths, times, segments and seed
family; bias(dt) ≈ (S(2 dt) − S(dt))/3, the scheme being O(dt²); :mod:`.estimate`)
and twice its SE.  The second run is made on the first call.

Measured (peak frequencies, cost of a 1 % SE, the estimate): docs/measurements.md,
§Monte Carlo spectra.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from .._checks import InputError, check_float
from ..budget import Cost, enforce
from ..model import VibroImpactSystem
from ..spectrum import Spectrum, check_omega, check_signal
from . import _setup as S
from ._paths import Paths, shared_options
from ._summary import _ratio
from ._welch import Welch
from .estimate import bias_factor, interruption_note, second_run

__all__ = ["spectrum", "SEGMENT"]

#: Default paths per device.
DEFAULT_PATHS = {"cpu": 256, "cuda": 4096}
#: Default segment length in relaxation times 1/λ (module docstring).
SEGMENT = 100.0
#: Default band: the largest requested ω at most this fraction of the Nyquist π/Δ.
BAND = 0.25
#: Chunks (half segments) per path at least: three whole segments.
MIN_CHUNKS = 4
#: The peak frequency is fitted where S is at least this fraction of its maximum.
PEAK_LEVEL = 0.8
#: Lags kept of R at most (every k-th lag beyond).
MAX_LAGS = 2049


def _plan(where: str, system: VibroImpactSystem, omega: np.ndarray, dt: float, lam: float,
          segment: float | None, interval: float | None) -> dict[str, Any]:
    """Sampling interval Δ = every·dt (every even, so a run at 2 dt samples alike),
    segment N = T/Δ samples (a multiple of 4)."""
    w0 = 2.0 * math.pi / S.time_scales(system)["period"]
    target = interval if interval is not None else \
        math.pi * BAND / max(float(omega[-1]), w0)
    every = max(2, 2 * round(target / (2.0 * dt)))
    delta = every * dt
    if omega[-1] >= math.pi / delta:
        how = "a smaller sample_interval" if every > 2 else \
            f"a smaller dt (Δ is at least 2 dt = {delta:.6g} s)"
        raise InputError(f"{where}: omega must stay below the Nyquist frequency π/Δ = "
                         f"{math.pi / delta:.6g} rad/s of the sampling interval Δ = "
                         f"{delta:.6g} s; got up to {omega[-1]:.6g} (give {how})",
                         where=where, name="omega")
    T = segment if segment is not None else SEGMENT / lam
    nseg = max(16, 4 * round(T / (4.0 * delta)))
    return {"every": every, "interval": delta, "nseg": nseg, "segment": nseg * delta,
            "chunk_steps": every * nseg // 2}


def _run(system, plan, of, *, n_paths, n_batches, dt, seed, max_impacts, threads, device,
         n_burn, max_chunks, target_rse, progress, chunks=None, omega=None):
    """The paths sampled into Welch sums: (welch of the signal, welch of y points or
    None, the mean, chunks done, partial)."""
    every = int(round(plan["interval"] / dt))
    P = Paths(system, n_paths=n_paths, n_batches=n_batches, dt=dt, seed=seed,
              max_impacts=max_impacts, threads=threads, device=device)
    prog = S.Progress(progress, "spectrum")
    try:
        P.burn_in(n_burn, prog, (0.0, 0.1))
    except KeyboardInterrupt:
        prog.close("(interrupted during burn-in: nothing sampled)")
        raise
    half, delta = plan["nseg"] // 2, plan["interval"]
    x0 = P.current_x().copy()
    known = of == "y" or system.symmetric
    workers = threads or -1
    q = Welch(plan["nseg"], P.starts, delta, 0.0 if known else float(np.mean(x0)),
              workers=workers)
    yw = Welch(plan["nseg"], P.starts, delta, 0.0, half=False, workers=workers) \
        if of == "y" else None
    n_chunks = chunks if chunks is not None else max_chunks
    done, partial = 0, False
    try:
        while done < n_chunks:
            ox = np.empty((n_paths, half))
            oy = np.empty((n_paths, half)) if of == "y" else None
            P.advance(every * half, every, ox, oy)
            if of == "x":
                q.push(ox)
            else:
                q.push(np.diff(np.concatenate([x0[:, None], ox], axis=1), axis=1) / delta)
                x0 = ox[:, -1].copy()
                yw.push(oy)
            done += 1
            frac = done / n_chunks
            if chunks is None and done >= MIN_CHUNKS:
                rse = _peak_rse(q, omega)
                frac = max(frac, min(1.0, (target_rse / rse) ** 2))
                if rse <= target_rse:
                    break
            prog.update(0.1 + 0.9 * min(frac, 1.0), "sampling")
    except KeyboardInterrupt:
        if q.segments == 0:
            prog.close("(interrupted before a whole segment)")
            raise
        partial = True
        interruption_note("\n[montecarlo] interrupted: returning the spectrum of the "
                          "segments sampled so far (info['partial'] = True)")
    prog.close()
    P.check_finite("montecarlo.spectrum")
    mean = 0.0 if known else q.mean()
    return q, yw, mean, done, partial, P


def _peak_rse(q: Welch, omega: np.ndarray) -> float:
    """Relative SE of S at its largest value in the requested band (the adaptive rule)."""
    w, Sb = q.density(q.power(None))
    band = w <= omega[-1] * (1 + 1e-12)
    band &= w >= omega[0] * (1 - 1e-12) - (w[1] if w.size > 1 else 0.0)
    if not band.any():
        band[:] = True
    est, se = _ratio(Sb[:, band] * q.n[:, None], q.n)
    k = int(np.argmax(est))
    return float(se[k] / est[k]) if est[k] > 0 else math.inf


def _reduce(q: Welch, yw: Welch | None, mean: float, of: str, omega: np.ndarray):
    """Densities, correlation and variance from the Welch sums (per batch → ratio
    estimates with SE), and the resolution bias at the requested ω."""
    w_grid, Sb = q.density(q.power(mean))
    wh_grid, Shb = q.density(q.power(mean, "half"), "half")
    if of == "y":
        Sb = Sb / np.sinc(w_grid * q.interval / (2 * math.pi)) ** 2
        Shb = Shb / np.sinc(wh_grid * q.interval / (2 * math.pi)) ** 2
    wt = np.diff(q.starts).astype(float)
    S_grid, S_se = _ratio(Sb * wt[:, None], wt)
    D, D_se = _ratio((Shb - Sb[:, ::2]) * wt[:, None], wt)
    dens = CubicSpline(w_grid, S_grid)(omega)
    se = np.interp(omega, w_grid, S_se)
    leak = CubicSpline(wh_grid, D)(omega) / 3.0
    leak_se = np.interp(omega, wh_grid, D_se) / 3.0
    src = yw if of == "y" else q
    lags, Rb = src.correlation(src.power(0.0 if of == "y" else mean))
    stride = max(1, math.ceil((lags.size - 1) / (MAX_LAGS - 1)))
    lags, Rb = lags[::stride], Rb[:, ::stride]
    R, R_se = _ratio(Rb * wt[:, None], wt)
    vb = src.variance(0.0 if of == "y" else mean)
    var, var_se = _ratio(vb[:, None] * src.count[:, None], src.count)
    alias = float(S_grid[-1])
    return dict(density=np.maximum(dens, 0.0), se=se, leak=leak, leak_se=leak_se,
                lags=lags, R=R, R_se=R_se, variance=float(var[0]),
                variance_se=float(var_se[0]), alias=alias, grid=w_grid, grid_density=S_grid,
                peak=_peak(w_grid, Sb, wt))


def _peak(w: np.ndarray, Sb: np.ndarray, wt: np.ndarray) -> tuple[float, float]:
    """The peak frequency: the vertex of the least-squares parabola through the Welch
    grid values (the whole band to π/Δ) around the largest pooled S where S stays at
    least :data:`PEAK_LEVEL` of it (at least five points), and its SE from the same
    fit to each batch (delta method)."""
    p = wt / wt.sum()
    S = p @ Sb
    k = int(np.argmax(S))
    lo = hi = k
    while lo > 0 and S[lo - 1] >= PEAK_LEVEL * S[k]:
        lo -= 1
    while hi < w.size - 1 and S[hi + 1] >= PEAK_LEVEL * S[k]:
        hi += 1
    while hi - lo < 4 and (lo > 0 or hi < w.size - 1):
        lo, hi = max(lo - 1, 0), min(hi + 1, w.size - 1)
    if hi - lo < 2:
        return float(w[k]), math.nan
    x = w[lo:hi + 1] - w[k]
    c = np.polyfit(x, np.column_stack([S[lo:hi + 1], Sb[:, lo:hi + 1].T]), 2)
    a, b = c[0, 0], c[1, 0]
    if not a < 0:
        return float(w[k]), math.nan
    # the vertex −b/(2a) linearised in the batches' deviations of (a, b) (delta method)
    dv = -(c[1, 1:] - b) / (2.0 * a) + b * (c[0, 1:] - a) / (2.0 * a * a)
    B = dv.size
    se = math.sqrt(B / (B - 1) * np.sum((p * dv) ** 2)) if B > 1 else math.nan
    return max(float(w[k] - b / (2.0 * a)), 0.0), se


def _at_peak(red: dict) -> dict[str, float]:
    """Relative SE and resolution bias (with twice its SE) at the largest requested S."""
    k = int(np.argmax(red["density"]))
    S = max(float(red["density"][k]), 1e-300)
    return {"rse_peak": float(red["se"][k]) / S,
            "resolution_peak": (abs(float(red["leak"][k])) + 2.0 * float(red["leak_se"][k]))
            / S}


def spectrum(system: VibroImpactSystem, omega: Any, of: str = "x", *,
             seed: int | np.random.SeedSequence | None = None, n_paths: int | None = None,
             dt: float | None = None, t_burn: float | None = None,
             t_sample: float | None = None, target_rse: float = 0.01,
             max_t_sample: float | None = None, segment: float | None = None,
             sample_interval: float | None = None, n_batches: int = 32,
             max_impacts: int = 64, progress: bool | None = None,
             threads: int | None = None, device: str = "cpu") -> Spectrum:
    """The two-sided S(ω) of x or y, and R(τ), by Welch averages of sampled paths
    (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
        Any stationary system: walls with constant or speed-dependent restitution,
        parametric noise, coloured external noise.  A forced system is refused.
    omega : array_like
        Frequencies in rad/s, ≥ 0, increasing, below the Nyquist frequency π/Δ.
    of : {"x", "y"}
    seed : int, SeedSequence or None
        Same seed → bit-identical spectrum (on one device).
    n_paths : int, optional
        Default 256 (4096 on a GPU).
    dt, t_burn, n_batches, max_impacts, progress, threads, device
        As in :func:`~fpk_vibro.montecarlo.stationary`.
    t_sample : float, optional
        Sampled time per path (rounded up to half segments, at least 2 segments);
        default: until the relative SE of S at its largest value in the band is at
        most ``target_rse``, at most ``max_t_sample`` (default 10⁴/λ).
    target_rse : float, default 0.01
    segment : float, optional
        Welch segment length T in seconds; default :data:`SEGMENT`/λ.
    sample_interval : float, optional
        Δ (rounded to an even number of steps); default π/4 over the larger of
        max(omega) and the natural frequency.

    Returns
    -------
    Spectrum
        ``info`` holds the run (dt, Δ, T, segments, paths, peak frequency of the Welch
        grid and its SE between batches, seconds, partial).

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> s = VibroImpactSystem(a=1.0, b=0.0, c=0.2, D1=0.02, barriers="none")
    >>> sp = spectrum(s, [0.0, 1.0], seed=1, n_paths=64, n_batches=8, t_sample=2000.0,
    ...               segment=400.0)
    >>> sp.density.shape, bool(abs(sp.density[1] / (s.D1 / np.pi / 0.04) - 1) < 0.2)
    ((2,), True)
    """
    where = "montecarlo.spectrum"
    t_start = time.perf_counter()
    w = check_omega(where, omega)
    of = check_signal(where, of)
    opts, r, dev = shared_options(where, system, dict(locals()), DEFAULT_PATHS)
    if segment is not None:
        segment = check_float("segment", segment, 0.0, where=where)
    if sample_interval is not None:
        sample_interval = check_float("sample_interval", sample_interval, 0.0, where=where)
    dt, lam = r["dt"], r["lam"]
    plan = _plan(where, system, w, dt, lam, segment, sample_interval)
    n_burn = math.ceil(r["t_burn"] / dt - 1e-9)
    chunk_t = plan["chunk_steps"] * dt
    fixed = opts.t_sample is not None
    t_max = opts.t_sample if fixed else r["max_t_sample"]
    n_chunks = max(MIN_CHUNKS if not fixed else 2, math.ceil(t_max / chunk_t - 1e-9))
    n = opts.n_paths
    cost = Cost(150e6 + 8.0 * n * plan["nseg"] * (3 if of == "y" else 1.5),
                float(n * (n_burn + n_chunks * plan["chunk_steps"])), "path-steps",
                1.0 + n * (n_burn + n_chunks * plan["chunk_steps"]) / 2e8,
                "t_sample" if fixed else "max_t_sample")
    enforce(cost, where)
    run = dict(n_paths=n, n_batches=opts.n_batches, seed=opts.seed,
               max_impacts=opts.max_impacts, threads=opts.threads, device=dev,
               target_rse=opts.target_rse, progress=opts.progress, omega=w)
    q, yw, mean, done, partial, paths = _run(system, plan, of, dt=dt, n_burn=n_burn,
                                             max_chunks=n_chunks,
                                             chunks=n_chunks if fixed else None, **run)
    red = _reduce(q, yw, mean, of, w)
    run["seed"] = paths.seed_entropy                  # the bias run: the same seed family
    seconds = time.perf_counter() - t_start
    info = dict(dt=dt, sample_interval=plan["interval"], segment=plan["segment"],
                nseg=plan["nseg"], segments=q.segments, n_paths=n, n_batches=opts.n_batches,
                t_burn=n_burn * dt, t_sample=done * chunk_t, seed_entropy=paths.seed_entropy,
                device=paths.device_name, partial=partial, seconds=seconds,
                peak_frequency=red["peak"][0], peak_frequency_se=red["peak"][1],
                variance_se=red["variance_se"], resolution_bias=red["leak"],
                correlation_se=red["R_se"], **_at_peak(red), scheme="BAOAB splitting, Welch (Hann, "
                "half overlap)")

    def estimate() -> dict[str, Any]:
        return _estimate(system, plan, of, w, red, partial, run, dt, n_burn, done)

    return Spectrum("montecarlo", system, of, w, red["density"], variance=red["variance"],
                    se=red["se"], lags=red["lags"], correlation=red["R"], estimate=estimate,
                    info=info, mean=mean)


def _estimate(system, plan, of, w, red, partial, run, dt, n_burn, done) -> dict[str, Any]:
    """The error estimate of the module docstring (the second run made here)."""
    dens, se = red["density"], red["se"]
    leak = np.abs(red["leak"]) + 2.0 * red["leak_se"]
    R0 = max(red["R"][0], 1e-300)
    out: dict[str, Any] = {"se": se, "resolution": red["leak"], "aliasing": red["alias"]}
    if partial:
        bias = np.zeros_like(dens)
        bias_R, bias_var = 0.0, 0.0
        assumes = ("2 standard errors, the resolution bias from half-length segments and "
                   "the aliasing bound; no time-step bias (an interrupted run)")
        out["time_step"] = np.full_like(dens, np.nan)
    else:
        t0 = time.perf_counter()

        def again(dt2: float):
            if dt2 > S.dt_limit(system):
                raise InputError(f"dt = {dt2:.4g} beyond the stability limit", name="dt")
            q, yw, mean, _, _, _ = _run(system, plan, of, dt=dt2,
                                        n_burn=math.ceil(n_burn * dt / dt2 - 1e-9),
                                        max_chunks=done, chunks=done, **run)
            return _reduce(q, yw, mean, of, w)

        other, step = second_run(again, dt, kept="the spectrum")
        f = bias_factor([(1.0, dt)], [2.0 * dt if step == "2 dt" else 0.5 * dt])
        b = f * (dens - other["density"])
        b_se = abs(f) * np.sqrt(se ** 2 + other["se"] ** 2)
        bias = np.abs(b) + 2.0 * b_se
        bR = f * (red["R"] - np.interp(red["lags"], other["lags"], other["R"]))
        bias_R = float(np.max(np.abs(bR) + 2.0 * abs(f) * np.hypot(
            red["R_se"], np.interp(red["lags"], other["lags"], other["R_se"]))))
        bias_var = abs(f * (red["variance"] - other["variance"])) + 2.0 * abs(f) * math.hypot(
            red["variance_se"], other["variance_se"])
        out["time_step"] = b
        out["seconds"] = time.perf_counter() - t0
        assumes = (f"2 standard errors + the resolution bias from half-length segments "
                   f"(O(1/T²)) + the aliasing bound (S at the Nyquist frequency) + the "
                   f"time-step bias from a run at {step} (O(dt²) scheme), each bias with "
                   "twice its standard error")
    density = 2.0 * se + leak + red["alias"] + bias
    out.update(density=density, relative=float(np.max(density) / max(np.max(dens), 1e-300)),
               variance=float((2.0 * red["variance_se"] + bias_var) /
                              max(red["variance"], 1e-300)),
               correlation=float((2.0 * np.max(red["R_se"]) + bias_R) / R0),
               assumes=assumes)
    return out
