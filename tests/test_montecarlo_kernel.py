"""The Monte Carlo kernel's vectorised sweep against the plain scalar scheme, and the
benchmark's entry point (its rates are reported, never asserted)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from fpk_vibro import VibroImpactSystem
from fpk_vibro.montecarlo import _kernel as K
from fpk_vibro.montecarlo import _setup as S
from fpk_vibro.montecarlo._rng import _normal


@njit
def scalar_reference(xs, ys, rng, starts, n_steps, p, ip, chunk):
    """Every path by the scalar BAOAB step with exact impacts (``K._step``), one
    path-step at a time, drawing the normals in the kernel's order (per block:
    chunk, step, path)."""
    lo, hi = p[K.P_LO], p[K.P_HI]
    mode = ip[K.I_MODE]
    lo_t = lo if mode == K.MODE_BOTH else -math.inf
    hi_t = hi if mode != K.MODE_NONE else math.inf
    a, bc = p[K.P_A], p[K.P_B]
    nimp = 0
    for b in range(starts.size - 1):
        s0, s1, s2, s3 = rng[b, 0], rng[b, 1], rng[b, 2], rng[b, 3]
        for i0 in range(starts[b], starts[b + 1], chunk):
            n = min(chunk, starts[b + 1] - i0)
            z = np.empty(n)
            for k in range(n_steps):
                for j in range(n):
                    z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                for j in range(n):
                    x = xs[i0 + j]
                    x, y, f, m = K._step(x, ys[i0 + j], -(a + bc * x * x) * x, z[j],
                                         p[K.P_HH], p[K.P_EC], p[K.P_SD0], p[K.P_D1S2],
                                         p[K.P_D2S2], a, bc, lo, hi, p[K.P_FLO],
                                         p[K.P_FHI], p[K.P_R], mode, ip[K.I_D2] != 0,
                                         ip[K.I_MAXK], lo_t, hi_t)
                    xs[i0 + j] = x
                    ys[i0 + j] = y
                    nimp += m
        rng[b, 0], rng[b, 1], rng[b, 2], rng[b, 3] = s0, s1, s2, s3
    return nimp


CASES = {
    "many impacts": VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.05, delta=0.3,
                                      r=0.6),
    "r = 0": VibroImpactSystem(a=1.0, b=0.0, c=0.05, D1=0.05, D2=0.0, delta=0.3, r=0.0),
    "unilateral": VibroImpactSystem(a=1.0, b=0.5, c=0.05, D1=0.05, D2=0.02, delta=0.2,
                                    r=0.8, barriers="right"),
    "no barrier": VibroImpactSystem(a=1.0, b=0.5, c=0.05, D1=0.05, D2=0.02,
                                    barriers="none"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_vectorised_sweep_equals_scalar_scheme(name):
    """Same normals → same paths as the scalar step, to rounding (the kernel keeps a
    kick-merged velocity, so the arithmetic differs in the last bits), with the same
    impact count; two blocks of 75 paths exercise a full and a partial chunk."""
    system = CASES[name]
    dt = S.default_dt(system)
    p, ip = S.step_params(system, dt, 64)
    n_paths, n_blocks, n_steps = 150, 2, 300
    starts = S.block_starts(n_paths, n_blocks)
    rng = S.rng_states(np.random.SeedSequence(3).spawn(n_blocks))
    gen = np.random.default_rng(4)
    lo, hi = system.x_bounds
    xs = gen.uniform(max(lo, -1.0), min(hi, 1.0), n_paths)
    ys = gen.normal(0.0, 0.5, n_paths)
    xr, yr, rr = xs.copy(), ys.copy(), rng.copy()
    nimp_ref = scalar_reference(xr, yr, rr, starts, n_steps, p, ip, K.CHUNK)

    hist = S.Histograms(system, (), S.check_bins("bins", 10, "t"), n_blocks, 1.0)
    mom = np.zeros((n_blocks, K.NM))
    imp = np.zeros((n_blocks, 2))
    xext = np.tile([np.inf, -np.inf], (n_blocks, 1))
    K.advance(xs, ys, rng, starts, n_steps, 0, 0, p, ip, mom, imp, xext,
              hist.hH, hist.hx, hist.hy, hist.hj, threads=1)

    assert np.array_equal(rng, rr)                 # the same normals were drawn
    assert imp[:, 0].sum() == nimp_ref
    if system.has_barrier:
        assert nimp_ref > 100                      # the impact path was exercised
    assert np.allclose(xs, xr, rtol=0, atol=1e-9)
    assert np.allclose(ys, yr, rtol=0, atol=1e-9)
    assert np.all((xs >= lo) & (xs <= hi))


def test_benchmark_rates_report_every_figure():
    from fpk_vibro.benchmarks.montecarlo import rates

    r = rates(n_paths=128, n_batches=4, path_steps=2e5, repeats=2, threads=[1, 2])
    assert set(r) == {1, 2}
    for nt, m in r.items():
        for key in ("kernel", "kernel_nosample", "floor", "ratio"):
            assert math.isfinite(m[key]) and m[key] > 0, (nt, key, m[key])
    assert r[1]["ratio_cpu"] > 0 and r[2]["ratio_cpu"] is None
    assert r[1]["speedup"] == 1.0 and r[2]["speedup"] > 0
