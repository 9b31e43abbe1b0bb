"""``fpk-vibro bench montecarlo``: the Monte Carlo engine (issue 3).

Prints

1. path-steps per second of the stationary kernel (the paper's r = 0.92 case,
   default dt, default sampling of all four histograms) next to the rate at which
   the kernel's own random source (xoshiro256+ with ziggurat normals, same
   blocking, same thread-pool dispatch) draws standard normals alone — the
   floor of one normal per path-step — single-thread and with all cores (see
   :func:`rates` for how the repeats are paired on a shared machine; figures
   in :mod:`fpk_vibro.montecarlo`);
2. the bias of E[H] against dt (each run to a target relative standard error,
   compared with the run at half the default dt);
3. the wall time of ``stationary(VibroImpactSystem.paper(r=0.92),
   target_rse=1e-3)`` in a fresh interpreter (import, cached compilation,
   burn-in and sampling included);
4. path-steps per second of the first-passage kernel (:mod:`._fp_kernel`; the
   paper's r = 0.92 case, H_c = 0.498 from (0, 0), default dt, until every path
   has exited) against the same random-source floor, paired as in 1.
"""
from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time

import numba
import numpy as np

from ..model import VibroImpactSystem
from ..montecarlo import _first_passage as FP
from ..montecarlo import _kernel as K
from ..montecarlo import _setup as S
from ..montecarlo import stationary
from ..montecarlo.solution import QUANTITIES

WALL_SNIPPET = """
import time; t0 = time.perf_counter()
from fpk_vibro import VibroImpactSystem
from fpk_vibro.montecarlo import stationary
sol = stationary(VibroImpactSystem.paper(r=0.92), seed=2024, target_rse={rse!r})
m, se = sol.moments()["E_H"], sol.moments_se()["E_H"]
print(f"{{time.perf_counter() - t0:.3f}} {{m:.6f}} {{se:.3g}} {{sol.t_sample:.1f}} {{sol.n_paths}} {{sol.dt:.5f}}")
"""


def _kernel_setup(system, n_paths, n_batches, seed):
    dt = S.default_dt(system)
    p, ip = S.step_params(system, dt, 64)
    ss = np.random.SeedSequence(seed)
    rng = S.rng_states(ss.spawn(n_batches))
    starts = S.block_starts(n_paths, n_batches)
    gen = np.random.default_rng(seed)
    xs = np.zeros(n_paths)
    ys = math.sqrt(S.energy_scale(system)) * gen.standard_normal(n_paths)
    hist = S.Histograms(system, QUANTITIES, S.check_bins("bins", 100, "bench"), n_batches, 1.5)
    p = hist.with_bins(p)
    mom = np.zeros((n_batches, K.NM))
    imp = np.zeros((n_batches, 2))
    xext = np.tile([np.inf, -np.inf], (n_batches, 1))
    every = S.default_sample_every(system, dt)
    return dict(xs=xs, ys=ys, rng=rng, starts=starts, p=p, ip=ip, mom=mom, imp=imp,
                xext=xext, hist=hist, every=every, dt=dt)


def _time_kernel(st, n_steps, sample=True, cpu=False):
    h = st["hist"]
    clock = time.thread_time if cpu else time.perf_counter
    t = clock()
    K.advance(st["xs"], st["ys"], st["rng"], st["starts"], n_steps, 0,
              st["every"] if sample else 0, st["p"], st["ip"], st["mom"], st["imp"],
              st["xext"], h.hH, h.hx, h.hy, h.hj)
    return clock() - t


def _time_floor(st, per_block, cpu=False):
    clock = time.thread_time if cpu else time.perf_counter
    t = clock()
    K.normals_floor(st["rng"], per_block)
    return clock() - t


def rates(n_paths=2048, n_batches=32, path_steps=1.6e8, repeats=5, threads=None):
    """Kernel and floor rates per thread count, measured back to back.

    Each repeat times, for each thread count in turn, the kernel with sampling,
    the kernel without sampling and the normals alone, one right after the
    other, so that the measurements compared see the same machine load: the
    kernel/floor ratio and the speed-up over one thread are medians over the
    repeats of these paired ratios (a shared machine's load drifts between
    repeats, which best-of-n rates taken at different moments would mix).  For
    one thread (blocks run in the calling thread) the ratio is also given by the
    thread's CPU time.

    Returns ``{threads: dict(kernel=, kernel_nosample=, floor=, ratio=,
    ratio_cpu=, speedup=)}``: best rates over the repeats (path-steps/s resp.
    normals/s, wall time) and the median paired ratios (``ratio_cpu`` only for
    one thread, ``speedup`` only when one thread is measured too).
    """
    system = VibroImpactSystem.paper(r=0.92)
    st = _kernel_setup(system, n_paths, n_batches, 7)
    _time_kernel(st, 4)                      # compile / load the cache
    _time_floor(st, 4)
    n_steps = max(2, int(path_steps // n_paths))
    per_block = n_steps * n_paths // n_batches
    work = n_steps * n_paths
    total = per_block * n_batches
    counts = list(threads or sorted({1, numba.config.NUMBA_NUM_THREADS}))
    t = {nt: {"k": [], "k0": [], "n": [], "ck": [], "cn": []} for nt in counts}
    old = numba.get_num_threads()
    try:
        for _ in range(repeats):
            for nt in counts:
                numba.set_num_threads(nt)
                m = t[nt]
                m["k"].append(_time_kernel(st, n_steps))
                m["k0"].append(_time_kernel(st, n_steps, sample=False))
                m["n"].append(_time_floor(st, per_block))
                if nt == 1:
                    m["ck"].append(_time_kernel(st, n_steps, cpu=True))
                    m["cn"].append(_time_floor(st, per_block, cpu=True))
    finally:
        numba.set_num_threads(old)

    def paired(num, den, scale):
        return float(np.median(np.asarray(num) / np.asarray(den))) * scale

    out = {}
    for nt, m in t.items():
        out[nt] = dict(kernel=work / min(m["k"]), kernel_nosample=work / min(m["k0"]),
                       floor=total / min(m["n"]),
                       ratio=paired(m["n"], m["k"], work / total),
                       ratio_cpu=paired(m["cn"], m["ck"], work / total) if m["ck"] else None,
                       speedup=paired(t[1]["k"], m["k"], 1.0) if 1 in t else None)
    return out


def fp_rates(n_paths=16384, repeats=5, threads=None, energy=0.498):
    """First-passage kernel rate against the normals floor, per thread count.

    Each repeat runs every path of the paper r = 0.92 case from (0, 0) until it
    leaves H < ``energy`` (:func:`._first_passage.simulate`, one round, a horizon
    that all paths reach first) and, right after, draws as many normals per block
    as the kernel did path-steps (mean per block) with the same generator and
    dispatch.  Returns ``{threads: dict(kernel=, floor=, ratio=, ratio_cpu=)}`` as
    :func:`rates` (best rates; median paired ratios; CPU-time ratio for one thread).
    """
    system = VibroImpactSystem.paper(r=0.92)
    dt = S.default_dt(system)
    nb = FP.N_BLOCKS
    k_all = math.ceil(FP.T_CAP / S.relaxation_rate(system) / dt)

    def run(nt, cpu):
        rng = S.rng_states(np.random.SeedSequence(11).spawn(nb))
        xs, ys = np.zeros(n_paths), np.zeros(n_paths)
        clock = time.thread_time if cpu else time.perf_counter
        t = clock()
        _, _, counts, _, _ = FP.simulate(system, energy, xs, ys, dt, rng, k_all, k_all, nt)
        el = clock() - t
        steps = float(counts[:, 0].sum())
        t = clock()
        K.normals_floor(rng, int(steps // nb), nt)
        return steps, el, clock() - t

    counts_t = list(threads or sorted({1, numba.config.NUMBA_NUM_THREADS}))
    run(1, False)                                  # compile / load the cache
    t = {nt: {"k": [], "n": [], "ck": [], "cn": [], "w": 0.0} for nt in counts_t}
    for _ in range(repeats):
        for nt in counts_t:
            steps, tk, tn = run(nt, False)
            m = t[nt]
            m["w"] = steps
            m["k"].append(tk)
            m["n"].append(tn)
            if nt == 1:
                _, ck, cn = run(nt, True)
                m["ck"].append(ck)
                m["cn"].append(cn)
    out = {}
    for nt, m in t.items():
        w, total = m["w"], (m["w"] // nb) * nb
        out[nt] = dict(kernel=w / min(m["k"]), floor=total / min(m["n"]), path_steps=w,
                       ratio=float(np.median(np.asarray(m["n"]) / m["k"])) * w / total,
                       ratio_cpu=(float(np.median(np.asarray(m["cn"]) / m["ck"])) * w / total
                                  if m["ck"] else None))
    return out


def bias_table(factors=(4.0, 2.0, 1.0, 0.5), target_rse=2e-3, seed=99):
    """E[H] of the paper r = 0.92 case for dt = factor × default dt.

    The last (smallest) dt is the reference; it is run to half the relative
    standard error so that its own noise does not dominate the differences.
    """
    system = VibroImpactSystem.paper(r=0.92)
    dt0 = S.default_dt(system)
    rows = []
    for i, f in enumerate(factors):
        t = time.perf_counter()
        rse = target_rse if i < len(factors) - 1 else target_rse / 2
        sol = stationary(system, dt=f * dt0, target_rse=rse, seed=seed + i,
                         quantities=())
        rows.append((f * dt0, sol.moments()["E_H"], sol.moments_se()["E_H"],
                     time.perf_counter() - t))
    return rows


def wall_time(rse=1e-3):
    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    t = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", WALL_SNIPPET.format(rse=rse)], env=env,
                         capture_output=True, text=True, check=True)
    total = time.perf_counter() - t
    inner, m, se, ts, n, dt = res.stdout.split()
    return total, float(inner), float(m), float(se), float(ts), int(n), float(dt)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; returns 0 (targets are reported, not asserted).
    ``--device cuda``: the GPU benchmark instead (:mod:`.montecarlo_cuda`, which takes
    the remaining arguments)."""
    argv = list(argv) if argv is not None else None
    import sys
    rest = list(sys.argv[1:] if argv is None else argv)
    if "--device" in rest:
        k = rest.index("--device")
        device = rest[k + 1] if k + 1 < len(rest) else ""
        if device not in ("cpu", "cuda"):
            print("fpk-vibro bench montecarlo: --device must be cpu or cuda; got "
                  f"{device!r}", file=sys.stderr)
            return 2
        del rest[k:k + 2]
        if device == "cuda":
            from . import montecarlo_cuda
            return montecarlo_cuda.main(rest) or 0
        argv = rest
    ap = argparse.ArgumentParser(prog="fpk-vibro bench montecarlo",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="small sizes, one repeat, relative SE 1e-2: a few seconds (a smoke "
                         "test, not a measurement)")
    ap.add_argument("--skip-bias", action="store_true")
    ap.add_argument("--skip-wall", action="store_true")
    ap.add_argument("--skip-first-passage", action="store_true")
    ap.add_argument("--bias-rse", type=float, default=None,
                    help="target relative SE of each E[H] in the dt table (default 2e-3; "
                         "1e-2 with --quick)")
    args = ap.parse_args(argv)
    if args.bias_rse is None:
        args.bias_rse = 1e-2 if args.quick else 2e-3
    ncpu = numba.config.NUMBA_NUM_THREADS
    print(f"fpk_vibro Monte Carlo benchmark — numba {numba.__version__}, "
          f"{ncpu} thread(s) available, load average {os.getloadavg()[0]:.2f}")
    print("\n1. kernel rate vs the random source's normal rate "
          "(paper r=0.92, default dt, 2048 paths, 32 blocks)")
    r = rates(path_steps=4e6 if args.quick else 8e7, repeats=1 if args.quick else 9)
    print(f"   {'threads':>7} {'kernel (sampling)':>18} {'kernel (no sampling)':>21} "
          f"{'normals alone':>14} {'kernel/floor':>12}")
    for nt, m in r.items():
        extra = f"   (by CPU time: {m['ratio_cpu']:.2f})" if m["ratio_cpu"] is not None else ""
        print(f"   {nt:>7} {m['kernel']:>14.3e}/s {m['kernel_nosample']:>17.3e}/s "
              f"{m['floor']:>12.3e}/s {m['ratio']:>12.2f}{extra}")
    print("   (rates: best of the repeats; ratios: medians of back-to-back pairs)")
    if 1 in r and ncpu > 1 and ncpu in r:
        print(f"   speed-up on {ncpu} threads: kernel {r[ncpu]['speedup']:.2f}x "
              f"(best rates: kernel {r[ncpu]['kernel'] / r[1]['kernel']:.2f}x, "
              f"normals {r[ncpu]['floor'] / r[1]['floor']:.2f}x)   "
              f"(targets: kernel/floor >= 0.5 single-thread, speed-up >= 1.8)")
    if not args.skip_bias:
        print(f"\n2. bias of E[H] against dt (paper r=0.92; each run to relative SE "
              f"{args.bias_rse:g}; reference: the smallest dt, to {args.bias_rse / 2:g})")
        rows = bias_table(target_rse=args.bias_rse)
        dref, mref, sref, _ = rows[-1]
        print(f"   {'dt':>8} {'E[H]':>9} {'SE':>9} {'E[H]-ref':>10} {'in comb. SE':>11} "
              f"{'time':>6}")
        for dt, m, se, t in rows:
            d = m - mref
            z = d / math.hypot(se, sref) if dt != dref else 0.0
            print(f"   {dt:8.4f} {m:9.5f} {se:9.2e} {d:+10.2e} {z:+11.2f} {t:5.1f}s")
    if not args.skip_wall:
        rse = 1e-2 if args.quick else 1e-3
        print(f"\n3. wall time, paper r=0.92, E[H] to relative SE {rse:g} "
              "(fresh interpreter: import, cached compile, burn-in, sampling)")
        total, inner, m, se, ts, n, dt = wall_time(rse)
        print(f"   {total:.2f} s wall ({inner:.2f} s from import to result): E[H] = {m:.5f} "
              f"± {se:.2g} (rel {se / m:.2e}), {n} paths × {ts:.0f} time units, dt={dt:.4f}"
              f"   (target <= 10 s)")
    if not args.skip_first_passage:
        n_paths = 2048 if args.quick else 16384
        print("\n4. first-passage kernel vs the random source's normal rate (paper r=0.92, "
              f"H_c=0.498 from (0, 0), default dt, {n_paths} paths to exit)")
        r = fp_rates(n_paths=n_paths, repeats=1 if args.quick else 7)
        print(f"   {'threads':>7} {'path-steps/s':>14} {'normals alone':>14} "
              f"{'kernel/floor':>12}")
        for nt, m in r.items():
            extra = f"   (by CPU time: {m['ratio_cpu']:.2f})" if m["ratio_cpu"] is not None \
                else ""
            print(f"   {nt:>7} {m['kernel']:>12.3e}/s {m['floor']:>12.3e}/s "
                  f"{m['ratio']:>12.2f}{extra}")
        print(f"   ({next(iter(r.values()))['path_steps']:.3g} path-steps per run; rates: "
              "best of the repeats; ratios: medians of back-to-back pairs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
