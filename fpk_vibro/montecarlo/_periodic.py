"""The periodic response by Monte Carlo: :func:`periodic` (docs/theory.md, §Harmonic forcing).

Paths start as the stationary run's do (x at 0, y Gaussian at the energy scale) at
t = 0 (phase φ0) and are burned in for whole periods: 12 relaxation times 12/λ (λ the
stationary run's energy relaxation rate: c, or the impact loss rate where c = 0),
rounded up to periods.  The forced mean's transient decays at half the energy's rate
(e^{−ct/2} for the linear oscillator), so the stationary 6/λ left e⁻³ ≈ 5 % of the
mean amplitude (a 5 % low amplitude at resonance, c = 0.05); 12/λ leaves e⁻⁶ ≈ 0.25 %
(:data:`.options.FORCED_BURN`).  Then every period is sampled on the grid of :mod:`._periodic_grid`: each
requested phase averages over its bin (``phase_bin``), the period average samples
``N_HARM`` equally spaced phases of every period, and E[x] at those phases gives the
first harmonic x̄ + A cos(φ − θ) by the discrete Fourier coefficients.  Standard
errors come from the spread between batches of paths (independent streams), for A
and θ through the batches' own Fourier coefficients (delta method).
"""
from __future__ import annotations

import math
import time
import types
from typing import Any

import numpy as np

from .._checks import InputError
from ..forcing import TWO_PI, check_phases, first_harmonic
from ..model import VibroImpactSystem
from ..periodic import PeriodicResponse
from . import _kernel as K
from . import _setup as S
from ._engine import _ensemble, _run_chunks
from ._flight import LEFT, NX, RIGHT, W_N, W_Q, W_U, X_E
from ._periodic_grid import N_HARM, Slots
from ._summary import _check_finite, _ratio, _reduce
from .estimate import bias_factor, interruption_note, second_run
from .options import Options
from .solution import QUANTITIES

__all__ = ["periodic"]


def _combine(arr: np.ndarray, weights: dict[int, float], nb: int) -> np.ndarray:
    """Σ_s w_s arr[s·nb : (s+1)·nb] (the rows of slot s)."""
    return sum(w * arr[s * nb:(s + 1) * nb] for s, w in weights.items())


def _harmonic(mh: np.ndarray, K_: int, nb: int, phi0: float) -> dict[str, float]:
    """x̄, A, θ of E[x] at K_ equally spaced phases, with SE between batches."""
    sx = mh[:, K.M_X].reshape(K_, nb)
    sn = mh[:, K.M_N].reshape(K_, nb)
    ph = phi0 + TWO_PI * np.arange(K_) / K_
    ex = sx.sum(axis=1) / sn.sum(axis=1)
    m, A, th = first_harmonic(ph, ex)
    cs, sn_ = 2.0 / K_ * np.cos(ph), 2.0 / K_ * np.sin(ph)
    c, s = float(ex @ cs), float(ex @ sn_)
    with np.errstate(invalid="ignore", divide="ignore"):
        exb = sx / sn                                  # [phase, batch]
    nb_w = sn.sum(axis=0) / sn.sum()
    dev = np.stack([exb.mean(axis=0) - m, cs @ exb - c, sn_ @ exb - s])
    B = nb
    cov = B / (B - 1) * (nb_w ** 2 * dev) @ dev.T
    vm, vc, vs, vcs = cov[0, 0], cov[1, 1], cov[2, 2], cov[1, 2]
    A2 = max(A * A, 1e-300)
    var_A = (c * c * vc + s * s * vs + 2 * c * s * vcs) / A2
    var_t = (s * s * vc + c * c * vs - 2 * c * s * vcs) / (A2 * A2)
    return {"mean_x": m, "amplitude": A, "lag": th, "mean_x_se": math.sqrt(max(vm, 0.0)),
            "amplitude_se": math.sqrt(max(var_A, 0.0)), "lag_se": math.sqrt(max(var_t, 0.0))}


def _impacts_of(w: dict[int, float], pimp: np.ndarray, nb: int):
    """The per-block arrays _reduce takes (imp, wimp, extra) for one phase bin."""
    p = _combine(pimp, w, nb)                           # [b, side, 5]
    wimp = np.zeros((nb, 2, K.NW))
    extra = np.zeros((nb, 2, NX))
    for side in (LEFT, RIGHT):
        wimp[:, side, W_N] = p[:, side, 0]
        wimp[:, side, W_U] = p[:, side, 1]
        wimp[:, side, W_Q] = p[:, side, 2]
        extra[:, side, X_E] = p[:, side, 3]
    imp = np.stack([p[:, 0, 0] + p[:, 1, 0], p[:, 0, 4]], axis=1)
    return imp, wimp, extra


def periodic(system: VibroImpactSystem, phases: Any, *, n_paths: int = 2048,
             dt: float | None = None, phase_bin: float = TWO_PI / 64,
             n_periods: int | None = None, burn_periods: int | None = None,
             seed: int | np.random.SeedSequence | None = None,
             quantities: Any = QUANTITIES, bins: int | dict = 60, n_batches: int = 32,
             max_impacts: int = 64, progress: bool | None = None,
             threads: int | None = None, device: str = "cpu",
             _steps: int | None = None) -> PeriodicResponse:
    """The periodic response to harmonic plus random excitation, phase by phase.

    Parameters
    ----------
    system : VibroImpactSystem
        With ``forcing`` (:class:`fpk_vibro.Harmonic`).
    phases : sequence of float
        Phases φ = (Ωt + φ0) mod 2π in radians in [0, 2π) at which the density is
        wanted.
    n_paths : int, default 2048
    dt : float, optional
        Largest time step; the period is cut into M equal steps h = T/M ≤ dt, M a
        multiple of 16 (and of the phases' common divisor, so that equally spaced
        phases fall on the grid).  Default as in :func:`stationary`.
    phase_bin : float, default 2π/64
        Each phase's statistics average over the bin [φ − w/2, φ + w/2] (the
        piecewise-linear interpolant of the sampled instants, :mod:`._periodic_grid`):
        a smooth m(φ) is seen as m(φ) + m''(φ) w²/24, the first harmonic's amplitude
        times sin(w/2)/(w/2) (1 − 4·10⁻⁴ at the default).  0: the point value
        (interpolated linearly between the grid's instants).  At most π/4.
    n_periods : int, optional
        Sampled periods per path; default the larger of 64 and 40 relaxation times.
    burn_periods : int, optional
        Burn-in in periods; default 12/λ (λ the slowest energy relaxation rate,
        :func:`stationary`; the forced mean relaxes at λ/2, so 6 of its e-folds)
        rounded up to whole periods.
    seed, bins, n_batches, max_impacts, progress, threads
        As in :func:`stationary` (``bins`` default 60).
    quantities : sequence of {"energy", "x", "y", "joint"}
        Histograms of each phase and of the average.
    device : {"cpu", "cuda", "auto"}
        As in :func:`stationary`: on "cuda" each path is a GPU thread sampling the
        same phase slots (:mod:`._cuda_periodic`); its streams differ from the CPU's,
        so the numbers agree within their standard errors.

    Returns
    -------
    PeriodicResponse
        ``at(i)`` a :class:`MonteCarloSolution` per phase (moments with SE,
        histograms, per-wall impact rates of the bin), ``average()`` the period
        average (sampled at 16 equally spaced phases of every period), ``amplitude``
        and ``lag`` of E[x] (SE in ``info``), ``error_estimate()``: 2 SE + the
        time-step bias from one second run at 2 dt (or dt/2) shared by all.
        ``partial`` True if Ctrl-C stopped the sampling (the periods finished are
        kept; no bias run then).
    """
    where = "montecarlo.periodic"
    phases = check_phases(where, phases)
    if getattr(system, "forcing", None) is None:
        raise InputError(f"{where}: system: a forced system (forcing=Harmonic(...)); got "
                         "one without forcing (use montecarlo.stationary)", where=where,
                         name="system")
    opts, _ = Options.prepare(system, "periodic", locals())
    fo = system.forcing
    T, phi0 = fo.period, fo.phase
    n_paths, n_batches, nb = opts.n_paths, opts.n_batches, opts.n_batches
    plan = opts.periodic_plan(system, phases)
    M = _steps if _steps is not None else plan["M"]
    h = T / M
    n_per, n_burn_per = plan["n_periods"], plan["burn_periods"]
    quantities = opts.quantities
    bins = S.check_bins("bins", opts.bins, None)
    ss = S.seed_sequence(opts.seed)
    family = dict(entropy=ss.entropy, spawn_key=ss.spawn_key, pool_size=ss.pool_size,
                  n_children_spawned=ss.n_children_spawned)
    children = ss.spawn(nb + 1)
    rng = S.rng_states(children[:nb])
    gen = np.random.default_rng(children[nb])
    starts = S.block_starts(n_paths, nb)
    xs = np.full(n_paths, S.initial_x(system))
    ys = math.sqrt(S.energy_scale(system)) * gen.standard_normal(n_paths)
    ens, device = _ensemble(system, opts, "periodic", xs, ys, children[0])
    p, ip = S.step_params(system, h, opts.max_impacts)
    law = S.wall_laws(system)
    slots = Slots(phases, phi0, M, float(opts.phase_bin))
    K_ = math.gcd(M, N_HARM)
    s_avg = M // K_
    rows = (slots.n_inst + 1) * nb
    prog = S.Progress(opts.progress, "periodic")
    none = S.Histograms(system, (), bins, nb, 1.0)
    junk = (np.zeros((nb, K.NM)), np.zeros((nb, 2)), np.tile([np.inf, -np.inf], (nb, 1)))
    try:
        _run_chunks(xs, ys, rng, starts, n_burn_per * M, 0, 0, p, ip, *junk, none,
                    n_paths, prog, "burn-in", (0.0, 0.1), threads=opts.threads, law=law,
                    ens=ens)
    except KeyboardInterrupt:
        prog.close("(interrupted during burn-in: nothing sampled)")
        raise
    H = system.energy(xs, ys)
    gmin = S.potential_min(system)
    H_max = gmin + max(1.5 * (H.max() - gmin), 10.0 * (H.mean() - gmin))
    hist = S.Histograms(system, quantities, bins, rows, H_max)
    p = hist.with_bins(p)
    mom = np.zeros((rows, K.NM))
    xext = np.tile([np.inf, -np.inf], (rows, 1))
    imp = np.zeros((nb, 2))
    wimp = np.zeros((nb, 2, K.NW))
    extra = np.zeros((nb, 2, K.NX))
    mh = np.zeros((K_ * nb, K.NM))
    xeh = np.tile([np.inf, -np.inf], (K_ * nb, 1))
    pimp = np.zeros((slots.n_steps * nb, 2, 5))
    tables = (M, slots.slot_of, slots.step_slot, s_avg, mh, xeh, pimp)
    partial = False
    per = S.CHUNK_PATH_STEPS if ens is None else ens.chunk_path_steps
    chunk = max(M, per // max(n_paths, 1) // M * M)
    advance = K.advance if ens is None else ens.advance
    done, total = 0, n_per * M
    try:
        while done < total:
            n = min(chunk, total - done)
            advance(xs, ys, rng, starts, n, done % M, 0, p, ip, mom, imp, xext, hist.hH,
                      hist.hx, hist.hy, hist.hj, opts.threads, wimp, None, law, extra,
                      t0=(done % M) * h, periodic=tables)
            done += n
            prog.update(0.1 + 0.9 * done / total, "sampling")
    except KeyboardInterrupt:
        partial = True
        interruption_note("\n[montecarlo] interrupted: returning the periods sampled so "
                          "far (response.partial = True)")
    if mom[-nb:, K.M_N].sum() == 0:
        raise KeyboardInterrupt(f"{where} interrupted before any sample")
    prog.close()
    _check_finite("periodic", mom[-nb:], xs, ys, h, s_avg)
    meta = dict(n_paths=n_paths, n_batches=nb, t_burn=float(n_burn_per * T),
                t_sample=float(done * h), time=None, seed_entropy=ss.entropy,
                partial=partial, sample_every=s_avg, quantities=list(quantities),
                mode=system.barriers, spawn_key=list(ss.spawn_key), device=device,
                phase_bin=float(opts.phase_bin))

    def view(rows_w: dict[int, float]):
        return types.SimpleNamespace(
            edges=hist.edges, **{k: _combine(getattr(hist, k), rows_w, nb)
                                 for k in ("hH", "hx", "hy", "hj")})

    sols = []
    for i, ph in enumerate(phases):
        w = slots.inst[i]
        used = np.concatenate([xext[s * nb:(s + 1) * nb] for s in w])
        xe = np.tile([used[:, 0].min(), used[:, 1].max()], (nb, 1))
        imp_i, wimp_i, extra_i = _impacts_of(slots.steps[i], pimp, nb)
        sol = _reduce(system, view(w), _combine(mom, w, nb), imp_i, xe, h,
                      dict(meta, periodic="phase", phase=float(ph)), wimp_i, extra_i)
        sols.append(sol)
    avg_w = {slots.n_inst: 1.0}
    avg = _reduce(system, view(avg_w), _combine(mom, avg_w, nb), imp, xext[-nb:], h,
                  dict(meta, periodic="average"), wimp, extra)
    harm = _harmonic(mh, K_, nb, phi0)
    info = dict(steps_per_period=M, dt=h, n_periods=int(done // M),
                burn_periods=int(n_burn_per), phase_bin=float(opts.phase_bin),
                harmonic_points=K_, seed_entropy=ss.entropy, n_paths=n_paths,
                n_batches=nb, partial=partial,
                **{k: harm[k] for k in ("mean_x_se", "amplitude_se", "lag_se")})
    out = PeriodicResponse("montecarlo", system, phases, sols, avg,
                           amplitude=harm["amplitude"], lag=harm["lag"],
                           mean_x=harm["mean_x"], info=info)
    out.partial = partial
    out._harm = harm
    if partial:
        out._harmonic_estimate = {k: 2.0 * harm[f"{k}_se"] for k in
                                  ("mean_x", "amplitude", "lag")} | {
            "assumes": "2 standard errors only: an interrupted run has no bias run"}
        return out

    def again(h2: float) -> PeriodicResponse:
        M2 = max(N_HARM // 2, round(T / h2))
        return periodic(system, phases, n_paths=n_paths, dt=T / M2 * (1 + 1e-12),
                        phase_bin=opts.phase_bin, n_periods=n_per,
                        burn_periods=n_burn_per, seed=np.random.SeedSequence(**family),
                        quantities=(), n_batches=nb, max_impacts=opts.max_impacts,
                        progress=opts.progress, threads=opts.threads, device=opts.device,
                        _steps=M2)

    _attach_estimate(out, again, h)
    return out


def _attach_estimate(out: PeriodicResponse, again, h: float) -> None:
    """One second run at 2 dt (dt/2 where refused) shared by the phases, the average
    and the harmonic (made on the first estimate asked of any)."""
    cache: dict[str, Any] = {}

    def once():
        if "run" not in cache:
            t0 = time.perf_counter()
            other, step = second_run(again, h, kept="the answer (all phases)")
            h2 = other.info["dt"]
            cache["run"] = (other, bias_factor([(1.0, h)], [h2]), step,
                            time.perf_counter() - t0)
        return cache["run"]

    def member(i: int | None):
        def source():
            other, f, step, sec = once()
            return (other.average() if i is None else other.at(i)), f, step, sec
        return source

    for i, sol in enumerate(out._solutions):
        sol._second_run = member(i)
    out._average._second_run = member(None)

    def harmonic_estimate() -> dict[str, Any]:
        other, f, step, sec = once()
        h1, h2 = out._harm, other._harm
        est: dict[str, Any] = {}
        for k in ("mean_x", "amplitude", "lag"):
            d = h1[k] - h2[k]
            if k == "lag":
                d = (d + math.pi) % TWO_PI - math.pi
            d_se = math.hypot(h1[f"{k}_se"], h2[f"{k}_se"])
            est[k] = 2.0 * h1[f"{k}_se"] + abs(f * d) + 2.0 * abs(f) * d_se
            est[f"{k}_bias"] = f * d
        est["assumes"] = (f"2 standard errors plus the time-step bias from a run at {step} "
                          "(O(dt²) scheme) and twice its standard error; absolute (lag in "
                          "radians)")
        est["seconds"] = sec
        return est

    out._harmonic_estimate = harmonic_estimate
