"""Monte Carlo with walls anywhere: the exact Gibbs density and wall fluxes on an
asymmetric strip, each wall with its own restitution, a preloaded wall, a left wall
alone, and the symmetric shorthand bit for bit as before walls could be given one by
one."""
from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest
from numba import njit
from scipy import integrate

from fpk_vibro import VibroImpactSystem, Wall
from fpk_vibro import montecarlo as mc
from fpk_vibro.montecarlo import _kernel as K
from fpk_vibro.montecarlo import _setup as S
from fpk_vibro.montecarlo._rng import _normal

ASYM = dict(a=1.0, b=0.2, c=0.025, D1=0.01)


def gibbs(system):
    """E[x], E[x²], E[y²], E[H] of p ∝ exp(−c H / D1) on the strip, and the marginal
    density p_X at each wall, by quadrature."""
    beta = system.c / system.D1
    lo, hi = system.x_bounds

    def w(x):
        return np.exp(-beta * system.potential(x))

    Z = integrate.quad(w, lo, hi, epsabs=0, epsrel=1e-13)[0]

    def avg(f):
        return integrate.quad(lambda x: f(x) * w(x), lo, hi, epsabs=0, epsrel=1e-13)[0] / Z
    Ey2 = 1.0 / beta
    moments = {"E_x": avg(lambda x: x), "E_x2": avg(lambda x: x * x), "E_y2": Ey2,
               "E_H": avg(system.potential) + 0.5 * Ey2}
    return moments, {side: float(w(wall.position)) / Z for side, wall in system.walls}


def run(system, seed, n_paths=1024, t_sample=500.0, **kw):
    return mc.stationary(system, seed=seed, n_paths=n_paths, t_sample=t_sample,
                         progress=False, **kw)


def assert_sane(sol):
    """Finite moments, histograms of mass 1 − overflow, positive rates with finite SEs."""
    assert all(math.isfinite(v) for v in sol.moments().values())
    assert all(math.isfinite(v) and v >= 0 for v in sol.moments_se().values())
    for q in ("energy", "x", "y"):
        edges, dens, _ = sol.histogram(q)
        mass = float(np.sum(dens * np.diff(edges)))
        assert abs(mass - (1.0 - sol.overflow[q])) < 1e-9, (q, mass, sol.overflow[q])
    lo, hi = sol.system.x_bounds
    assert lo <= sol.x_seen[0] and sol.x_seen[1] <= hi
    imp = sol.impacts()
    assert set(imp) == {side for side, _ in sol.system.walls}
    for d in imp.values():
        assert d["count"] > 0 and d["rate"] > 0
        assert all(math.isfinite(d[k]) and d[k] > 0 for k in ("rate_se", "mean_speed_se",
                                                             "mean_square_speed_se"))
    # the walls' counts make up the total impact rate
    total = sum(d["count"] for d in imp.values())
    assert total == pytest.approx(sol.impact_rate * sol.t_sample * sol.n_paths, rel=1e-9)
    assert sol.info["impacts"] == imp and sol.info["mean_x"] == sol.mean_x()


def power_balance(sol):
    """(noise power in, out by damping and the walls, combined SE): in a stationary
    state D1 + D2 E[x²] = c E[y²] + Σ_w ½ (1 − r_w²) E[u²] rate_w."""
    s, m, se, imp = sol.system, sol.moments(), sol.moments_se(), sol.impacts()
    p_in = s.D1 + s.D2 * m["E_x2"]
    p_out = s.c * m["E_y2"] + sum(d["energy_rate"] for d in imp.values())
    err = s.D2 * se["E_x2"] + s.c * se["E_y2"] + sum(d["energy_rate_se"] for d in imp.values())
    return p_in, p_out, err


def test_asymmetric_elastic_walls_give_the_gibbs_moments_and_wall_fluxes():
    """r = 1, D2 = 0: moments, E[x] and the impact rate of each wall against the exact
    density.  The velocity is N(0, D1/c) independent of x, so the paths reach the wall
    x_w at the rate p_X(x_w) E[y⁺] = p_X(x_w) sqrt(D1/c)/sqrt(2π), with mean speed
    sqrt(π D1/(2c)) and mean-square speed 2 D1/c."""
    s = VibroImpactSystem(**ASYM, left=Wall(-0.4), right=Wall(0.8))
    exact, p_wall = gibbs(s)
    assert exact["E_x"] > 0.1                          # the asymmetry shows
    sol = run(s, seed=11, n_paths=2048, t_sample=2000.0)
    assert_sane(sol)
    m, se = sol.moments(), sol.moments_se()
    got = dict(m, E_x=sol.mean_x())
    got_se = dict(se, E_x=sol.mean_x_se())
    for k, v in exact.items():
        assert abs(got[k] - v) < 4 * got_se[k], (k, got[k], v, got_se[k])
    sigma = math.sqrt(s.D1 / s.c)
    imp = sol.impacts()
    for side, d in imp.items():
        for key, v in (("rate", p_wall[side] * sigma / math.sqrt(2 * math.pi)),
                       ("mean_speed", sigma * math.sqrt(math.pi / 2)),
                       ("mean_square_speed", 2 * sigma ** 2)):
            assert abs(d[key] - v) < 4 * d[f"{key}_se"], (side, key, d[key], v)
        assert d["energy_rate"] == 0.0                    # elastic walls take nothing
    assert imp["left"]["rate"] > 1.5 * imp["right"]["rate"]      # the nearer wall
    edges = sol.histogram("x")[0]
    assert (edges[0], edges[-1]) == (-0.4, 0.8)


def test_each_wall_its_own_restitution():
    """r_L = 0.7, r_R = 0.95 with parametric noise: sane results, the nearer and less
    elastic left wall is hit more often and takes more energy, and the power balance
    (each wall's loss from its own r) holds."""
    s = VibroImpactSystem(**ASYM, D2=0.01, left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95))
    sol = run(s, seed=5)
    assert_sane(sol)
    imp = sol.impacts()
    assert imp["left"]["rate"] > imp["right"]["rate"]
    assert imp["left"]["energy_rate"] > imp["right"]["energy_rate"] > 0
    p_in, p_out, err = power_balance(sol)
    assert abs(p_in - p_out) < 4 * err, (p_in, p_out, err)
    # a plastic wall and an elastic one: no stall, the plastic one takes energy
    sol = run(s.replace(left=Wall(-0.3, r=0.0), right=Wall(0.5, r=1.0)), seed=6,
              n_paths=256, t_sample=200.0)
    assert all(math.isfinite(v) for v in sol.moments().values())
    assert sol.impacts()["right"]["energy_rate"] == 0.0
    assert sol.impacts()["left"]["energy_rate"] > 0.0


@pytest.mark.parametrize("position", [-0.1, 0.0])
def test_preloaded_wall(position):
    """A right wall at or left of the equilibrium, no left wall: every sample at or left
    of the wall, the x histogram from the energy reach to the wall, the power balance."""
    wall = Wall(position, r=0.8)
    s = VibroImpactSystem(a=1.0, b=0.0, c=0.05, D1=0.01, right=wall)
    sol = run(s, seed=7)
    assert_sane(sol)
    assert sol.x_seen[1] <= position and sol.mean_x() < position
    edges = sol.histogram("x")[0]
    assert edges[-1] == position and edges[0] < position - 0.5
    assert float(sol.pdf_x(np.array([position + 0.01]))[0]) == 0.0
    p_in, p_out, err = power_balance(sol)
    assert abs(p_in - p_out) < 4 * err, (p_in, p_out, err)
    tr = mc.transient(s, initial={"mean": (position - 0.2, 0.2), "std": (0.05, 0.05)},
                      times=(0.0, 5.0), seed=8, n_paths=512, progress=False)
    assert tr[-1].x_seen[1] <= position and tr[-1].impacts()["right"]["count"] > 0


def test_left_wall_alone_mirrors_the_right_wall_alone():
    left = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, left=Wall(-0.3, r=0.9))
    assert left == VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, delta=0.3, r=0.9,
                                      barriers="left")
    right = VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, right=Wall(0.3, r=0.9))
    sl, sr = run(left, seed=21), run(right, seed=22)
    assert_sane(sl)
    assert set(sl.impacts()) == {"left"} and sl.x_seen[0] >= -0.3
    edges = sl.histogram("x")[0]
    assert edges[0] == -0.3 and edges[-1] > 1.0
    pairs = [(sl.moments()[k], sr.moments()[k], sl.moments_se()[k], sr.moments_se()[k])
             for k in ("E_H", "E_x2", "E_y2", "P_impact")]
    pairs.append((sl.mean_x(), -sr.mean_x(), sl.mean_x_se(), sr.mean_x_se()))
    a, b = sl.impacts()["left"], sr.impacts()["right"]
    pairs += [(a[k], b[k], a[f"{k}_se"], b[f"{k}_se"]) for k in ("rate", "mean_speed")]
    for u, v, su, sv in pairs:
        assert abs(u - v) < 4 * math.hypot(su, sv), (u, v, su, sv)


@njit
def scalar_reference(xs, ys, rng, starts, n_steps, p, ip, out):
    """Every path by the scalar step with exact impacts (``K._step_walls``), one
    path-step at a time, normals in the kernel's order (per block: chunk, step, path);
    the wall statistics summed into ``out[side, column]``."""
    lo, hi, a, bc = p[K.P_LO], p[K.P_HI], p[K.P_A], p[K.P_B]
    for b in range(starts.size - 1):
        s0, s1, s2, s3 = rng[b, 0], rng[b, 1], rng[b, 2], rng[b, 3]
        for i0 in range(starts[b], starts[b + 1], K.CHUNK):
            n = min(K.CHUNK, starts[b + 1] - i0)
            z = np.empty(n)
            for _ in range(n_steps):
                for j in range(n):
                    z[j], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                for j in range(n):
                    x = xs[i0 + j]
                    x, y, f, nl, nr, ul, ur, ql, qr = K._step_walls(
                        x, ys[i0 + j], -(a + bc * x * x) * x, z[j], p[K.P_HH], p[K.P_EC],
                        p[K.P_SD0], p[K.P_D1S2], p[K.P_D2S2], a, bc, lo, hi, p[K.P_FLO],
                        p[K.P_FHI], p[K.P_RL], p[K.P_R], ip[K.I_D2] != 0, ip[K.I_MAXK], lo, hi)
                    xs[i0 + j] = x
                    ys[i0 + j] = y
                    out[0, K.W_N] += nl
                    out[1, K.W_N] += nr
                    out[0, K.W_U] += ul
                    out[1, K.W_U] += ur
                    out[0, K.W_Q] += ql
                    out[1, K.W_Q] += qr
        rng[b, 0], rng[b, 1], rng[b, 2], rng[b, 3] = s0, s1, s2, s3


@pytest.mark.parametrize("system", [
    VibroImpactSystem(**ASYM, D2=0.05, left=Wall(-0.2, r=0.5), right=Wall(0.3, r=0.9)),
    VibroImpactSystem(a=1.0, b=0.5, c=0.05, D1=0.05, left=Wall(-0.2, r=0.7)),
    VibroImpactSystem(a=1.0, b=0.0, c=0.05, D1=0.05, right=Wall(-0.1, r=0.8)),
    VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.05, left=Wall(0.1, r=0.6),
                      right=Wall(0.4, r=1.0)),
], ids=["asymmetric r", "left only", "preload", "one side"])
def test_vectorised_sweep_equals_scalar_step_per_wall(system):
    """Same normals → same paths as the scalar step to rounding, the same impact count
    on each wall and the same impact-speed sums (two blocks of 75 paths: a full and a
    partial chunk)."""
    dt = S.default_dt(system)
    p, ip = S.step_params(system, dt, 64)
    n_paths, n_blocks, n_steps = 150, 2, 300
    starts = S.block_starts(n_paths, n_blocks)
    rng = S.rng_states(np.random.SeedSequence(3).spawn(n_blocks))
    lo, hi = system.x_bounds
    x0 = lo if math.isfinite(lo) else hi - 1.0
    xs = np.random.default_rng(4).uniform(x0, hi if math.isfinite(hi) else lo + 1.0, n_paths)
    ys = np.random.default_rng(5).normal(0.0, 0.5, n_paths)
    xr, yr, rr, ref = xs.copy(), ys.copy(), rng.copy(), np.zeros((2, K.NW))
    scalar_reference(xr, yr, rr, starts, n_steps, p, ip, ref)

    hist = S.Histograms(system, (), S.check_bins("bins", 10, "t"), n_blocks, 1.0)
    imp, walls = np.zeros((n_blocks, 2)), np.zeros((n_blocks, 2, K.NW))
    K.advance(xs, ys, rng, starts, n_steps, 0, 0, p, ip, np.zeros((n_blocks, K.NM)), imp,
              np.tile([np.inf, -np.inf], (n_blocks, 1)), hist.hH, hist.hx, hist.hy, hist.hj,
              threads=1, walls=walls)
    assert np.array_equal(rng, rr)
    got = walls.sum(axis=0)
    assert np.array_equal(got[:, K.W_N], ref[:, K.W_N]) and imp[:, 0].sum() == ref[:, 0].sum()
    for side, _ in system.walls:
        assert ref[K.LEFT if side == "left" else K.RIGHT, K.W_N] > 100, side
    assert np.allclose(got, ref, rtol=1e-9, atol=0)
    assert np.allclose(xs, xr, rtol=0, atol=1e-9) and np.allclose(ys, yr, rtol=0, atol=1e-9)
    assert np.all((xs >= lo) & (xs <= hi))


def test_same_seed_same_bits_on_one_and_two_threads():
    s = VibroImpactSystem(**ASYM, D2=0.01, left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95))
    one, two = (run(s, seed=9, n_paths=512, t_sample=100.0, threads=t) for t in (1, 2))
    assert _digest(one) == _digest(two)
    assert one.impacts() == two.impacts() and one.mean_x() == two.mean_x()


def test_impacts_survive_save_and_load(tmp_path):
    from fpk_vibro.solution import Solution
    s = VibroImpactSystem(**ASYM, left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95))
    sol = run(s, seed=3, n_paths=128, t_sample=50.0)
    back = Solution.load(sol.save(tmp_path / "walls"))
    assert back.impacts() == sol.impacts() and back.info == sol.info
    assert back.mean_x() == sol.mean_x() and back.mean_x_se() == sol.mean_x_se()


# -- the symmetric shorthand bit for bit -------------------------------------------
def _digest(sol):
    """SHA-1 (16 hex digits) of every moment, standard error, the impact rate, the
    sample count, the x range seen and every histogram array, with E[H] in hex."""
    h = hashlib.sha1()
    for d in (sol.moments(), sol.moments_se()):
        for k in sorted(d):
            h.update(f"{k}={float(d[k]).hex()};".encode())
    for v in (sol.impact_rate, sol.impact_rate_se, sol.n_samples, *sol.x_seen):
        h.update(float(v).hex().encode())
    for q in sol.quantities:
        for a in sol.histogram(q):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()[:16], float(sol.moments()["E_H"]).hex()


CASES = {
    "paper092": (lambda: VibroImpactSystem.paper(r=0.92),
                 dict(seed=1, n_paths=512, t_sample=50.0)),
    "paper098_right": (lambda: VibroImpactSystem.paper(r=0.98, barriers="right"),
                       dict(seed=2, n_paths=256, t_sample=50.0)),
    "none": (lambda: VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, D2=0.01,
                                       barriers="none"),
             dict(seed=3, n_paths=256, t_sample=50.0)),
    "hard03": (lambda: VibroImpactSystem.paper(r=0.3, D1=0.002),
               dict(seed=5, n_paths=256, t_sample=50.0)),
}
TRANSIENT = dict(initial={"mean": (0.0, 1.0), "std": (0.05, 0.05)}, times=(0.0, 5.0, 20.0),
                 seed=4, n_paths=512)


def record():
    """The digests of :data:`CASES` and of the transient of paper(r=0.92)."""
    out = {name: _digest(mc.stationary(make(), progress=False, **kw))
           for name, (make, kw) in CASES.items()}
    for sol in mc.transient(VibroImpactSystem.paper(r=0.92), progress=False, **TRANSIENT):
        out[f"transient t={sol.time:g}"] = _digest(sol)
    return out


#: Recorded with the Monte Carlo engine of commit d616586 (one restitution, walls at ±Δ
#: only), by :func:`record` (``python tests/test_walls_montecarlo.py`` prints it).
BEFORE = {
    "paper092": ("21cbcb85104146cd", "0x1.5ba68d1164b46p-3"),
    "paper098_right": ("7533535999dad47d", "0x1.3731d24c14972p-2"),
    "none": ("a3cde92fb61516cb", "0x1.e57542b789520p-3"),
    "hard03": ("a7e336a6f6eb72a2", "0x1.2a6ba56e40ce1p-4"),
    "transient t=0": ("ffb0a9990c20bbb8", "0x1.0102e4c2f445ep-1"),
    "transient t=5": ("915b690626f5f6cb", "0x1.59b534c50c145p-2"),
    "transient t=20": ("d383d3bede0edc1f", "0x1.98e2b0e43cf44p-3"),
}


def test_symmetric_shorthand_is_bit_identical():
    assert record() == BEFORE


if __name__ == "__main__":
    import json
    print(json.dumps(record(), indent=1))
