"""Monte Carlo on an NVIDIA GPU (numba-cuda): the host side of :mod:`._cuda_kernels`.

- :class:`Ensemble`: the paths of a stationary or transient run, resident on the GPU
  (40 bytes a path, 64 with a paired run), advanced by :meth:`Ensemble.advance`, which
  takes the arguments of the CPU's :func:`._kernel.advance` and adds into the same
  per-batch arrays, so :func:`._summary._reduce` turns them into the same
  :class:`MonteCarloSolution`.  Launches cover at most :data:`LAUNCH_THREADS` paths
  and about :data:`LAUNCH_PATH_STEPS` path-steps, so a launch is short whatever the
  size (progress, Ctrl-C between launches).
- ``paired=True``: each thread also carries a path at step 2h driven by the same
  normals (e^{−ch} z₁ + z₂, normalised: the exact OU coupling), sampled at the same
  times into its own arrays: the time-step bias run of ``error_estimate()``, in which
  the noise of the difference cancels (:func:`paired_bias`).
- :func:`first_passage`: paths run until they leave an energy, displacement or
  impact-speed safe set (:mod:`._cuda_fp`: each path its own stream, threads take
  the next path from a counter); no per-path memory (exit times go to a histogram on a grid:
  R(t) at its edges exactly, the mean and its SE from Σ T, Σ T²), so any number of
  paths fits, launched :data:`FP_LAUNCH_PATHS` at a time.
- :func:`steps_given`: the steps of given normals, for the tests' comparison with the
  CPU copy of the same functions.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _cuda_fp as CF
from . import _cuda_kernels as CK
from . import _setup as S
from ._device import simulator
from ._sampling import NM
from ._scalar_step import encode_walls

__all__ = ["Ensemble", "first_passage", "paired_bias", "steps_given", "LAUNCH_PATH_STEPS"]

#: Path-steps per stationary launch (about 0.1 s at 1e11 path-steps/s).
LAUNCH_PATH_STEPS = 1 << 33
#: Threads (paths) per stationary launch.
LAUNCH_THREADS = 1 << 24
#: Paths per first-passage launch, and the threads that run them.
FP_LAUNCH_PATHS = 1 << 26
FP_THREADS = 1 << 18
#: Threads per batch of the first-passage fold (:func:`._cuda_fp.kernel`).
FP_FOLD_PER_BATCH = 256
#: The first-passage kinds by name.
KINDS = {"energy": CK.FP_ENERGY, "displacement": CK.FP_DISPLACEMENT,
         "impact_speed": CK.FP_SPEED}


from ._cuda_launch import (LAUNCH_STEPS_MAX, THREADS_PER_BLOCK, _Deferred, _flat,  # noqa: E402,F401
                           _tpb, block_map)


class Ensemble:
    """The paths (xs, ys) on the GPU, with one xoroshiro128+ stream each.

    Parameters
    ----------
    system : VibroImpactSystem
    xs, ys : float64[n]
        Starting states (copied to the GPU).
    seed : int
        64-bit seed (:func:`._cuda_rng.seed_of`); path i draws from stream i
        (splitmix64 seeding, :func:`._cuda_rng.seed_py`, done on the GPU).
    paired : bool
        Also carry a path at 2h from the same state (:func:`paired_bias`).
    zs : float64[n], optional
        With coloured external noise: each path's starting force ζ (copied to the
        GPU; the kernels advance it, :func:`._cuda_kernels._make_stationary`).  Not
        with ``paired``.

    Each path also carries the time and wall of its last impact (from its start, so
    a gap after the burn-in reaches back into it, as on the CPU).
    """

    #: What the engine's chunk loop should give one call (path-steps).
    chunk_path_steps = 1 << 35

    def __init__(self, system, xs: np.ndarray, ys: np.ndarray, seed: int,
                 paired: bool = False, zs: np.ndarray | None = None) -> None:
        self.K = CK.kernels()
        nc = self.K.cuda
        self.n = int(xs.size)
        self.paired = paired
        walls = encode_walls(system)
        self.walls = tuple(nc.to_device(np.ascontiguousarray(w)) for w in walls)
        self.s0 = nc.device_array(self.n, dtype=np.uint64)
        self.s1 = nc.device_array(self.n, dtype=np.uint64)
        if self.n:
            tpb = _tpb()
            self.K.seed[(self.n + tpb - 1) // tpb, tpb](self.s0, self.s1,
                                                          np.uint64(seed % (1 << 64)), 0)
        self.x = nc.to_device(np.ascontiguousarray(xs, dtype=float))
        self.y = nc.to_device(np.ascontiguousarray(ys, dtype=float))
        self.tl = nc.to_device(np.full(self.n, -1.0))
        self.wl = nc.to_device(np.zeros(self.n, dtype=np.int8))
        if paired:
            self.xc = nc.to_device(np.ascontiguousarray(xs, dtype=float))
            self.yc = nc.to_device(np.ascontiguousarray(ys, dtype=float))
            self.tlc = nc.to_device(np.full(self.n, -1.0))
            self.wlc = nc.to_device(np.zeros(self.n, dtype=np.int8))
        else:
            self.xc, self.yc, self.tlc, self.wlc = self.x, self.y, self.tl, self.wl
        if (zs is not None) != (system.external is not None) or (zs is not None and paired):
            raise ValueError("Ensemble: zs (the paths' ζ) is given exactly for a coloured "
                             "system, and not with paired")
        self.coloured = zs is not None
        self.zt = nc.to_device(np.ascontiguousarray(zs, dtype=float) if self.coloured
                               else np.zeros(1))
        self.t = 0.0
        self._maps: dict = {}

    def _segments(self, starts: np.ndarray, tpb: int):
        """Per launch of at most LAUNCH_THREADS paths: (device batch of each block,
        device [first, end) of each block, device first block per batch)."""
        key = (starts.tobytes(), tpb, LAUNCH_THREADS)
        if key not in self._maps:
            nc = self.K.cuda
            self._maps = {key: [tuple(nc.to_device(a) for a in block_map(starts, i0, min(
                self.n, i0 + LAUNCH_THREADS), tpb)) for i0 in range(0, self.n, LAUNCH_THREADS)]}
        return self._maps[key]

    def _chunk(self, kern, segs, m, step0, sample_every, args, part, sums, tpb, tail=()):
        """Queue one chunk of m steps: every segment's launch, then its fold
        (``tail``: the kernel's last arguments, the forcing's)."""
        nk = sums.shape[0] * sums.shape[1]
        for blk_b, blk_i, bstart in segs:
            if blk_b.size == 0:
                continue
            kern[blk_b.size, tpb](*self._state, blk_b, blk_i, m, step0, sample_every,
                                  self.t, *args, *tail, self.zt)
            self.K.fold[(nk + 127) // 128, 128](part, bstart, sums)

    def advance(self, xs, ys, rng, starts, n_steps, step0, sample_every, p, ip, mom, imp,
                xext, hH, hx, hy, hj, threads=None, walls=None, speeds=None, law=None,
                extra=None, last=None, energies=None, gaps=None, t0=0.0, periodic=None,
                zeta=None, *, p2=None, out2=None) -> None:
        """:func:`._kernel.advance` on the GPU: the same arguments and sums (``rng``,
        ``threads`` and ``law`` unused: the streams and the laws live on the GPU);
        ``xs``, ``ys`` receive the new states; ``starts`` None: equal batches.

        ``walls[b, side]`` adds impacts, Σu, Σu² (and Σ energy lost, where it has a 4th
        column); ``extra[b, side, X_*]`` the CPU's further statistics (:mod:`._flight`:
        energy lost, the largest impact speed, and where ``last`` is given, any value,
        the gaps back to each path's previous impact per wall pair: the GPU tracks
        the last impact itself); ``speeds``, ``energies`` [nb, 2, m] and ``gaps``
        [nb, 1, m] the histograms of impact speeds, energy losses and gaps (bin widths
        from ``p``, as on the CPU).  Paired (:func:`paired_bias`): ``p2`` the step
        records at 2h and ``out2`` a dict of mom, imp, walls, xext, hH, hx, hy, hj,
        speeds, energies, gaps (and extra) for the 2h path; ``n_steps``, ``step0`` and
        ``sample_every`` must then be even.

        ``t0``: the time of the states on entry (with forcing, ``ip.forced``, step k
        of the call kicks with F cos(Ω (t0 + k h) + φ0), as on the CPU);
        ``periodic``: the CPU's phase-resolved sampling tables
        (:func:`._cuda_periodic.advance`); ``zeta``: with coloured noise, receives
        the paths' ζ (the GPU keeps its own copy, started from the ensemble's ``zs``).

        Ctrl-C: the chunks finished (and one already queued) are added to the sums,
        ``xs``/``ys`` receive the states, and the KeyboardInterrupt propagates.
        """
        if periodic is not None:
            from ._cuda_periodic import advance as advance_periodic
            return advance_periodic(self, xs, ys, starts, n_steps, step0, p, ip, mom, imp,
                                    xext, hH, hx, hy, hj, walls, extra, t0, periodic)
        nc = self.K.cuda
        nb = mom.shape[0]
        if self.paired and (n_steps % 2 or step0 % 2 or sample_every % 2):
            raise ValueError("a paired run takes even n_steps, step0 and sample_every")
        starts = S.block_starts(self.n, nb) if starts is None else np.asarray(starts)
        track = last is not None or (gaps is not None and gaps.shape[-1] > 0)
        f = _fill(nb, dict(walls=walls, speeds=speeds, energies=energies, gaps=gaps))
        host = [hH, hx, hy, hj, f["speeds"], f["energies"], f["gaps"]]
        dev = [nc.to_device(np.zeros_like(a)) for a in host]
        ks = 2 * CK.NSUM if self.paired else CK.NSUM
        sums = nc.to_device(np.zeros((nb, ks)))
        ext = nc.to_device(np.full((nb, CK.NEXT), -np.inf))
        if self.paired:
            o2 = _fill(nb, dict(out2))
            host2 = [o2[k] for k in ("hH", "hx", "hy", "hj", "speeds", "energies", "gaps")]
            dev2 = [nc.to_device(np.zeros_like(a)) for a in host2]
            ext2 = nc.to_device(np.full((nb, CK.NEXT), -np.inf))
            pf2 = nc.to_device(_flat(p2))
        else:
            host2, dev2, ext2, pf2 = None, dev, ext, None
        pf = nc.to_device(_flat(p))
        iwa = nc.to_device(np.array([p.u_iw_left, p.u_iw_right, p.e_iw_left, p.e_iw_right,
                                     p.g_iw, 1.0 if track else 0.0]))
        tpb = _tpb()
        segs = self._segments(starts, tpb)
        part = nc.device_array((max(int(sg[0].size) for sg in segs) if segs else 1, ks))
        forced = bool(getattr(ip, "forced", 0))
        kern = self.K.stationary(self.paired, track, *host,
                                 tuple(host2) if self.paired else (), forced=forced,
                                 coloured=self.coloured)
        fo = (float(p.f_amp), float(p.f_omega), float(p.f_phase), float(t0))
        self._state = (self.x, self.y, self.tl, self.wl, self.s0, self.s1, self.xc, self.yc,
                       self.tlc, self.wlc)
        args = (pf, pf if pf2 is None else pf2, int(ip.has_d2), int(ip.max_impacts),
                *self.walls, iwa, part, ext, *dev, ext2, *dev2)
        per = max(2, min(LAUNCH_STEPS_MAX, LAUNCH_PATH_STEPS // max(self.n, 1)) // 2 * 2)
        done = queued = 0
        try:
            while done < n_steps:
                m = min(per, n_steps - done)
                with _Deferred():
                    self._chunk(kern, segs, m, step0 + done, sample_every, args, part,
                                sums, tpb, fo + (done,))
                    queued = m
                nc.synchronize()
                done, queued = done + m, 0
                self.t += m * p.hh * 2.0
        except KeyboardInterrupt:
            nc.synchronize()            # a queued chunk has run: it counts
            done += queued
            self.t += queued * p.hh * 2.0
            raise
        finally:
            counts = np.diff(starts).astype(float)
            s, e = sums.copy_to_host(), ext.copy_to_host()
            _add_sums(s[:, :CK.NSUM], e, counts * done, mom, imp, xext, f["walls"], extra,
                      track)
            for a, d in zip(host, dev):
                a += d.copy_to_host()
            if self.paired:
                _add_sums(s[:, CK.NSUM:], ext2.copy_to_host(), counts * (done // 2),
                          o2["mom"], o2["imp"], o2["xext"], o2["walls"], o2.get("extra"),
                          track)
                for a, d in zip(host2, dev2):
                    a += d.copy_to_host()
            xs[:] = self.x.copy_to_host()
            ys[:] = self.y.copy_to_host()
            if zeta is not None and self.coloured:
                zeta[:] = self.zt.copy_to_host()

    def coarse_states(self) -> tuple[np.ndarray, np.ndarray]:
        """The states of the 2h paths (paired runs)."""
        return self.xc.copy_to_host(), self.yc.copy_to_host()


def _fill(nb: int, d: dict) -> dict:
    """``d`` with the absent optional arrays as empty (or throw-away) ones."""
    empty = {"walls": np.zeros((nb, 2, 4)), "speeds": np.zeros((nb, 2, 0)),
             "energies": np.zeros((nb, 2, 0)), "gaps": np.zeros((nb, 1, 0))}
    return {**d, **{k: v for k, v in empty.items() if d.get(k) is None}}


def _add_sums(s, e, path_steps, mom, imp, xext, walls, extra, track) -> None:
    """A run's per-batch device sums ``s`` [nb, NSUM] and maxima ``e`` [nb, NEXT]
    (:mod:`._cuda_kernels`) added into the CPU engine's arrays (:func:`._kernel.advance`)."""
    from ._flight import X_E, X_G0, X_GL, X_GM, X_GR, X_M, X_TL, X_TR
    mom += s[:, :NM]
    w = s[:, NM:NM + 8]
    imp[:, 0] += w[:, 0] + w[:, 4]
    imp[:, 1] += path_steps
    nw = min(walls.shape[2], 4)
    for side in (0, 1):
        walls[:, side, :nw] += w[:, 4 * side:4 * side + nw]
    xext[:, 0] = np.minimum(xext[:, 0], -e[:, 0])
    xext[:, 1] = np.maximum(xext[:, 1], e[:, 1])
    if extra is None:
        return
    g = s[:, NM + 8:NM + 18]
    for side in (0, 1):
        extra[:, side, X_E] += w[:, 4 * side + 3]
        if track:
            extra[:, side, [X_GL, X_TL, X_GR, X_TR, X_G0]] += g[:, 5 * side:5 * side + 5]
            extra[:, side, X_GM] = np.maximum(extra[:, side, X_GM], e[:, 3 + side])
    extra[:, 0, X_M] = np.maximum(extra[:, 0, X_M], e[:, 2])


def _sums(nb: int, nm: int = NM) -> dict[str, np.ndarray]:
    return {"mom": np.zeros((nb, nm)), "imp": np.zeros((nb, 2)),
            "walls": np.zeros((nb, 2, 4)),
            "xext": np.tile([np.inf, -np.inf], (nb, 1))}


def paired_bias(system, xs: np.ndarray, ys: np.ndarray, dt: float, seed: int,
                n_batches: int, n_burn: int, n_sample: int, sample_every: int,
                max_impacts: int = 64) -> dict[str, dict[str, np.ndarray]]:
    """Paths at dt and at 2 dt from the same states and the same normals: burn-in of
    ``n_burn`` fine steps, then ``n_sample`` sampled every ``sample_every`` (each
    rounded up to even).  Returns {"fine": sums, "coarse": sums}, each with ``mom``,
    ``imp``, ``walls``, ``xext`` per batch, as :func:`._summary._reduce` takes them
    (``imp`` counts each ensemble's own steps; the coarse path-time is the same).
    The batch-by-batch difference of any ratio estimate then has the noise of the
    difference of two coupled paths, not of two independent runs."""
    n_burn += n_burn % 2
    n_sample += n_sample % 2
    sample_every += sample_every % 2
    nb = n_batches
    p, ip = S.step_params(system, dt, max_impacts)
    p2, _ = S.step_params(system, 2.0 * dt, max_impacts)
    ens = Ensemble(system, xs, ys, seed, paired=True)
    xs, ys = xs.copy(), ys.copy()
    empty = {"hH": np.zeros((nb, 0)), "hx": np.zeros((nb, 0)), "hy": np.zeros((nb, 0)),
             "hj": np.zeros((nb, 0, 1))}
    fine, coarse = _sums(nb), _sums(nb)
    for n, every, keep in ((n_burn, 0, False), (n_sample, sample_every, True)):
        a, c = (fine, coarse) if keep else (_sums(nb), _sums(nb))
        ens.advance(xs, ys, None, None, n, 0, every, p, ip, a["mom"], a["imp"], a["xext"],
                    empty["hH"], empty["hx"], empty["hy"], empty["hj"], walls=a["walls"],
                    p2=p2, out2={**c, **empty})
    return {"fine": fine, "coarse": coarse}


def first_passage(system, kind: str, value: Any, x0s: np.ndarray, y0s: np.ndarray,
                  n_paths: int, dt: float, kmax: int, seed: int, grid_dt: float,
                  n_batches: int = 32, bridge: bool = True, max_impacts: int = 64,
                  progress=None) -> dict[str, Any]:
    """First passage out of a safe set on the GPU.

    Parameters
    ----------
    kind, value : str, float or (x_lo, x_hi)
        "energy" (H_c), "displacement" ((x_lo, x_hi)) or "impact_speed" (u_c).
    x0s, y0s : float64[m]
        Starts; path i starts from entry i % m.
    n_paths, dt, kmax : int, float, int
        Paths, step, horizon in steps (censored beyond).
    grid_dt : float
        Width of the exit-time bins: R(t) exact at t = k grid_dt, k ≤ kmax dt/grid_dt.
    progress : callable(fraction), optional

    Returns
    -------
    dict
        ``hist`` [n_batches, nbins + 1] exit counts per bin (last: beyond or censored),
        ``sums`` [n_batches, 6] Σ T (censored at the horizon), Σ T², exits, censored,
        path-steps, exits by the bridge; ``edges`` the bin edges; ``mean``,
        ``mean_se``, ``times``, ``survival`` (R at the edges), ``censored``;
        ``n_paths`` the paths run and ``partial``: True when Ctrl-C stopped the run
        between launches (the launches finished are kept, every statistic is over
        their ``n_paths``; interrupted before the first one ends, KeyboardInterrupt
        propagates).  Same seed, same numbers (:mod:`._cuda_fp`: Σ T and Σ T² are
        folded per path in a fixed order, the counts are exact).
    """
    K = CK.kernels()
    nc = K.cuda
    p, ip = S.step_params(system, dt, max_impacts)
    pf = nc.to_device(_flat(p))
    walls = tuple(nc.to_device(np.ascontiguousarray(w)) for w in encode_walls(system))
    hc, xlo, xhi, uc = math.inf, -math.inf, math.inf, math.inf
    if kind == "energy":
        hc = float(value)
    elif kind == "displacement":
        xlo, xhi = (float(v) for v in value)
    else:
        uc = float(value)
    if not 1 <= n_batches <= CF.NB_MAX:
        raise ValueError(f"first_passage: n_batches must be in [1, {CF.NB_MAX}]; "
                         f"got {n_batches}")
    horizon = kmax * dt
    nbins = max(1, int(math.ceil(horizon / grid_dt - 1e-9)))
    hist = nc.to_device(np.zeros((n_batches, nbins + 1)))
    sums = nc.to_device(np.zeros((n_batches, CK.NFP)))
    x0 = nc.to_device(np.ascontiguousarray(x0s, dtype=float))
    y0 = nc.to_device(np.ascontiguousarray(y0s, dtype=float))
    gmin = CF.min_potential(system) if kind == "energy" else -math.inf
    inv_bmax = 1.0 / math.sqrt(2.0 * (hc - gmin)) if hc - gmin > 0.0 else 0.0
    hu = nc.to_device(np.zeros((2, 0)))
    hti = nc.to_device(np.zeros(0))
    counter = nc.to_device(np.zeros(1, dtype=np.int64))
    Ts = nc.device_array(max(1, min(FP_LAUNCH_PATHS, n_paths)))
    G = n_batches * FP_FOLD_PER_BATCH
    part = nc.device_array((G, 2))
    fsum = np.zeros((n_batches, 2))
    tpb = _tpb()
    sd = np.uint64(seed % (1 << 64))
    n_done = queued = 0
    partial = False
    try:
        for path0 in range(0, n_paths, FP_LAUNCH_PATHS):
            m = min(FP_LAUNCH_PATHS, n_paths - path0)
            g = min(FP_THREADS, m)
            with _Deferred():
                counter.copy_to_device(np.zeros(1, dtype=np.int64))
                K.first_passage[(g + tpb - 1) // tpb, tpb](
                    m, path0, x0, y0, sd, n_batches, pf, int(ip.has_d2), int(ip.max_impacts),
                    *walls, KINDS[kind], hc, xlo, xhi, uc, float(system.D1),
                    float(system.D2), bool(bridge), int(kmax), 1.0 / grid_dt, inv_bmax, hist,
                    sums, counter, hu, hti, Ts)
                K.fp_fold[(G + tpb - 1) // tpb, tpb](Ts, m, part)
                queued = m
            nc.synchronize()
            np.add.at(fsum, (path0 + np.arange(G)) % n_batches, part.copy_to_host())
            n_done, queued = n_done + m, 0
            if progress is not None:
                progress(n_done / n_paths)
    except KeyboardInterrupt:
        nc.synchronize()                # a queued launch has run: it counts
        if queued:
            np.add.at(fsum, (n_done + np.arange(G)) % n_batches, part.copy_to_host())
            n_done += queued
        if n_done == 0:
            raise
        partial = True
    h, s = hist.copy_to_host(), sums.copy_to_host()
    s[:, :2] = fsum
    h[:, -1] += s[:, 3]                     # the censored paths: last column
    n = float(n_done)
    mean = s[:, 0].sum() / n
    var = max(s[:, 1].sum() / n - mean * mean, 0.0)
    counts = h.sum(axis=0)
    edges = np.arange(nbins + 1) * grid_dt
    R = 1.0 - np.concatenate([[0.0], np.cumsum(counts[:-1])]) / n
    return {"hist": h, "sums": s, "edges": edges, "mean": mean,
            "mean_se": math.sqrt(var / max(n - 1.0, 1.0)), "times": edges, "survival": R,
            "censored": float(s[:, 3].sum() / n), "path_steps": float(s[:, 4].sum()),
            "horizon": horizon, "n_paths": n_done, "partial": partial}


def steps_given(system, dt: float, xs: np.ndarray, ys: np.ndarray, zs: np.ndarray,
                max_impacts: int = 64, target: str = "cuda", speeds: int = 0,
                u_iw: float = 0.0, energies: int = 0, e_iw: float = 0.0, gaps: int = 0,
                g_iw: float = 0.0, track: bool = False, t0: float = 0.0, p=None):
    """Paths (xs, ys) stepped from time ``t0`` with the normals ``zs[k, j]`` on
    ``target`` ("cuda" or "cpu", the same functions): returns (x, y, time and wall of
    the last impact, per-path wall sums [n, 8], speed histogram [2, speeds], energy
    histogram [2, energies], gap histogram [gaps], per-path gap records [n, 2, NX]
    (``track``)).  A forced system's kicks add F cos(Ω (t0 + k dt) + φ0); ``p``: the
    step records to use instead of the system's (a test's zero forcing)."""
    from ._flight import NX
    from ._scalar_step import given_cpu
    p0, ip = S.step_params(system, dt, max_impacts)
    p = p0 if p is None else p
    forced = bool(ip.forced) or p.f_amp != 0.0
    pf = _flat(p)
    walls = encode_walls(system)
    x = np.array(xs, dtype=float)
    y = np.array(ys, dtype=float)
    tl = np.full(x.size, -1.0)
    wl = np.zeros(x.size, dtype=np.int8)
    out = np.zeros((x.size, 8))
    hu = np.zeros((2, speeds))
    he = np.zeros((2, energies))
    hg = np.zeros(gaps)
    accs = np.zeros((x.size, 2, NX))
    iw = (float(u_iw), float(u_iw), float(e_iw), float(e_iw), float(g_iw),
          1.0 if track else 0.0)
    zs = np.ascontiguousarray(zs, dtype=float)
    args = (float(t0), pf, int(ip.has_d2), int(ip.max_impacts), *walls)
    if target == "cpu":
        ia = np.array([CK._F[k] for k in ("a", "b", "hh", "ec", "sd0", "d1s2", "d2s2", "lo",
                                           "hi", "f_lo", "f_hi", "f_amp", "f_omega",
                                           "f_phase")])
        given_cpu(x, y, tl, wl, zs, *args, out, hu, he, hg, accs, iw, ia, forced)
        return x, y, tl, wl, out, hu, he, hg, accs
    K = CK.kernels()
    nc = K.cuda
    d = [nc.to_device(a) for a in (x, y, tl, wl, zs)]
    dw = [nc.to_device(a) for a in (out, hu, he, hg, accs)]
    tpb = _tpb()
    K.given[(x.size + tpb - 1) // tpb, tpb](
        *d, *(nc.to_device(a) if isinstance(a, np.ndarray) else a for a in args), *dw,
        nc.to_device(np.array(iw)), forced)
    nc.synchronize()
    return tuple(a.copy_to_host() for a in d[:4]) + tuple(a.copy_to_host() for a in dw)
