"""Monte Carlo on a GPU against the CPU engine on the same machine (issue 33).

Prints the GPU, its driver and the numba-cuda version, then path-steps/s on the GPU
and on the CPU threads (and their ratio) for the paper's stationary case and a first
passage out of {H < 0.498} (r = 0.92), E[H] ± SE against FE's 0.214725, and the
time of a reliability R(t), t ≤ 20, from 10⁹ paths.  A benchmark, not a test::

    python -m fpk_vibro.benchmarks.montecarlo_cuda [--quick] [--paths-1e9 N]
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

FE_EH = 0.214725
#: FE's mean first-passage time out of {H < 0.498} from rest, r = 0.92 (about).
FE_FP = 80.43


def _stationary_gpu(n, n_burn, n_samp, dt, every):
    from fpk_vibro import VibroImpactSystem
    from fpk_vibro.montecarlo import _setup as S
    from fpk_vibro.montecarlo._cuda_engine import Ensemble
    from fpk_vibro.montecarlo._kernel import M_H, M_N, NM
    from fpk_vibro.montecarlo._summary import _ratio
    system = VibroImpactSystem.paper()
    nb = 32
    g = np.random.default_rng(1)
    xs, ys = np.zeros(n), g.normal(0.0, math.sqrt(FE_EH), n)
    p, ip = S.step_params(system, dt, 64)
    hist = S.Histograms(system, ("energy", "x", "y"), S.check_bins("bins", 100, None), nb,
                        2.0)
    p = hist.with_bins(p)

    def sums():
        return (np.zeros((nb, NM)), np.zeros((nb, 2)), np.tile([np.inf, -np.inf], (nb, 1)),
                np.zeros((nb, 2, 4)))

    from fpk_vibro.montecarlo import _cuda_engine as CE
    from fpk_vibro.montecarlo import _cuda_launch as CL
    Ensemble(system, xs[:64], ys[:64], 1)                                     # compile
    t0 = time.perf_counter()
    ens = Ensemble(system, xs, ys, 12345)
    t_seed = time.perf_counter() - t0
    mom, imp, xext, wimp = sums()
    e = (hist.hH[:, :0], hist.hx[:, :0], hist.hy[:, :0], hist.hj[:, :0])
    ens.advance(xs, ys, None, None, 2, 0, 0, p, ip, mom, imp, xext, *e, walls=wimp)  # compile
    rates = {}
    for tpb in (128, 256):
        CL.THREADS_PER_BLOCK = tpb
        t0 = time.perf_counter()
        ens.advance(xs, ys, None, None, n_burn // 2, 0, 0, p, ip, mom, imp, xext, *e,
                    walls=wimp)
        rates[tpb] = n * (n_burn // 2) / (time.perf_counter() - t0)
    CL.THREADS_PER_BLOCK = max(rates, key=rates.get)
    t_burn = n * n_burn / sum(n * (n_burn // 2) / r for r in rates.values())
    mom, imp, xext, wimp = sums()
    ens.advance(xs, ys, None, None, 2, 0, every, p, ip, mom, imp, xext, hist.hH, hist.hx,
                hist.hy, hist.hj, walls=wimp)                                # compile
    mom, imp, xext, wimp = sums()
    t0 = time.perf_counter()
    ens.advance(xs, ys, None, None, n_samp, 0, every, p, ip, mom, imp, xext, hist.hH,
                hist.hx, hist.hy, hist.hj, walls=wimp, speeds=None)
    t_samp = time.perf_counter() - t0
    est, se = _ratio(mom[:, [M_H]], mom[:, M_N])
    return {"seeding_s": t_seed, "burn_rate": t_burn, "tpb": rates,
            "sample_rate": n * n_samp / t_samp, "EH": float(est[0]), "EH_se": float(se[0]),
            "impacts": float(imp[:, 0].sum())}


def _stationary_cpu(n, n_steps, dt):
    from fpk_vibro import VibroImpactSystem
    from fpk_vibro.montecarlo import _kernel as K
    from fpk_vibro.montecarlo import _setup as S
    system = VibroImpactSystem.paper()
    nb = 64
    g = np.random.default_rng(1)
    xs, ys = np.zeros(n), g.normal(0.0, math.sqrt(FE_EH), n)
    rng = S.rng_states(np.random.SeedSequence(1).spawn(nb))
    starts = S.block_starts(n, nb)
    p, ip = S.step_params(system, dt, 64)
    e = np.zeros((nb, 0))
    args = (np.zeros((nb, K.NM)), np.zeros((nb, 2)), np.tile([np.inf, -np.inf], (nb, 1)),
            e, e, e, np.zeros((nb, 0, 1)))
    K.advance(xs, ys, rng, starts, 2, 0, 0, p, ip, *args)
    t0 = time.perf_counter()
    K.advance(xs, ys, rng, starts, n_steps, 0, 0, p, ip, *args)
    return n * n_steps / (time.perf_counter() - t0)


def _first_passage(n_gpu, n_cpu, dt, t_max=None, system_r=0.92, energy=0.498):
    from fpk_vibro import VibroImpactSystem, montecarlo
    from fpk_vibro.montecarlo._cuda_engine import first_passage
    system = VibroImpactSystem.paper(r=system_r)
    kmax = int(math.ceil((t_max if t_max is not None else 500 / 0.025) / dt))
    z = np.zeros(1)
    first_passage(system, "energy", energy, z, z, 1024, dt, 100, 1, 1.0)       # compile
    t0 = time.perf_counter()
    fp = first_passage(system, "energy", energy, z, z, n_gpu, dt, kmax, 2, 0.5)
    t_gpu = time.perf_counter() - t0
    out = {"gpu_rate": fp["path_steps"] / t_gpu, "gpu_s": t_gpu, "mean": fp["mean"],
           "mean_se": fp["mean_se"], "censored": fp["censored"], "n": n_gpu,
           "R": {t: float(np.interp(t, fp["times"], fp["survival"])) for t in (10, 20, 80)}}
    if n_cpu:
        montecarlo.first_passage(system, energy=energy, n_paths=64, dt=dt, seed=3,
                                 progress=False)                             # compile
        cpu = montecarlo.first_passage(system, energy=energy, n_paths=n_cpu, dt=dt, seed=1,
                                       progress=False)
        out.update(cpu_rate=cpu.info["path_steps"] / cpu.info["seconds"], cpu_mean=cpu.mean,
                   cpu_mean_se=cpu.mean_se)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke test)")
    ap.add_argument("--paths-1e9", type=float, default=1e9,
                    help="paths of the R(t) timing (0: skip)")
    ap.add_argument("--first-passage-only", action="store_true",
                    help="skip the stationary case")
    a = ap.parse_args(argv)
    from fpk_vibro.montecarlo._device import describe, resolve
    import numba
    info = describe()
    print(f"GPU: {info['gpu']}; driver: {info['driver']}; numba-cuda {info['numba_cuda']}; "
          f"numba {numba.__version__}; numpy {np.__version__}; CPU threads "
          f"{numba.get_num_threads()}", flush=True)
    if resolve("auto") != "cuda":
        print("no GPU: nothing to measure")
        return
    dt = 0.0506                                   # the paper case's default T0/120
    q = a.quick
    if not a.first_passage_only:
        _print_stationary(q, dt)
    _print_fp(a, q, dt)


def _print_stationary(q, dt):
    n = 1 << (12 if q else 22)
    st = _stationary_gpu(n, 200 if q else 4000, 200 if q else 4000, dt, 30)
    cpu = _stationary_cpu(1 << (10 if q else 16), 100 if q else 1000, dt)
    print(f"stationary, paper case, {n} paths: GPU {st['sample_rate']:.3g} path-steps/s "
          f"sampling, {st['burn_rate']:.3g} burn-in; CPU engine {cpu:.3g}; ratio "
          f"{st['sample_rate'] / cpu:.1f}x (seeding {st['seeding_s']:.2f} s); burn-in by "
          f"threads per block: " + ", ".join(f"{k}: {v:.3g}" for k, v in st["tpb"].items()),
          flush=True)
    print(f"E[H] = {st['EH']:.6f} +- {st['EH_se']:.2g} (FE {FE_EH}; "
          f"{(st['EH'] - FE_EH) / st['EH_se']:+.2f} SE)", flush=True)


def _print_fp(a, q, dt):
    fp = _first_passage(1 << (12 if q else 22), 1 << (8 if q else 14), dt)
    print(f"first passage H < 0.498, r = 0.92, {fp['n']} paths: GPU {fp['gpu_rate']:.3g} "
          f"path-steps/s ({fp['gpu_s']:.2f} s), CPU engine {fp['cpu_rate']:.3g}, ratio "
          f"{fp['gpu_rate'] / fp['cpu_rate']:.1f}x; mean {fp['mean']:.4f} +- "
          f"{fp['mean_se']:.2g} (CPU {fp['cpu_mean']:.3f} +- {fp['cpu_mean_se']:.2g}; FE "
          f"{FE_FP}: GPU {(fp['mean'] - FE_FP) / fp['mean_se']:+.1f} SE), "
          f"censored {fp['censored']:.2g}", flush=True)
    if a.paths_1e9 > 0:
        m = int(1e6 if q else a.paths_1e9)
        r = _first_passage(m, 0, dt, t_max=20.0)
        print(f"reliability R(t), t <= 20, {m:.3g} paths: {r['gpu_s']:.1f} s "
              f"({r['gpu_rate']:.3g} path-steps/s); R(10) = {r['R'][10]:.6f}, "
              f"R(20) = {r['R'][20]:.6f}", flush=True)


if __name__ == "__main__":
    main()
