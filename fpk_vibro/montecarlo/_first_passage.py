"""Mean first-passage time and reliability by Monte Carlo: :func:`first_passage`.

Paths start from a point, a Gaussian (conditioned on the safe set) or the stationary
density conditioned on the safe set, and run with the stationary engine's own step
(the compiled :mod:`._fp_kernel`, which calls the sweep, flight and impact code of
:mod:`._kernel`) until H ≥ H_c for the first time.

Crossing detection
------------------
H is checked at every step end, and between step ends by the probability that the
velocity, a Brownian bridge between its values at the step ends, left the band
|y| < sqrt(2 (H_c − G(x))) (:mod:`._fp_kernel`); in a step with an impact the
bridge runs to the impact and from it, and an impact at H ≥ H_c is an exit.
Checking the step ends alone detects every exit late, by about the overshoot
0.58 σ sqrt(dt) of the continuous path (Broadie–Glasserman–Kou): an O(sqrt(dt))
bias of τ.  Measured on the paper's r = 0.92 case, H_c = 0.498, from (0, 0),
against FE (τ = 80.331, 80.405 at nx = 24, 48: ≈ 80.43 at order 2),
τ_MC/τ_FE − 1 in %, dt in units of the default T0/120 ≈ 0.0506::

    dt / default                        4       2       1       ½       ¼
    step ends only                  +18.2   +12.3    +8.4    +5.7    +4.4
    bridge of H, σ_H² = 2 D y²       +3.3    +1.3   +0.56   +0.20   −0.01
    the same, through impacts       +1.46   +0.47   +0.10   +0.08
    bridge of y (this module)       +0.38   −0.09   −0.10   −0.09   +0.04

(first two rows 2¹⁸ paths, SE 0.17 %; the others 2 to 6 runs of 2²⁰ paths each,
SE 0.03–0.06 % for the row's mean).  At the default dt the bias is −0.1 ± 0.03 %,
of the order of the FE reference's own uncertainty.  The bridge of H is the same
where |y| ≫ sqrt(D dt) but misses the crossings near the turning points of the
boundary (y ≈ 0), where the energy rises by the noise's drift D: a double well
(a = −1, b = 1, c = 0.1, D1 = 0.05, walls at ±1.5, H_c = 0.1, τ ≈ 2.29 ≈ 80 steps)
started at the saddle (0, 0) gives, against dt/16: step ends only +22 %, bridge of H
+2.0 %, bridge of y −0.5 ± 0.25 % at the default dt.  Exit times are interpolated
within the step: H linearly for an exit seen at a step end, the middle of the step
for the others.

Censoring
---------
A path that has not exited by the horizon is censored.  With ``t_max`` None the
horizon grows (×4 per round, from 10 relaxation times) and only the surviving paths
are continued, from their state and their block's random stream, until every path
has exited or the horizon reaches 500 relaxation times; work is spent only on
living paths, so a long horizon costs little.  Censored paths (``t_max`` given, or
the cap reached) enter the mean as min(T, t_max): the mean is then a lower bound;
``info["censored"]`` gives their fraction, and a RuntimeWarning says so with an
estimate of the missing part.  R(t) is exact (empirical) up to the horizon.
"""
from __future__ import annotations

import math
import sys
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from .. import _checks
from ..first_passage import FirstPassage, check_times, parse_start
from ..safe_sets import SafeSet, parse_safe_set
from ..initial import parse_initial
from ..model import VibroImpactSystem, check_system
from . import _fp_kernel as FK
from . import _kernel as K
from . import _setup as S
from ._threads import n_threads, run_blocks

__all__ = ["first_passage"]

WHERE = "montecarlo.first_passage"
#: Blocks of paths (one random stream each); fixed, so results do not depend on threads.
N_BLOCKS = 32
#: First horizon and largest horizon of an adaptive run, in relaxation times 1/λ.
T_FIRST, T_CAP = 10.0, 500.0
#: Horizon growth per round of an adaptive run.
GROWTH = 4
#: Quantiles reported in ``info["quantiles"]``.
QUANTILES = (0.05, 0.5, 0.95)
#: Burn-in of the stationary start, in relaxation times (initial bias ~e⁻⁹).
STATIONARY_BURN = 9.0
#: Fewest start samples inside the safe set per sample drawn (else ValueError).
MIN_ACCEPT = 1e-3


def _check_args(system, safe, start, times, values: dict[str, Any]) -> dict[str, Any]:
    """Every argument checked (one-line InputError naming it), defaults filled in: the
    numerical keywords by the declared options (:class:`.options.Options`, mode
    "first_passage", with the budget).  ``safe``: the keywords energy, displacement,
    impact_speed."""
    from .options import Options
    check_system(WHERE, system)
    safe = parse_safe_set(WHERE, system, **safe)
    kind, value = parse_start(WHERE, system, start, safe)
    requested = check_times(WHERE, times)
    values = {k: v for k, v in values.items()
              if k not in ("energy", "displacement", "impact_speed")}
    opts, _ = Options.prepare(system, "first_passage", values)
    return {"safe": safe, "kind": kind, "value": value, "n_paths": opts.n_paths,
            "dt": opts.resolved(system, "first_passage")["dt"], "t_max": opts.t_max,
            "seed": opts.seed, "times": requested, "threads": opts.threads,
            "progress": opts.progress, "bridge": opts.bridge, "device": opts.device}


def first_passage(system: VibroImpactSystem, *, energy: float | None = None,
                  displacement: Any = None, impact_speed: float | None = None,
                  start: Any = (0.0, 0.0), n_paths: int = 4096, dt: float | None = None, t_max: float | None = None,
                  seed: int | np.random.SeedSequence | None = None,
                  times: Sequence[float] | None = None, threads: int | None = None,
                  progress: bool | None = None, bridge: bool = True,
                  device: str = "cpu") -> FirstPassage:
    """Mean first-passage time and reliability out of a safe set by simulation.

    Parameters
    ----------
    system : VibroImpactSystem
    energy, displacement, impact_speed
        The safe set, exactly one of them (:func:`fpk_vibro.safe_sets.parse_safe_set`):
        ``energy=H_c`` (above min G on the strip): {H < H_c}; ``displacement=b``
        (|x| < b) or ``(x_lo, x_hi)``: a path leaves when x reaches a bound (a bound
        at or beyond a wall is never reached), located exactly on the scheme's path,
        which is linear within each half step; ``impact_speed=u_c``: a path leaves at
        its first impact faster than u_c (timed at the middle of its step).
    start : (x0, y0), dict or "stationary"
        A point of the safe set (default the equilibrium at rest), a Gaussian
        ``{"mean": (x0, y0), "std": (sx, sy)}`` (x truncated to the strip, samples
        outside the safe set redrawn: the density conditioned on it), or
        "stationary": states of a stationary run (burn-in of 9 relaxation times)
        with H < H_c.
    n_paths : int, default 4096
        Independent paths, at least 2 (and within the budget,
        :mod:`fpk_vibro.budget`); the standard error of τ falls as
        1/sqrt(n_paths) (T is about exponential when H_c is well above E[H]:
        SE ≈ τ/sqrt(n_paths)).
    dt : float, optional
        Time step; default as in :func:`~fpk_vibro.montecarlo.stationary` (T0/120
        on the paper's case: bias of τ −0.1 %, module docstring).
    t_max : float, optional
        Horizon: paths still inside then are censored (module docstring).  Default:
        continued until every path has exited (at most 500 relaxation times).
    seed : int, SeedSequence or None
        Same seed → the same numbers for any number of threads; None draws fresh
        entropy (``info["seed_entropy"]``).
    times : sequence of float, optional
        Times at which R(t) must be known, in any order
        (:func:`fpk_vibro.first_passage.check_times`): added to the empirical grid,
        which runs to the last exit or the horizon (up to the horizon when paths are
        censored).
    threads : int, optional
        Worker threads; default :func:`numba.get_num_threads`.
    progress : bool or None
        Progress line on stderr; None: when stderr is a terminal (after 2 s).
    bridge : bool, default True
        Detect crossings between step ends by the Brownian-bridge probability;
        False checks the step ends only (biased late by O(sqrt(dt)); kept for
        measuring that bias).
    device : {"cpu", "cuda", "auto"}, default "cpu"
        "cuda": on an NVIDIA GPU (:func:`._cuda_engine.first_passage`: no per-path
        memory, so any ``n_paths`` fits; exit times go to a histogram of 4096 bins up
        to the horizon, ``t_max`` or 500 relaxation times, so R(t) is exact at its
        edges and the quantiles are read from it to a bin); "auto": the GPU when one
        is usable.  Without a GPU "cuda" is refused in one line.

    Returns
    -------
    FirstPassage
        ``method`` "montecarlo"; ``mean`` ± ``mean_se`` (standard error over the
        independent paths); ``times``, ``survival`` the empirical R(t) = P(T > t),
        ``survival_band`` its 95 % Dvoretzky–Kiefer–Wolfowitz band (simultaneous in
        t); ``info`` with ``quantiles`` {0.05, 0.5, 0.95} of T and their 95 %
        order-statistic intervals ``quantiles_ci``, ``censored`` (fraction),
        ``t_max`` (horizon reached), ``dt``, ``path_steps``, ``exits_by_bridge``,
        ``seconds``, ``seed_entropy``.

    Raises
    ------
    ValueError
        For an invalid argument (an InputError naming it; the numerical keywords are
        declared by :class:`fpk_vibro.montecarlo.Options`, mode "first_passage"),
        or a run beyond the budget, before any simulation; or a start
        that puts almost no mass (< 0.1 %) inside the safe set.
    FloatingPointError
        If a path becomes NaN (a time step too large for the motion).

    Warns
    -----
    RuntimeWarning
        When paths are censored: the mean is then a lower bound.

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem, montecarlo
    >>> fp = montecarlo.first_passage(VibroImpactSystem.paper(r=0.92), energy=0.498,
    ...                               seed=1, progress=False)
    >>> 70 < fp.mean < 90
    True
    """
    a = _check_args(system, dict(energy=energy, displacement=displacement,
                                 impact_speed=impact_speed), start, times, locals())
    t0 = time.perf_counter()
    safe, n, dt = a["safe"], a["n_paths"], a["dt"]
    ss = S.seed_sequence(a["seed"])
    nb = min(N_BLOCKS, n)
    kids = ss.spawn(nb + 2)
    rng = S.rng_states(kids[:nb])
    prog = S.Progress(a["progress"], "first passage")
    info: dict[str, Any] = {}
    lam = S.relaxation_rate(system)
    k_final = math.ceil((a["t_max"] if a["t_max"] is not None else T_CAP / lam) / dt - 1e-9)
    kmax = k_final if a["t_max"] is not None else min(k_final, math.ceil(T_FIRST / lam / dt))
    from ._device import resolve
    on_gpu = resolve(a["device"], WHERE) == "cuda"
    try:
        if a["kind"] == "point":
            xs, ys = np.full(n, a["value"][0]), np.full(n, a["value"][1])
        elif a["kind"] == "gaussian":
            xs, ys = _gaussian_starts(system, a["value"], safe, n,
                                      np.random.default_rng(kids[nb]))
        else:
            xs, ys, info["stationary_start"] = _stationary_starts(
                system, safe, n, dt, kids[nb + 1], a["threads"], prog)
        if on_gpu:
            return _on_gpu(system, safe, a, xs, ys, k_final, kids[0], prog, info, ss, t0)
        T, status, counts, rounds, kmax = simulate(
            system, safe, xs, ys, dt, rng, kmax, k_final, a["threads"], a["bridge"], prog)
    except KeyboardInterrupt:
        prog.close("(interrupted)")
        raise
    prog.close()
    if np.any(status == FK.FAILED):
        raise FloatingPointError(
            f"{WHERE}: {int(np.sum(status == FK.FAILED))} path(s) became NaN; the time "
            f"step dt = {dt:g} is too large for this motion")
    horizon = kmax * dt
    censored = status == FK.ALIVE
    info.update(n_paths=n, dt=float(dt), t_max=float(horizon), rounds=rounds,
                n_censored=int(censored.sum()), censored=float(censored.mean()),
                path_steps=float(counts[:, 0].sum()),
                exits_by_bridge=float(counts[:, 2].sum() / max(counts[:, 1:].sum(), 1.0)),
                crossing=("step ends + Brownian bridge" if a["bridge"] else "step ends")
                if safe.kind == "energy" else "located on the path" if
                safe.kind == "displacement" else "at impacts",
                band="95 % Dvoretzky-Kiefer-Wolfowitz (simultaneous)",
                seed_entropy=ss.entropy, n_blocks=nb)
    return _summarise(system, safe, (a["kind"], a["value"]), np.where(censored, horizon, T),
                      censored, horizon, a["times"], info, t0)


def simulate(system: VibroImpactSystem, H_c: "float | SafeSet", xs: np.ndarray, ys: np.ndarray,
             dt: float, rng: np.ndarray, kmax: int, k_final: int, threads: int | None = None,
             bridge: bool = True, prog: S.Progress | None = None, max_impacts: int = 64
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """Run every path from (xs, ys) (updated in place) until it exits or the horizon.

    Paths are split into ``rng.shape[0]`` blocks of consecutive indices.  Rounds:
    horizon ``kmax`` steps, then (if paths survive and ``kmax < k_final``) ×GROWTH,
    continuing the survivors.  Returns (exit times, status per path, per-block
    counts [path-steps, exits at step ends, exits by the bridge], rounds, final
    horizon in steps).  ``H_c``: the critical energy or any :class:`SafeSet`.
    """
    safe = H_c if isinstance(H_c, SafeSet) else SafeSet("energy", energy=float(H_c))
    kind = {"energy": FK.ENERGY, "displacement": FK.DISPLACEMENT,
            "impact_speed": FK.IMPACT_SPEED}[safe.kind]
    hc = float(safe.energy) if safe.kind == "energy" else math.inf
    uc = float(safe.speed) if safe.kind == "impact_speed" else math.inf
    law = S.wall_laws(system)
    n, nb = xs.size, rng.shape[0]
    p, ip = S.step_params(system, dt, max_impacts)
    home = S.block_starts(n, nb)
    order, starts = np.arange(n, dtype=np.int64), home.copy()
    ks = np.zeros(n, dtype=np.int64)
    T = np.full(n, np.nan)
    status = np.zeros(n, dtype=np.int64)
    counts = np.zeros((nb, 3))
    xs, ys = np.ascontiguousarray(xs, dtype=float), np.ascontiguousarray(ys, dtype=float)
    wave = max(4, 2 * n_threads(threads))
    rounds = 0
    while True:
        rounds += 1
        for b0 in range(0, nb, wave):
            run_blocks(FK._fp_block, min(wave, nb - b0),
                       (b0, order, starts, xs, ys, ks, T, status, rng, p, ip,
                        float(system.D1), float(system.D2), hc,
                        int(kmax), bool(bridge), counts, kind, float(safe.x_lo),
                        float(safe.x_hi), uc, law), threads)
            if prog is not None:
                prog.update(min(b0 + wave, nb) / nb, f"round {rounds}, horizon "
                            f"{kmax * dt:.4g}")
        alive = np.flatnonzero(status == FK.ALIVE)
        if alive.size == 0 or kmax >= k_final:
            return T, status, counts, rounds, kmax
        kmax = min(kmax * GROWTH, k_final)
        order = alive.astype(np.int64)           # sorted: grouped by home block
        starts = np.searchsorted(order, home).astype(np.int64)


#: Bins of the GPU's exit-time histogram.
GPU_BINS = 4096


def _on_gpu(system, safe, a, xs, ys, k_final, child, prog, info, ss, t0) -> FirstPassage:
    """The run on the GPU (:func:`._cuda_engine.first_passage`) summarised as on the CPU:
    R(t) at the histogram's edges (and, interpolated linearly within a bin, at the
    requested times), quantiles from it, the DKW band."""
    from . import _cuda_engine
    from ._cuda_rng import seed_of
    from ._device import describe
    n, dt = a["n_paths"], a["dt"]
    value = {"energy": safe.energy, "displacement": (safe.x_lo, safe.x_hi),
             "impact_speed": safe.speed}[safe.kind]
    horizon = k_final * dt
    out = _cuda_engine.first_passage(
        system, safe.kind, value, xs, ys, n, dt, k_final, seed_of(child),
        horizon / GPU_BINS, n_batches=min(N_BLOCKS, n), bridge=a["bridge"],
        progress=lambda g: prog.update(g, "GPU"))
    prog.close()
    n = int(out.get("n_paths", n))         # (fewer after Ctrl-C: the launches finished)
    if out.get("partial"):
        info["partial"] = True
        print(f"\n[montecarlo] interrupted: first passage from the {n} paths finished",
              file=sys.stderr)
    grid, R = np.asarray(out["times"], dtype=float), np.asarray(out["survival"], dtype=float)
    censored = float(out["censored"])
    if not censored:                       # the grid ends at the last exit, as on the CPU
        last = int(np.flatnonzero(R > 0)[-1]) + 1 if np.any(R > 0) else 0
        grid, R = grid[:last + 1], R[:last + 1]
    if a["times"] is not None:
        ts = np.asarray(a["times"], dtype=float)
        Rt = np.interp(ts, grid, R, right=R[-1] if censored else 0.0)
        grid, idx = np.unique(np.concatenate([grid, ts]), return_index=True)
        R = np.concatenate([R, Rt])[idx]
    eps = math.sqrt(math.log(2.0 / 0.05) / (2.0 * n))
    band = (np.clip(R - eps, 0.0, 1.0), np.clip(R + eps, 0.0, 1.0))
    qs, ci = {}, {}
    for q in QUANTILES:
        def at(level: float) -> float:
            below = np.flatnonzero(R <= 1.0 - level)
            return float(grid[below[0]]) if below.size else math.inf
        qs[q] = at(q)
        ci[q] = (at(max(q - 1.96 * math.sqrt(q * (1 - q) / n), 0.0)),
                 at(min(q + 1.96 * math.sqrt(q * (1 - q) / n), 1.0)))
    info.update(n_paths=n, dt=float(dt), t_max=float(horizon), rounds=1,
                n_censored=int(round(censored * n)), censored=censored,
                path_steps=float(out["path_steps"]),
                exits_by_bridge=float(out["sums"][:, 5].sum() / max(out["sums"][:, 2].sum(), 1.0)),
                crossing=("step ends + Brownian bridge" if a["bridge"] else "step ends")
                if safe.kind == "energy" else "located on the path" if
                safe.kind == "displacement" else "at impacts",
                band="95 % Dvoretzky-Kiefer-Wolfowitz (simultaneous)",
                seed_entropy=ss.entropy, n_blocks=min(N_BLOCKS, n), quantiles=qs,
                quantiles_ci=ci, band_halfwidth=eps, device=describe()["gpu"],
                quantiles_from=f"a histogram of {GPU_BINS} bins to the horizon")
    if censored:
        warnings.warn(f"{WHERE}: {100 * censored:.3g} % of the paths were still inside "
                      f"{safe.describe()} at t_max = {horizon:.6g}: the mean is that of "
                      "min(T, t_max), a lower bound; raise t_max", RuntimeWarning,
                      stacklevel=3)
    info["seconds"] = time.perf_counter() - t0
    return FirstPassage("montecarlo", system,
                        float(safe.energy) if safe.kind == "energy" else None,
                        (a["kind"], a["value"]), float(out["mean"]), float(out["mean_se"]),
                        grid, R, band, info, safe_set=safe)


def _gaussian_starts(system, spec, safe, n, gen) -> tuple[np.ndarray, np.ndarray]:
    """n samples of the Gaussian start conditioned on the safe set (redrawn outside)."""
    init = parse_initial(spec, system)
    xs, ys, drawn = [], [], 0
    while sum(x.size for x in xs) < n:
        m = max(n, 1024)
        x, y = init.sample(m, gen)
        keep = safe.contains(system, x, y)
        xs.append(x[keep])
        ys.append(y[keep])
        drawn += m
        got = sum(x.size for x in xs)
        if got < MIN_ACCEPT * drawn or (got < n and drawn >= 1000 * n):
            raise _checks.invalid(WHERE, "start", f"a Gaussian with mass inside the safe "
                                  f"set {safe.describe()}", spec, f"{got} of {drawn} samples fall "
                                  "inside")
    return np.concatenate(xs)[:n], np.concatenate(ys)[:n]


def _stationary_starts(system, safe, n, dt, ss, threads, prog):
    """n states of stationary paths inside the safe set: fresh paths burned in for
    STATIONARY_BURN relaxation times by the stationary kernel, those inside kept (more
    paths are burned in until n are found)."""
    from ._engine import _run_chunks
    t_burn = STATIONARY_BURN / S.relaxation_rate(system)
    n_steps = math.ceil(t_burn / dt - 1e-9)
    p, ip = S.step_params(system, dt, 64)
    law = S.wall_laws(system)
    keep_x, keep_y, got, made, m = [], [], 0, 0, n
    for _ in range(20):
        nb = min(N_BLOCKS, m)
        kids = ss.spawn(nb + 1)
        rng = S.rng_states(kids[:nb])
        starts = S.block_starts(m, nb)
        xs = np.full(m, S.initial_x(system))
        ys = math.sqrt(S.energy_scale(system)) * np.random.default_rng(kids[nb]).standard_normal(m)
        none = S.Histograms(system, (), S.check_bins("bins", 2, WHERE), nb, 1.0)
        _run_chunks(xs, ys, rng, starts, n_steps, 0, 0, p, ip, np.zeros((nb, K.NM)),
                    np.zeros((nb, 2)), np.tile([np.inf, -np.inf], (nb, 1)), none, m,
                    prog, "stationary start", (0.0, 0.0), threads=threads, law=law)
        inside = safe.contains(system, xs, ys)
        keep_x.append(xs[inside])
        keep_y.append(ys[inside])
        got, made = got + int(inside.sum()), made + m
        if got >= n:
            break
        if got < MIN_ACCEPT * made:
            raise _checks.invalid(WHERE, "start", "a start with stationary mass in the safe "
                                  f"set {safe.describe()}", "stationary", f"only {got} of {made} "
                                  "stationary states fall inside")
        m = min(math.ceil(1.2 * (n - got) * made / got) + 64, 16 * n)
    else:  # pragma: no cover - MIN_ACCEPT bounds the rounds
        raise RuntimeError(f"{WHERE}: could not draw {n} stationary starts")
    info = {"t_burn": n_steps * dt, "safe_fraction": got / made, "paths_burned_in": made}
    return np.concatenate(keep_x)[:n], np.concatenate(keep_y)[:n], info


def _summarise(system, safe, start, T, censored, horizon, times, info, t0) -> FirstPassage:
    """Mean ± SE, quantiles, empirical R(t) with its DKW band, and the censoring
    warning."""
    n = T.size
    mean = float(T.mean())
    mean_se = float(T.std(ddof=1) / math.sqrt(n))
    Ts = np.sort(np.where(censored, np.inf, T))
    qs, ci = {}, {}
    for q in QUANTILES:
        pos = q * (n - 1)
        i = math.floor(pos)
        f = pos - i
        hi = Ts[min(i + 1, n - 1)]
        qs[q] = float(Ts[i] + f * (hi - Ts[i])) if math.isfinite(hi) else math.inf
        lo_k = max(int(stats.binom.ppf(0.025, n, q)), 1)
        hi_k = min(int(stats.binom.ppf(0.975, n, q)) + 1, n)
        ci[q] = (float(Ts[lo_k - 1]), float(Ts[hi_k - 1]))
    finite = Ts[np.isfinite(Ts)]
    t_end = horizon if censored.any() else float(finite.max(initial=0.0))
    # the own grid runs to the last exit (or the horizon); requested times are
    # added to it (R there is exact too), never stretching it
    grid = np.linspace(0.0, t_end, 501)
    if times is not None:
        beyond = times[times > t_end] if not censored.any() else times[:0]
        grid = np.unique(np.concatenate([grid, times[times <= t_end], beyond]))
    R = (n - np.searchsorted(Ts, grid, side="right")) / n
    eps = math.sqrt(math.log(2.0 / 0.05) / (2.0 * n))
    band = (np.clip(R - eps, 0.0, 1.0), np.clip(R + eps, 0.0, 1.0))
    info.update(quantiles=qs, quantiles_ci=ci, band_halfwidth=eps)
    if censored.any():
        half = np.searchsorted(grid, 0.5 * horizon)
        r_half, r_end = R[half], R[-1]
        rate = (math.log(r_half / r_end) / (horizon - grid[half])
                if r_end > 0 and r_half > r_end else 0.0)
        missing = float(censored.mean() / rate) if rate > 0 else math.inf
        info["censored_bias_estimate"] = missing
        warnings.warn(f"{WHERE}: {int(censored.sum())} of {n} paths "
                      f"({100 * censored.mean():.3g} %) were still inside {safe.describe()} at "
                      f"t_max = {horizon:.6g}: the mean {mean:.6g} is that of min(T, t_max), "
                      f"a lower bound (short by ~{missing:.3g} on an exponential tail); R(t) "
                      "is exact up to t_max; raise t_max", RuntimeWarning, stacklevel=3)
    info["seconds"] = time.perf_counter() - t0
    return FirstPassage("montecarlo", system,
                        float(safe.energy) if safe.kind == "energy" else None, start, mean,
                        mean_se, grid, R, band, info, safe_set=safe)
