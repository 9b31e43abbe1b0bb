"""Drivers of the Monte Carlo engine: :func:`stationary` and :func:`transient`."""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._checks import InputError
from ..initial import parse_initial, parse_times
from ..model import VibroImpactSystem
from . import _kernel as K
from . import _setup as S
from ._paired import stationary_pairs
from ._summary import _check_finite, _ratio, _reduce
from .estimate import interruption_note, shared_second_run
from .options import Options
from ..solution import TransientResult
from .solution import QUANTITIES, MonteCarloSolution


#: The list :func:`transient` returns (fpk_vibro.solution.TransientResult: ``partial``,
#: ``times_requested``); the name stays for the code that imports it from here.
TransientRun = TransientResult


def _run_chunks(xs, ys, rng, starts, n_steps, step0, sample_every, p, ip, mom, imp, xext,
                hist, n_paths, progress, label, done_frac=(0.0, 1.0), stop=None,
                frac=None, threads=None, walls=None, law=None, extra=None, last=None,
                ens=None, t0=0.0, zeta=None):
    """Advance in chunks of ~CHUNK_PATH_STEPS path-steps; returns steps done.

    ``ens``: a :class:`._cuda_engine.Ensemble` (device "cuda") advances the paths
    instead of the CPU kernel, in chunks of its ``chunk_path_steps``, adding into
    the same arrays (its wall losses into ``extra[..., X_E]``).

    ``stop()`` (checked after every chunk) ends the loop early when True;
    ``frac(done)`` overrides the completed fraction shown by the progress line;
    ``law``, ``extra``, ``last``: as :func:`._kernel.advance` takes them (``law`` is
    needed for a wall whose r depends on the impact speed); ``t0`` the time of the
    states on entry (the phase of a harmonic forcing); ``zeta`` the paths' coloured
    noise ζ (None: white), updated in place.
    """
    per = S.CHUNK_PATH_STEPS if ens is None else ens.chunk_path_steps
    chunk = max(1, per // max(n_paths, 1))
    if sample_every > 0:
        chunk = max(sample_every, chunk // sample_every * sample_every)
    done = 0
    while done < n_steps:
        n = min(chunk, n_steps - done)
        if ens is None:
            K.advance(xs, ys, rng, starts, n, step0 + done, sample_every, p, ip, mom, imp,
                      xext, hist.hH, hist.hx, hist.hy, hist.hj, threads, walls, hist.hu,
                      law, extra, last, hist.he, hist.hg, t0=t0 + done * 2.0 * p.hh,
                      zeta=zeta)
        else:
            ens.advance(xs, ys, rng, starts, n, step0 + done, sample_every, p, ip, mom,
                        imp, xext, hist.hH, hist.hx, hist.hy, hist.hj, threads, walls,
                        hist.hu, law, extra, last, hist.he, hist.hg,
                        t0=t0 + done * 2.0 * p.hh, zeta=zeta)
        done += n
        f0, f1 = done_frac
        g = done / n_steps if frac is None else frac(done)
        progress.update(f0 + (f1 - f0) * min(max(g, 0.0), 1.0), label)
        if stop is not None and stop():
            break
    return done


def _ensemble(system, opts, mode, xs, ys, child, zs=None):
    """(Ensemble or None, the device's name for ``info["device"]``): the option
    ``device`` resolved (:func:`._device.resolve`: "cuda" without a GPU is refused in
    one line); on "cuda" the paths (and their ζ, ``zs``) move to the GPU with a
    stream seeded from ``child``."""
    from . import _device
    where = f"montecarlo.{mode}"
    if _device.resolve(opts.device, where) == "cpu":
        return None, "cpu"
    from . import _cuda_engine
    from ._cuda_rng import seed_of
    return (_cuda_engine.Ensemble(system, xs, ys, seed_of(child), zs=zs),
            _device.describe()["gpu"])


def _initial_zeta(system, gen, n_paths):
    """The paths' starting ζ: the stationary law of the OU force, N(0, D1/τ),
    independent of (x, y), drawn after them (None for white noise)."""
    ou = system.external
    if ou is None:
        return None
    return math.sqrt(ou.variance(system.D1)) * gen.standard_normal(n_paths)


def _gap_range(extra: np.ndarray, t_burn: float) -> float:
    """The default range of the inter-impact time histogram: 1.5 × the longest gap of
    the burn-in, at least 10 × its mean gap (the burn-in length without gaps)."""
    n = extra[:, :, [K.X_GL, K.X_GR]].sum()
    if n == 0:
        return max(float(t_burn), 1e-12)
    mean = extra[:, :, [K.X_TL, K.X_TR]].sum() / n
    return max(1.5 * float(extra[:, :, K.X_GM].max()), 10.0 * float(mean), 1e-12)


def stationary(system: VibroImpactSystem, *, n_paths: int = 2048, dt: float | None = None,
               t_burn: float | None = None, t_sample: float | None = None,
               seed: int | np.random.SeedSequence | None = None,
               quantities: Sequence[str] = QUANTITIES, bins: int | dict = 100,
               n_batches: int = 32, target_rse: float = 0.005,
               max_t_sample: float | None = None, sample_every: int | None = None,
               max_impacts: int = 64, progress: bool | None = None,
               threads: int | None = None, device: str = "cpu") -> MonteCarloSolution:
    """Stationary densities and moments by time-and-ensemble averages (docs/theory.md, §Monte Carlo).

    Parameters
    ----------
    system : VibroImpactSystem
        With coloured external noise (``external=OrnsteinUhlenbeck(tau=τ)``,
        :mod:`fpk_vibro.noise`) each path also carries its force ζ, started from
        ζ's stationary law N(0, D1/τ) independently of (x, y) and advanced exactly
        (:mod:`fpk_vibro.montecarlo`, §Coloured noise); the densities and moments are
        of (x, y) (ζ marginalised), and :meth:`~MonteCarloSolution.coloured_moments`
        gives E[ζ²] and E[ζ y], the power ζ puts in (the input of
        :meth:`~MonteCarloSolution.power_balance`).
    n_paths : int, default 2048
        Independent paths, split into ``n_batches`` batches (one random stream
        each; standard errors from the spread between batches).
    dt : float, optional
        Time step; default the smallest step the system's time scales allow
        (:func:`._setup.step_bounds`): T0/120 with T0 = 2π/ω0, ω0² = |a| + |b|X²,
        X the amplitude at 5 energy scales D1/c, at most Δ (the paper's case: X =
        Δ, dt ≈ 0.05, where halving dt moves E[H] by < 0.05 %, measured); 1/(10 c);
        the noise time E/D over 4; the time L/v to cross the strip at the typical
        speed over a divisor from 1/8 (elastic walls) to 256 (r = 0 where noise
        moves paths off the wall).  Must be ≤ 1/ω_max, ω_max² = |a| + 3|b|X², X at
        30 energy scales, and at most 8 × each of the other scales' steps
        (InputError naming the scale); a default step whose run would exceed the
        budget (:mod:`fpk_vibro.budget`) is refused naming the scale and the cost.
        For an adaptive run (no ``t_sample``) with ``target_rse`` below 1e-3 the
        default shrinks as sqrt(target_rse/1e-3), keeping the O(dt²) bias at
        about 0.4 × the target: the largest bias measured, E[x²] at r = 0.98
        against FE, is 65, 17, 5.4 and 3.0 (each ±1) × 1e-4 relative at 4, 2, 1
        and ½ × T0/120 (second order: ratios 3.8, 3.2); E[H] at r = 0.92 is
        below 2.5e-4 at T0/120.
    t_burn : float, optional
        Burn-in per path before sampling; default 6/λ with λ the slowest energy
        relaxation rate (λ = c, or the impact loss rate (1 − r²)/T0 when c = 0;
        with c > 2 ω0 the overdamped rate ≈ ω0²/c).
    t_sample : float, optional
        Sampled time per path.  Default None: sample until the relative standard
        error of E[H] is ≤ ``target_rse`` (checked every chunk of ~8·10⁶
        path-steps, at least 1/λ and at most ``max_t_sample``, default 10⁴/λ).
    seed : int, SeedSequence or None
        Same seed → bit-identical result whatever the number of threads.  None
        draws fresh entropy (recorded in ``solution.seed_entropy``).
    quantities : sequence of {"energy", "x", "y", "joint", "impacts", "impact_energy", "inter_impact"}
        Histograms to accumulate (moments and per-wall impact statistics are always
        accumulated); default the four of the state.  Only when asked (each needs a
        wall): "impacts" counts the speed just before every impact in a histogram per
        wall (:meth:`~MonteCarloSolution.impact_speed_histogram`,
        :meth:`~MonteCarloSolution.impact_speed_pdf`); "impact_energy" the energy
        each impact removes, ½ (1 − r(u)²) u², per wall
        (:meth:`~MonteCarloSolution.impact_energy_pdf`); "inter_impact" the time
        between successive impacts of a path, any wall
        (:meth:`~MonteCarloSolution.inter_impact_pdf`,
        :meth:`~MonteCarloSolution.mean_inter_impact_time`, per wall pair in
        :meth:`~MonteCarloSolution.inter_impact`).
    bins : int or dict, default 100
        n → n bins for H, x, y and n//2 × n//2 for the joint histogram; or a dict
        ``{quantity: count or equally spaced edges}`` (joint: a pair; impacts: edges
        from 0, shared by the walls).  Default
        ranges: x over the strip x_L..x_R, a side without wall cut at the reach of
        H_max (where G = H_max), H up to
        H_max = max(1.5 × largest, 10 × mean) burned-in energy, y to ±sqrt(2 H_max),
        the impact speed at wall w from 0 to sqrt(2 (H_max − G(x_w))).
    n_batches : int, default 32
    target_rse : float, default 0.005
        Relative standard error of E[H] at which an adaptive run stops.
    max_t_sample : float, optional
    sample_every : int, optional
        Steps between samples of each path; default about T0/4 in time.
    max_impacts : int, default 64
        Bound on the impacts handled in one free-flight sub-step (see the
        module docstring).
    progress : bool or None
        Progress line on stderr; None: only when stderr is a terminal (shown after
        2 s).
    threads : int, optional
        Worker threads over the batches; default :func:`numba.get_num_threads`
        (all cores unless set otherwise).  The result does not depend on it.
    device : {"cpu", "cuda", "auto"}, default "cpu"
        "cuda": the paths run on an NVIDIA GPU (:mod:`._cuda_engine`; needs the
        ``gpu`` extra), in launches of bounded size, with the same estimators and
        result type (``info["device"]`` names the GPU); its random streams differ
        from the CPU's, so the numbers agree within their standard errors.  "auto":
        the GPU when one is usable, else the CPU.  Without a GPU "cuda" is refused
        in one line.

    Returns
    -------
    MonteCarloSolution
        With ``partial = True`` if interrupted by Ctrl-C during sampling (holds
        the samples taken so far).  Per-wall impact statistics over the sampled
        time in :meth:`~MonteCarloSolution.impacts` (also ``info["impacts"]``),
        E[x] in :meth:`~MonteCarloSolution.mean_x`.

    Raises
    ------
    ValueError
        For an invalid argument (naming it, the allowed range and the value),
        before any simulation.
    """
    opts, _ = Options.prepare(system, "stationary", locals())
    r = opts.resolved(system, "stationary")
    n_paths, n_batches, t_sample, target_rse = (opts.n_paths, opts.n_batches, opts.t_sample,
                                                opts.target_rse)
    dt, lam, t_burn, max_t_sample, sample_every = (r["dt"], r["lam"], r["t_burn"],
                                                   r["max_t_sample"], r["sample_every"])
    ss = S.seed_sequence(opts.seed)
    quantities, max_impacts, threads = opts.quantities, opts.max_impacts, opts.threads
    bins = S.check_bins("bins", opts.bins, None)
    progress = opts.progress

    children = ss.spawn(n_batches + 1)
    rng = S.rng_states(children[:n_batches])
    gen = np.random.default_rng(children[n_batches])
    starts = S.block_starts(n_paths, n_batches)
    xs = np.full(n_paths, S.initial_x(system))
    ys = math.sqrt(S.energy_scale(system)) * gen.standard_normal(n_paths)
    zs = _initial_zeta(system, gen, n_paths)
    ens, device = _ensemble(system, opts, "stationary", xs, ys, children[0], zs)
    p, ip = S.step_params(system, dt, max_impacts)
    law = S.wall_laws(system)
    mom = np.zeros((n_batches, K.NM))
    imp = np.zeros((n_batches, 2))
    wimp = np.zeros((n_batches, 2, K.NW))
    extra = np.zeros((n_batches, 2, K.NX))
    # each path's last impact (time, wall), tracked from the burn-in on: every impact
    # sampled then has the gap before it (:mod:`._summary`)
    last = (np.tile([-np.inf, 0.0], (n_paths, 1)) if ens is None else True) \
        if "inter_impact" in quantities else None
    xext = np.tile([np.inf, -np.inf], (n_batches, 1))
    none = S.Histograms(system, (), bins, n_batches, 1.0)
    prog = S.Progress(progress, "stationary")
    n_burn = math.ceil(t_burn / dt - 1e-9)
    try:
        _run_chunks(xs, ys, rng, starts, n_burn, 0, 0, p, ip, mom, imp, xext, none,
                    n_paths, prog, "burn-in", (0.0, 0.1), threads=threads, law=law,
                    extra=extra, last=last, ens=ens, zeta=zs)
    except KeyboardInterrupt:
        prog.close("(interrupted during burn-in: nothing sampled)")
        raise
    H = system.energy(xs, ys)
    gmin = S.potential_min(system)
    H_max = gmin + max(1.5 * (H.max() - gmin), 10.0 * (H.mean() - gmin))
    hist = S.Histograms(system, quantities, bins, n_batches, H_max,
                        _gap_range(extra, t_burn))
    p = hist.with_bins(p)
    imp[:] = 0.0
    wimp[:] = 0.0
    extra[:] = 0.0
    adaptive = t_sample is None
    n_samp = math.ceil((max_t_sample if adaptive else t_sample) / dt - 1e-9)
    n_min = math.ceil(1.0 / (lam * dt)) if adaptive else n_samp

    def reached() -> bool:
        if not adaptive:
            return False
        done = imp[:, 1].sum() / n_paths
        if done < n_min or mom[:, K.M_N].sum() == 0:
            return False
        est, se = _ratio(mom[:, [K.M_H]], mom[:, K.M_N])
        return bool(se[0] <= target_rse * abs(est[0]))

    def fraction(done: int) -> float:
        if not adaptive or mom[:, K.M_N].sum() == 0:
            return done / n_samp
        est, se = _ratio(mom[:, [K.M_H]], mom[:, K.M_N])
        # the standard error falls like 1/sqrt(time): fraction of the time needed
        need = (se[0] / (target_rse * abs(est[0]))) ** 2 if est[0] != 0 else math.inf
        return max(done / n_samp, min(1.0, 1.0 / need) if need > 0 else 1.0)

    partial = False
    try:
        _run_chunks(xs, ys, rng, starts, n_samp, 0, sample_every, p, ip, mom, imp, xext,
                    hist, n_paths, prog, "sampling", (0.1, 1.0), stop=reached,
                    frac=fraction, threads=threads, walls=wimp, law=law, extra=extra,
                    last=last, ens=ens, zeta=zs)
    except KeyboardInterrupt:
        partial = True
        interruption_note("\n[montecarlo] interrupted: returning the samples taken so far "
                          "(solution.partial = True)")
    if partial and mom[:, K.M_N].sum() == 0:
        raise KeyboardInterrupt("montecarlo.stationary interrupted before any sample")
    prog.close()
    _check_finite("stationary", mom, xs, ys, dt, sample_every)
    t_done = float(imp[:, 1].sum() / n_paths * dt)
    meta = dict(n_paths=n_paths, n_batches=n_batches, t_burn=float(n_burn * dt),
                t_sample=t_done, time=None, seed_entropy=ss.entropy, partial=partial,
                sample_every=sample_every, quantities=list(quantities),
                mode=system.barriers, target_rse=target_rse if adaptive else None,
                spawn_key=list(ss.spawn_key), device=device)
    sol = _reduce(system, hist, mom, imp, xext, dt, meta, wimp, extra)
    sol._progress = progress           # the estimate's second run shows it the same way
    return sol


MonteCarloSolution.rerun = staticmethod(stationary)
MonteCarloSolution.rerun_paired = staticmethod(stationary_pairs)


def transient(system: VibroImpactSystem, *, initial: Any, times: Sequence[float],
              n_paths: int = 4096, dt: float | None = None,
              seed: int | np.random.SeedSequence | None = None,
              quantities: Sequence[str] = QUANTITIES, bins: int | dict = 60,
              n_batches: int = 32, max_impacts: int = 64,
              progress: bool | None = None, threads: int | None = None,
              device: str = "cpu") -> TransientRun:
    """Ensemble densities at given times from an initial density (docs/theory.md, §Monte Carlo).

    Parameters
    ----------
    system : VibroImpactSystem
        With coloured external noise, as in :func:`stationary`.
    initial : dict or callable
        At t = 0 (a forced system's phase there is φ0):
        ``{"mean": (x0, y0), "std": (sx, sy)}`` (x truncated to the strip, std 0 =
        exactly that value) or ``initial(n, rng)`` returning samples; see
        :mod:`fpk_vibro.initial`.  It describes (x, y) only: with coloured noise each
        path's ζ starts from its stationary law N(0, D1/τ), independent of (x, y)
        (the force has been acting since long before t = 0).
    times : sequence of float
        Increasing times ≥ 0 (0 gives the initial ensemble).  Each interval is
        split into equal steps of at most ``dt``, so every time is hit exactly.
    n_paths : int, default 4096
    dt : float, optional
        Largest time step; default as in :func:`stationary`.
    seed, quantities, n_batches, max_impacts, progress, threads, device
        As in :func:`stationary` ("impacts", "impact_energy" and "inter_impact"
        excepted: stationary only).
    bins : int or dict, default 60
        As in :func:`stationary`; default ranges follow the ensemble at each time
        (H up to its largest value, so nothing overflows).

    Returns
    -------
    TransientRun
        A list with one :class:`MonteCarloSolution` per time (``time``,
        ``impact_rate`` and per-wall :meth:`~MonteCarloSolution.impacts` over the
        interval ending there); ``partial`` True and
        fewer entries if interrupted by Ctrl-C.  Each one's ``error_estimate()``
        adds the time-step bias from one second transient at 2 dt (dt/2 where 2 dt
        is refused) with the same initial ensemble and seed, made on the first
        estimate asked of any time and shared by all (:mod:`.estimate`; none for an
        interrupted run).
    """
    tarr = parse_times(times, "montecarlo.transient")
    opts, _ = Options.prepare(system, "transient", locals(), times=tarr)
    n_paths, n_batches, dt = opts.n_paths, opts.n_batches, opts.resolved(system, "transient")["dt"]
    ss = S.seed_sequence(opts.seed)
    family = dict(entropy=ss.entropy, spawn_key=ss.spawn_key, pool_size=ss.pool_size,
                  n_children_spawned=ss.n_children_spawned)   # the same streams again
    quantities, max_impacts, threads = opts.quantities, opts.max_impacts, opts.threads
    bins = S.check_bins("bins", opts.bins, None)
    progress = opts.progress
    init = parse_initial(initial, system)

    children = ss.spawn(n_batches + 1)
    rng = S.rng_states(children[:n_batches])
    gen = np.random.default_rng(children[n_batches])
    starts = S.block_starts(n_paths, n_batches)
    xs, ys = init.sample(n_paths, gen)
    xs, ys = np.ascontiguousarray(xs, dtype=float), np.ascontiguousarray(ys, dtype=float)
    zs = _initial_zeta(system, gen, n_paths)
    ens, device = _ensemble(system, opts, "transient", xs, ys, children[0], zs)
    none = S.Histograms(system, (), bins, n_batches, 1.0)
    law = S.wall_laws(system)
    gmin = S.potential_min(system)
    prog = S.Progress(progress, "transient")
    out = TransientRun()
    out.times_requested = tuple(float(t) for t in tarr)
    t_now = 0.0
    steps = []                                  # (interval, its step) per time
    try:
        for t in tarr:
            n = math.ceil((t - t_now) / dt - 1e-9)
            h = (t - t_now) / n if n > 0 else dt
            tau = float(t) - t_now
            p, ip = S.step_params(system, h, max_impacts)
            imp = np.zeros((n_batches, 2))
            wimp = np.zeros((n_batches, 2, K.NW))
            extra = np.zeros((n_batches, 2, K.NX))
            mom = np.zeros((n_batches, K.NM))
            xext = np.tile([np.inf, -np.inf], (n_batches, 1))
            frac = (t_now / tarr[-1], t / tarr[-1]) if tarr[-1] > 0 else (0.0, 1.0)
            _run_chunks(xs, ys, rng, starts, n, 0, 0, p, ip, mom, imp, xext, none,
                        n_paths, prog, f"t={t:g}", frac, threads=threads, walls=wimp,
                        law=law, extra=extra, ens=ens, t0=t_now, zeta=zs)
            t_now = float(t)
            H = system.energy(xs, ys)
            H_max = float(H.max())
            H_max = H_max + max(1e-9 * abs(H_max - gmin), 1e-12)
            hist = S.Histograms(system, quantities, bins, n_batches, H_max)
            p = hist.with_bins(p)
            K.snapshot(xs, ys, starts, p, mom, xext, hist.hH, hist.hx, hist.hy, hist.hj, zs)
            _check_finite("transient", mom, xs, ys, h, 0)
            meta = dict(n_paths=n_paths, n_batches=n_batches, t_burn=0.0, t_sample=0.0,
                        time=t_now, seed_entropy=ss.entropy, partial=False,
                        sample_every=0, quantities=list(quantities), mode=system.barriers,
                        initial=init.describe(), spawn_key=list(ss.spawn_key),
                        device=device)
            out.append(_reduce(system, hist, mom, imp, xext, h, meta, wimp, extra))
            steps.append((tau, h))
    except KeyboardInterrupt:
        out.partial = True
        interruption_note(f"\n[montecarlo] interrupted: returning {len(out)} of {tarr.size} "
                          "times (run.partial = True)")
    prog.close()
    if not out.partial:

        def again(dt2: float) -> TransientRun:
            return transient(system, initial=initial, times=tarr, n_paths=n_paths, dt=dt2,
                             seed=np.random.SeedSequence(**family), quantities=(),
                             n_batches=n_batches, max_impacts=max_impacts,
                             progress=progress, threads=threads, device=opts.device)

        sources = shared_second_run(again, dt, steps)
        for sol, source in zip(out, sources):
            sol._second_run = source     # the estimate's bias run (.estimate), made once
    return out
