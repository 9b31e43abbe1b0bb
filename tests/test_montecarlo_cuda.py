"""Monte Carlo on a GPU (issue 33), checked on numba's CUDA simulator.

The simulator runs the very kernels of :mod:`fpk_vibro.montecarlo._cuda_kernels` in
Python, so the step is compared exactly with its CPU compilation (the same plain
functions, :mod:`fpk_vibro.montecarlo._scalar_step`).  It must be switched on before
``numba.cuda`` is first imported: this module sets it; if some earlier test imported
numba.cuda without it (nothing in the package does at import), the simulator tests are
skipped with that reason.  Tests that need a real GPU run in a subprocess without the
simulator and are skipped where there is none.
"""
from __future__ import annotations

import inspect
import math
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

if "numba.cuda" not in sys.modules:
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

from fpk_vibro import VibroImpactSystem, Wall  # noqa: E402
from fpk_vibro.montecarlo import _setup as S  # noqa: E402
from fpk_vibro.montecarlo._cuda_engine import Ensemble, first_passage, steps_given  # noqa: E402
from fpk_vibro.montecarlo._device import simulator  # noqa: E402
from fpk_vibro.restitution import Restitution  # noqa: E402

SIM = simulator() and ("numba.cuda" not in sys.modules
                       or sys.modules["numba.cuda"].config.ENABLE_CUDASIM)
needs_sim = pytest.mark.skipif(not SIM, reason="numba.cuda was imported before this module "
                               "could switch on the CUDA simulator")
ENV = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
#: E[H] of VibroImpactSystem.paper() by FE (converged; docs/measurements.md).
FE_EH = 0.214725


def _systems():
    paper = VibroImpactSystem.paper(r=0.5)
    narrow = VibroImpactSystem(a=1.0, b=0.2, c=0.01, D1=0.5, left=Wall(-0.05, r=1.0),
                               right=Wall(0.05, r=0.995))
    one = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, right=Wall(0.3, r=0.8),
                            barriers="right")
    plastic = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.02,
                                left=Wall(-0.4, r=0.0), right=Wall(0.4, r=0.0))
    tanh = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01,
                             left=Wall(-0.6, r=Restitution.tanh(0.9, 0.2, 1.0)),
                             right=Wall(0.6, r=Restitution.tanh(0.9, 0.2, 1.0)))
    return {"paper r=0.5": (paper, 0.05, 1.5), "several impacts a flight": (narrow, 0.1, 8.0),
            "one wall": (one, 0.05, 1.0), "r=0, D2": (plastic, 0.05, 1.0),
            "tanh law": (tanh, 0.05, 1.5)}


@needs_sim
@pytest.mark.parametrize("case", list(_systems()))
def test_gpu_step_matches_cpu_scalar_step(case):
    system, dt, speed = _systems()[case]
    rng = np.random.default_rng(3)
    n, k = 6, 60
    lo, hi = (max(v, -0.5) if i == 0 else min(v, 0.5) for i, v in enumerate(system.x_bounds))
    xs = rng.uniform(lo, hi, n)
    ys = rng.normal(0.0, speed, n)
    zs = rng.standard_normal((k, n))
    kw = dict(speeds=12, u_iw=4.0, energies=10, e_iw=8.0, gaps=12, g_iw=2.0, track=True)
    cpu = steps_given(system, dt, xs, ys, zs, target="cpu", **kw)
    with np.errstate(over="ignore"):
        gpu = steps_given(system, dt, xs, ys, zs, target="cuda", **kw)
    for a, b in zip(cpu, gpu):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    walls = cpu[4]
    assert walls[:, [0, 4]].sum() > 0, "no impact: the case tests nothing"
    if case == "several impacts a flight":       # more impacts than flights on a path
        assert walls[:, [0, 4]].sum(axis=1).max() > 2 * k
    if case == "one wall":
        assert walls[:, 0].sum() == 0
    if case == "r=0, D2":                        # all the energy at impact is lost
        np.testing.assert_allclose(walls[:, [3, 7]], 0.5 * walls[:, [2, 6]], rtol=1e-12)
    assert cpu[5].sum() == cpu[6].sum() == walls[:, [0, 4]].sum()   # every impact counted
    acc = cpu[8]                                 # every impact: a gap or the path's first
    assert acc[:, :, [2, 4, 7]].sum() == walls[:, [0, 4]].sum()
    assert cpu[7].sum() == acc[:, :, [2, 4]].sum()


def _cpu_vectorised_step():
    """The CPU engine's compiled scalar step with one r (what its vectorised sweep
    redoes flagged paths with), called by its parameter names."""
    from fpk_vibro.montecarlo import _kernel as K
    names = list(inspect.signature(K._step.py_func).parameters)
    if "r" not in names:
        pytest.skip("the CPU engine's _kernel._step changed its arguments (issue 32): "
                    "adapt this call")
    return K._step, names


@pytest.mark.parametrize("r", [0.98, 0.0])
def test_cpu_engine_step_agrees_with_scalar_step(r):
    step, names = _cpu_vectorised_step()
    system = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.3, D2=0.01, r=r, delta=0.3)
    dt = 0.05
    p, ip = S.step_params(system, dt, 64)
    rng = np.random.default_rng(5)
    n, k = 8, 80
    xs, ys, zs = rng.uniform(-0.25, 0.25, n), rng.normal(0, 1.5, n), rng.standard_normal((k, n))
    ref = steps_given(system, dt, xs, ys, zs, target="cpu")
    vals = dict(hh=p.hh, ec=p.ec, sd0=p.sd0, d1s2=p.d1s2, d2s2=p.d2s2, a=p.a, bcub=p.b,
                lo=p.lo, hi=p.hi, flo=p.f_lo, fhi=p.f_hi, r=r, mode=ip.mode,
                has_d2=bool(ip.has_d2), maxk=ip.max_impacts, lo_t=p.lo, hi_t=p.hi)
    hits = 0
    for j in range(n):
        x, y = xs[j], ys[j]
        f = -(p.a + p.b * x * x) * x
        for i in range(k):
            args = dict(vals, x=x, y=y, f=f, z=zs[i, j])
            x, y, f, m = step(*(args[nm] for nm in names))
            hits += m
        assert x == pytest.approx(ref[0][j], rel=1e-12, abs=1e-12)
        assert y == pytest.approx(ref[1][j], rel=1e-12, abs=1e-12)
    assert hits == ref[4][:, [0, 4]].sum() > 0


@needs_sim
def test_small_paper_run_agrees_with_fe():
    """E[H] of the paper's case: burn-in by the CPU copy of the step, sampling by the
    GPU kernel on the simulator; within 3 SE (batch means) of FE."""
    from fpk_vibro.montecarlo._kernel import M_H, M_N, NM
    from fpk_vibro.montecarlo._summary import _ratio
    system = VibroImpactSystem.paper()
    n, nb, dt = 192, 8, 0.1
    rng = np.random.default_rng(11)
    xs = np.zeros(n)
    ys = rng.normal(0.0, math.sqrt(FE_EH), n)
    zs = rng.standard_normal((int(240 / dt), n))        # 6 relaxation times
    xs, ys = steps_given(system, dt, xs, ys, zs, target="cpu")[:2]
    p, ip = S.step_params(system, dt, 64)
    hist = S.Histograms(system, ("energy",), S.check_bins("bins", 16, None), nb, 2.0)
    p = hist.with_bins(p)
    mom, imp = np.zeros((nb, NM)), np.zeros((nb, 2))
    xext, wimp = np.tile([np.inf, -np.inf], (nb, 1)), np.zeros((nb, 2, 4))
    with np.errstate(over="ignore"):
        Ensemble(system, xs, ys, 17).advance(xs, ys, None, None, 300, 0, 6, p, ip, mom, imp,
                                             xext, hist.hH, hist.hx, hist.hy, hist.hj,
                                             walls=wimp)
    est, se = _ratio(mom[:, [M_H]], mom[:, M_N])
    assert mom[:, M_N].sum() == n * 50
    assert hist.hH.sum() + mom[:, 7].sum() == n * 50         # counted or overflowed
    assert imp[:, 1].sum() == n * 300
    assert abs(est[0] - FE_EH) < 3.0 * se[0] + 1e-3, (est[0], se[0])


@needs_sim
def test_first_passage_kinds_run_and_count_every_path():
    system = VibroImpactSystem.paper(r=0.9)
    n = 48
    for kind, value in (("energy", 0.25), ("displacement", (-0.45, 0.45)),
                        ("impact_speed", 0.4)):
        with np.errstate(over="ignore"):
            fp = first_passage(system, kind, value, np.array([0.0]), np.array([0.6]), n,
                               0.1, 400, 9, 0.5, n_batches=4)
        assert fp["hist"].sum() == n
        assert fp["survival"][0] == 1.0 and np.all(np.diff(fp["survival"]) <= 0)
        assert 0 < fp["mean"] <= fp["horizon"]
        assert fp["sums"][:, 2].sum() + fp["sums"][:, 3].sum() == n


def _no_sim(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=ENV, timeout=300)


def _has_gpu() -> bool:
    r = _no_sim("from fpk_vibro.montecarlo._device import available; print(available()[0])")
    return r.stdout.strip().endswith("True")


def test_cuda_refused_without_a_device():
    if _has_gpu():
        pytest.skip("a GPU is present: nothing to refuse")
    r = _no_sim("from fpk_vibro.montecarlo._device import resolve\n"
                "print(resolve('auto'))\nresolve('cuda')")
    assert r.stdout.strip() == "cpu"
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("fpk_vibro._checks.InputError: montecarlo: device = \"cuda\"")
    assert "device = \"cpu\"" in last and "no CUDA device" in last


def test_real_gpu_step_matches_cpu():
    if not _has_gpu():
        pytest.skip("no CUDA GPU here")
    r = _no_sim(
        "import numpy as np\nfrom fpk_vibro import VibroImpactSystem as V\n"
        "from fpk_vibro.montecarlo._cuda_engine import steps_given\n"
        "s = V.paper(r=0.5); g = np.random.default_rng(3)\n"
        "xs, ys, zs = g.uniform(-.5, .5, 64), g.normal(0, 1.5, 64), g.standard_normal((50, 64))\n"
        "a = steps_given(s, 0.05, xs, ys, zs, target='cpu')\n"
        "b = steps_given(s, 0.05, xs, ys, zs, target='cuda')\n"
        "print(max(float(np.max(np.abs(u - v))) for u, v in zip(a[:2], b[:2])))")
    assert r.returncode == 0, r.stderr
    # fused multiply-adds on the GPU: not bit for bit, close over 50 steps
    assert float(r.stdout.split()[-1]) < 1e-9


def _fp_system():
    law = Restitution.tanh(0.9, 0.2, 1.0)
    return VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.02, left=Wall(-0.3, r=0.6),
                             right=Wall(0.35, r=law))


def test_fp_step_decision_mirrors_cpu_engine():
    """The GPU's exit test of one step (energy set) against the CPU engine's own
    pieces (:mod:`._fp_kernel`): an impact's peak energy, the bridges to and from
    the impact, the bridge of a step without impact."""
    from fpk_vibro.montecarlo import _fp_kernel as FK
    from fpk_vibro.montecarlo._cuda_fp import P_CUT, cpu
    from fpk_vibro.montecarlo._params import wall_laws
    from fpk_vibro.montecarlo._scalar_step import encode_walls
    system = _fp_system()
    a, b = system.a, system.b
    lo, hi = system.x_bounds
    G = lambda x: x * x * (0.5 * a + 0.25 * b * x * x)       # noqa: E731
    glo, ghi, hc, dt = G(lo), G(hi), 0.3, 0.1
    d1, d2 = system.D1, system.D2
    law = wall_laws(system)
    walls = encode_walls(system)
    dec = cpu().decide
    rng = np.random.default_rng(4)
    seen = {"peak": 0, "impact bridge": 0, "bridge": 0}
    for _ in range(400):
        x0, x1 = rng.uniform(lo, hi, 2)
        y0, y1 = rng.uniform(-0.75, 0.75, 2)
        if not (0.5 * y0 * y0 + G(x0) < hc and 0.5 * y1 * y1 + G(x1) < hc):
            continue
        nl, nr = int(rng.integers(0, 2)), int(rng.integers(0, 2))
        ql, qr = nl * rng.uniform(0.0, 0.8) ** 2, nr * rng.uniform(0.0, 0.8) ** 2
        p, now = dec(x0, y0, G(x0), x1, y1, G(x1), nl, nr, ql, qr, glo, ghi, hc, d1, d2, dt,
                     True, *walls)
        sy = 2.0 * d1 + d2 * (x0 * x0 + x1 * x1)
        b0, b1 = (math.sqrt(max(2.0 * (hc - G(x)), 0.0)) for x in (x0, x1))
        if nl + nr:
            Hp, Up, Gw, Rw = (np.zeros(1) for _ in range(4))
            FK._peak(0, nl, nr, ql, qr, glo, ghi, law, Hp, Up, Gw, Rw)
            if Hp[0] >= hc:
                assert now and p == 0.0
                seen["peak"] += 1
                continue
            bw = math.sqrt(max(2.0 * (hc - Gw[0]), 0.0))
            pa = min(FK._cross(y0, b0, Up[0], bw, sy, dt), 1.0)
            pb = min(FK._cross(-Rw[0] * Up[0], bw, y1, b1, sy, dt), 1.0)
            ref = 1.0 - (1.0 - pa) * (1.0 - pb)
            ref = ref if ref > P_CUT else 0.0
            seen["impact bridge"] += ref > 0.0
        else:
            ep, em = FK._exponents(y0, b0, y1, b1, sy, dt)
            ref = FK._cross(y0, b0, y1, b1, sy, dt) if min(ep, em) < FK.BRIDGE_CUT else 0.0
            seen["bridge"] += ref > 0.0
        assert not now
        assert p == pytest.approx(ref, rel=1e-12, abs=1e-300)
    assert min(seen.values()) >= 5, seen


@needs_sim
def test_gpu_first_passage_matches_cpu_copy_path_by_path():
    """Every path's exit time on the simulator equals the CPU compilation of the same
    functions (each path draws its own stream), bridges through impacts included."""
    from fpk_vibro.montecarlo._cuda_fp import cpu, min_potential
    from fpk_vibro.montecarlo import _setup as S_
    from fpk_vibro.montecarlo._scalar_step import encode_walls
    system = _fp_system()
    n, dt, kmax, hc, seed = 40, 0.1, 300, 0.12, 77
    x0s, y0s = np.array([0.0, 0.1]), np.array([0.2, -0.3])
    with np.errstate(over="ignore"):
        fp = first_passage(system, "energy", hc, x0s, y0s, n, dt, kmax, seed, 0.5,
                           n_batches=4)
    p, ip = S_.step_params(system, dt, 64)
    a, b, lo, hi = p.a, p.b, p.lo, p.hi
    G = lambda x: x * x * (0.5 * a + 0.25 * b * x * x)       # noqa: E731
    inv_bmax = 1.0 / math.sqrt(2.0 * (hc - min_potential(system)))
    path = cpu().path
    e2 = np.zeros((2, 0))
    rec = (e2, e2, np.zeros(0), e2, (0.0,) * 6)
    T = np.empty(n)
    steps = 0
    br = 0.0
    with np.errstate(over="ignore"):
        for i in range(n):
            T[i], k, bb = path(i, np.uint64(seed), x0s[i % 2], y0s[i % 2], 0, hc, -np.inf,
                               np.inf, np.inf, system.D1, system.D2, True, kmax, inv_bmax,
                               a, b, p.hh, p.ec, p.sd0, p.d1s2, p.d2s2, lo, hi, p.f_lo,
                               p.f_hi, G(lo), G(hi), int(ip.has_d2), int(ip.max_impacts),
                               *encode_walls(system), rec)
            steps += k
            br += bb
    Tc = np.where(T >= 0.0, T, kmax * dt)
    s = fp["sums"].sum(axis=0)
    np.testing.assert_allclose(s[[0, 1]], [Tc.sum(), (Tc * Tc).sum()], rtol=1e-12)
    assert (s[2], s[3], s[4], s[5]) == ((T >= 0).sum(), (T < 0).sum(), steps, br)
    assert br > 0 and (T >= 0).sum() > n // 2


# --- issue 33: impact records, determinism, Ctrl-C -------------------------------------

REC = dict(speeds=9, u_iw=4.0, energies=7, e_iw=10.0, gaps=10, g_iw=1.5, track=True)


def _law_system():
    return VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, D2=0.01,
                             left=Wall(-0.35, r=0.7),
                             right=Wall(0.4, r=Restitution.tanh(0.9, 0.2, 1.0)))


def test_cpu_engine_records_agree_with_scalar_step():
    """The CPU engine's own step with its ``ext`` records (:mod:`._flight`: what its
    vectorised sweep runs for the paths that hit a wall) against the shared scalar
    step: the gaps per wall pair, the energy and gap histograms, the same numbers."""
    from fpk_vibro.montecarlo import _kernel as K
    from fpk_vibro.montecarlo._flight import NX
    names = list(inspect.signature(K._step_full.py_func).parameters)
    if names[-4:] != ["law", "ext", "t0", "i"]:
        pytest.skip("the CPU engine's _kernel._step_full changed its arguments: adapt")
    system, dt = _law_system(), 0.05
    p, ip = S.step_params(system, dt, 64)
    law = S.wall_laws(system)
    rng = np.random.default_rng(8)
    n, k = 6, 120
    xs, ys, zs = rng.uniform(-0.3, 0.3, n), rng.normal(0, 0.6, n), rng.standard_normal((k, n))
    ref = steps_given(system, dt, xs, ys, zs, target="cpu", **REC)
    acc, he, hg = np.zeros((2, NX)), np.zeros((2, REC["energies"])), np.zeros((1, REC["gaps"]))
    hu, last = np.zeros((2, REC["speeds"])), np.tile([-np.inf, 0.0], (n, 1))
    ext = (acc, he, hg, last, REC["e_iw"], REC["e_iw"], REC["g_iw"])
    for j in range(n):
        x, y = xs[j], ys[j]
        f = -(p.a + p.b * x * x) * x
        for i in range(k):
            x, y, f, *_ = K._step_full(x, y, f, zs[i, j], p.hh, p.ec, p.sd0, p.d1s2, p.d2s2,
                                       p.a, p.b, p.lo, p.hi, p.f_lo, p.f_hi, p.r_left,
                                       p.r_right, bool(ip.has_d2), ip.max_impacts, p.lo, p.hi,
                                       hu, REC["u_iw"], REC["u_iw"], law, ext, i * dt, j)
        assert (x, y) == pytest.approx((ref[0][j], ref[1][j]), rel=1e-12, abs=1e-12)
    gap_cols = [2, 3, 4, 5, 7]                                  # X_GL X_TL X_GR X_TR X_G0
    np.testing.assert_allclose(ref[8].sum(axis=0)[:, gap_cols], acc[:, gap_cols], rtol=1e-12)
    np.testing.assert_allclose(ref[8].max(axis=0)[:, 6], acc[:, 6], rtol=1e-12)   # X_GM
    np.testing.assert_array_equal(ref[5], hu)
    np.testing.assert_array_equal(ref[6], he)
    np.testing.assert_array_equal(ref[7], hg[0])
    assert acc[:, [2, 4]].sum() > 10 and acc[0, 4] > 0 and acc[1, 2] > 0   # both pairs


def _gpu_normals(seed, n, k):
    """The normals path i draws on the GPU (stream i of ``seed``, Box–Muller pairs)."""
    from fpk_vibro.montecarlo._cuda_rng import CPU as R
    zs = np.empty((k, n))
    for i in range(n):
        s0, s1 = R.seed(np.uint64(seed), i)
        for j in range(0, k, 2):
            zs[j, i], zs[j + 1, i], s0, s1 = R.normal2(np.uint64(s0), np.uint64(s1))
    return zs


def _advance(system, xs, ys, seed, nb, k, dt, with_records=True, **kw):
    """Ensemble.advance with every record asked; the CPU engine's arrays back."""
    from fpk_vibro.montecarlo._flight import NW, NX
    from fpk_vibro.montecarlo._sampling import NM
    p, ip = S.step_params(system, dt, 64)
    p = p._replace(u_iw_left=REC["u_iw"], u_iw_right=REC["u_iw"], e_iw_left=REC["e_iw"],
                   e_iw_right=REC["e_iw"], g_iw=REC["g_iw"])
    out = dict(mom=np.zeros((nb, NM)), imp=np.zeros((nb, 2)),
               xext=np.tile([np.inf, -np.inf], (nb, 1)), walls=np.zeros((nb, 2, NW)),
               extra=np.zeros((nb, 2, NX)), speeds=np.zeros((nb, 2, REC["speeds"])),
               energies=np.zeros((nb, 2, REC["energies"])),
               gaps=np.zeros((nb, 1, REC["gaps"])))
    h0 = (np.zeros((nb, 0)),) * 3 + (np.zeros((nb, 0, 1)),)
    ens = Ensemble(system, xs, ys, seed)
    x, y = xs.copy(), ys.copy()
    with np.errstate(over="ignore"):
        ens.advance(x, y, None, None, k, 0, 2, p, ip, out["mom"], out["imp"], out["xext"],
                    *h0, walls=out["walls"], speeds=out["speeds"], extra=out["extra"],
                    last=True, energies=out["energies"], gaps=out["gaps"], **kw)
    return out, x, y


@needs_sim
def test_gpu_ensemble_records_match_scalar_copy_and_repeat_bit_for_bit():
    """Ensemble.advance's per-batch impact records (walls, losses, gaps per wall pair,
    the three histograms, maxima) equal the CPU copy of the step on the GPU's own
    normals; a second run with the seed gives the same bits."""
    system, dt, seed, nb = _law_system(), 0.05, 21, 3
    n, k = 10, 60
    rng = np.random.default_rng(2)
    xs, ys = rng.uniform(-0.3, 0.3, n), rng.normal(0, 1.5, n)
    out, x, y = _advance(system, xs, ys, seed, nb, k, dt)
    ref = steps_given(system, dt, xs, ys, _gpu_normals(seed, n, k), target="cpu", **REC)
    np.testing.assert_allclose(x, ref[0], rtol=1e-12, atol=1e-12)
    starts = S.block_starts(n, nb)
    batch = np.repeat(np.arange(nb), np.diff(starts))
    walls = np.zeros((nb, 8))
    np.add.at(walls, batch, ref[4])
    np.testing.assert_allclose(out["walls"].reshape(nb, 6), walls[:, [0, 1, 2, 4, 5, 6]],
                               rtol=1e-12)
    np.testing.assert_allclose(out["extra"][:, :, 0], walls[:, [3, 7]], rtol=1e-12)  # X_E
    acc = np.zeros((nb, 2, 8))
    np.add.at(acc, batch, ref[8])
    cols = [2, 3, 4, 5, 7]
    np.testing.assert_allclose(out["extra"][:, :, cols], acc[:, :, cols], rtol=1e-12)
    gm = np.full((nb, 2), -np.inf)
    np.maximum.at(gm, batch, ref[8][:, :, 6])
    np.testing.assert_array_equal(out["extra"][:, :, 6], np.maximum(gm, 0.0))
    for key, i in (("speeds", 5), ("energies", 6)):
        np.testing.assert_array_equal(out[key].sum(axis=0), ref[i])
    np.testing.assert_array_equal(out["gaps"].sum(axis=(0, 1)), ref[7])
    assert out["imp"][:, 0].sum() == ref[4][:, [0, 4]].sum() > 10
    assert acc[:, :, [2, 4]].sum() > 5
    again, x2, _ = _advance(system, xs, ys, seed, nb, k, dt)
    for key in out:
        assert np.array_equal(out[key], again[key]), key          # bit for bit
    assert np.array_equal(x, x2)


class _StopSecond:
    """Ctrl-C just before the second chunk is queued."""
    entered = 0

    def __enter__(self):
        type(self).entered += 1
        if type(self).entered == 2:
            raise KeyboardInterrupt
        return self

    def __exit__(self, *exc):
        return False


@needs_sim
def test_ctrl_c_keeps_the_finished_chunks(monkeypatch):
    """Interrupted between chunks, Ensemble.advance keeps the first chunk's sums (the
    same bits as a run of that length) and first_passage returns its first launch
    (``partial``), the same numbers as a run of those paths."""
    from fpk_vibro.montecarlo import _cuda_engine as CE
    system, dt, seed, nb, n = _law_system(), 0.05, 5, 2, 8
    xs, ys = np.zeros(n), np.linspace(-0.5, 0.5, n)
    whole, _, _ = _advance(system, xs, ys, seed, nb, 4, dt)
    deferred = CE._Deferred
    monkeypatch.setattr(CE, "LAUNCH_PATH_STEPS", 4 * n)             # chunks of 4 steps
    monkeypatch.setattr(CE, "_Deferred", _StopSecond)
    with pytest.raises(KeyboardInterrupt):
        _advance(system, xs, ys, seed, nb, 12, dt)
    _StopSecond.entered = 0
    out = {}
    real = CE.Ensemble.advance

    def keep(self, *a, **kw):                  # the arrays the interrupted call filled
        out.update(mom=a[9], imp=a[10], walls=kw["walls"], extra=kw["extra"])
        return real(self, *a, **kw)

    monkeypatch.setattr(CE.Ensemble, "advance", keep)
    with pytest.raises(KeyboardInterrupt):
        _advance(system, xs, ys, seed, nb, 12, dt)
    for key in ("mom", "imp", "walls", "extra"):
        assert np.array_equal(out[key], whole[key]), key
    assert out["imp"][:, 1].sum() == 4 * n and out["mom"][:, 0].sum() == 2 * n
    _StopSecond.entered = 0
    monkeypatch.setattr(CE, "FP_LAUNCH_PATHS", 6)
    kw = dict(n_batches=2)
    args = (system, "energy", 0.08, np.array([0.0]), np.array([0.2]))
    with np.errstate(over="ignore"):
        part = first_passage(*args, 15, 0.1, 200, 3, 0.5, **kw)
        monkeypatch.setattr(CE, "_Deferred", deferred)
        ref = first_passage(*args, 6, 0.1, 200, 3, 0.5, **kw)
    assert part["partial"] and part["n_paths"] == 6 and not ref["partial"]
    for key in ("hist", "sums", "survival"):
        assert np.array_equal(part[key], ref[key]), key
    assert part["mean"] == ref["mean"] and part["sums"][:, 2:4].sum() == 6
