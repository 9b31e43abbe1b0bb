"""Monte Carlo with walls anywhere: the exact Gibbs density and wall fluxes on an
asymmetric strip, each wall with its own restitution, a preloaded wall, a left wall
alone, and the symmetric shorthand bit for bit as the same walls given one by one (in
one process) and to 1e-12 as before walls could be given one by one (stored values)."""
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
    sample count, the x range seen and every histogram array, with E[H] in hex: for
    comparing two runs in one process (never against a stored value: the bits of
    another machine may differ)."""
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


def _summary(sol):
    """Numbers to compare with a stored value at a tolerance: every moment and standard
    error, the impact rate and its SE, the sample count, the x range seen, and of each
    histogram (density, SE) the sums Σ p_k, Σ k p_k, Σ p_k² and Σ se_k²."""
    out = [float(sol.moments()[k]) for k in sorted(sol.moments())]
    out += [float(sol.moments_se()[k]) for k in sorted(sol.moments_se())]
    out += [float(sol.impact_rate), float(sol.impact_rate_se), float(sol.n_samples),
            *map(float, sol.x_seen)]
    for q in sol.quantities:
        *_, dens, se = sol.histogram(q)
        k = np.arange(dens.size).reshape(dens.shape)
        out += [float(np.sum(dens)), float(np.sum(k * dens)), float(np.sum(dens ** 2)),
                float(np.sum(se ** 2))]
    return out


#: The defaults of commit d616586 for these runs, given explicitly: the regression
#: below is of the engine, not of the default step (changed by issue 22 §1).
CASES = {
    "paper092": (lambda: VibroImpactSystem.paper(r=0.92),
                 dict(seed=1, n_paths=512, t_sample=50.0, dt=0.050570963680874145)),
    "paper098_right": (lambda: VibroImpactSystem.paper(r=0.98, barriers="right"),
                       dict(seed=2, n_paths=256, t_sample=50.0, dt=0.041233982789105214)),
    "none": (lambda: VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, D2=0.01,
                                       barriers="none"),
             dict(seed=3, n_paths=256, t_sample=50.0, dt=0.045204377811457704)),
    "hard03": (lambda: VibroImpactSystem.paper(r=0.3, D1=0.002),
               dict(seed=5, n_paths=256, t_sample=50.0, dt=0.050570963680874145)),
}
for _, _kw in CASES.values():
    _kw["sample_every"] = 30
TRANSIENT = dict(initial={"mean": (0.0, 1.0), "std": (0.05, 0.05)}, times=(0.0, 5.0, 20.0),
                 seed=4, n_paths=512, dt=0.050570963680874145)


def _walls(s):
    """``s`` given wall by wall (a system without walls as it is)."""
    if not s.has_barrier:
        return s
    return VibroImpactSystem(a=s.a, b=s.b, c=s.c, D1=s.D1, D2=s.D2, left=s.left,
                             right=s.right)


def runs(walls=False):
    """{case: solution} of :data:`CASES` and of the transient of paper(r=0.92)
    (``walls``: each system given wall by wall)."""
    sys_ = (lambda s: _walls(s)) if walls else (lambda s: s)
    out = {name: mc.stationary(sys_(make()), progress=False, **kw)
           for name, (make, kw) in CASES.items()}
    for sol in mc.transient(sys_(VibroImpactSystem.paper(r=0.92)), progress=False,
                            **TRANSIENT):
        out[f"transient t={sol.time:g}"] = sol
    return out


@pytest.fixture(scope="module")
def shorthand_runs():
    return runs()


def test_symmetric_shorthand_is_bit_identical_to_its_walls(shorthand_runs):
    """Bit for bit, in one process: the shorthand and the same walls one by one."""
    walls = runs(walls=True)
    for name, sol in shorthand_runs.items():
        if name != "none":
            assert _digest(walls[name]) == _digest(sol), name


def record():
    """The :func:`_summary` of each of :func:`runs` (``python
    tests/test_walls_montecarlo.py`` prints it)."""
    return {name: _summary(sol) for name, sol in runs().items()}


#: :func:`record` at commit 5a917b5 on a machine where every run had the SHA-1
#: digest (:func:`_digest`) of the Monte Carlo engine of commit d616586 (one
#: restitution, walls at ±Δ only) on the machine that recorded those, bit for bit.
nan = float("nan")       # the impact rate of a transient time
BEFORE = {
    'hard03': [0.07285656567914912, 0.06888653518638428, 0.01119854287320192,
                0.07570674188459377, 0.014119783895074503, 0.05078125, 0.002760915999656814,
                0.0024808378179237314, 0.0006155096256017955, 0.003000522243799729,
                0.0008703795002314853, 0.005394668524960883, 0.02264959868243737,
                0.002247035804468422, 8192.0, -0.5998429682242651, 0.5999609636252179,
                141.973834557374, 1399.1147050557622, 892.1206678793352, 5.791954510375155,
                83.3333333333333, 4122.823079427083, 86.75745791859093, 0.8921602934492102,
                42.12686710363323, 2086.6889501438095, 41.906473048351295, 0.24744379329578275,
                877.6430646590256, 1096000.0591948775, 978.2697910845638, 97.44369701248044],
     'none': [0.23704006311997095, 0.21529836130942817, 0.13999451514712297,
              0.24478231341580145, 0.19865937533174172, 0.010754008759877628,
              0.008974232268224639, 0.014650828769392596, 0.011309277209567554,
              0.027256693131993897, 0.0, 0.0, 9216.0, -1.999272045883065, 2.056038031758015,
              27.68559467595534, 168.0724402997606, 60.54043460722622, 0.2252737224550273,
              22.679005875192964, 1123.4450120668098, 13.767727321960821, 0.060412660394444526,
              18.603964322570338, 920.817506253627, 10.768776634067498, 0.04073118856879983,
              105.47985404336325, 131884.40524071874, 38.498590364457996, 1.2502229722907257],
     'paper092': [0.16975126466112495, 0.10462871149917671, 0.021166689136274328,
                  0.23275714890944577, 0.12622334726730836, 0.35479736328125,
                  0.004303658903427364, 0.0016104393922088372, 0.00048146939893054446,
                  0.007384573059086527, 0.006014969678204836, 0.013308603504514353,
                  0.19970697872755983, 0.00819486001743923, 16384.0, -0.5999468770325237,
                  0.5996471182376836, 58.037348368893056, 543.267696081255, 157.90239208971283,
                  0.37553717991992, 83.33333333333333, 4119.349161783854, 71.38075307011603,
                  0.4153882276840962, 26.934491912994446, 1333.8919147492807,
                  15.125753503615526, 0.051711411791877444, 561.1352481873843, 700206.851922808,
                  285.03247660101977, 19.47303707482274],
     'paper098_right': [0.30390099133833026, 0.22550965749034435, 0.16387899372947812,
                        0.3659044258133684, 0.39362634706048355, 0.529296875,
                        0.01441245061665264, 0.00915663880047381, 0.01576560014906203,
                        0.01821359415499321, 0.04438191203041301, 0.018459906210102645,
                        0.12105302504307758, 0.00486029098388981, 10240.0, -2.2056030765669914,
                        0.5999091078863191, 20.19578739242279, 114.11014325691387,
                        33.83519088333115, 0.11691634276168973, 32.49626384271024,
                        2440.513843073262, 20.62747635833114, 0.11020259676005888,
                        15.888591580290718, 786.8856012544409, 7.367480543713993,
                        0.02909440163354169, 129.07996602054786, 243851.35478039083,
                        39.00240827165055, 1.689688012138705],
     'transient t=0': [0.5019752014142218, 0.002384802775346768, 1.6264467224498744e-05,
                       1.0015639736063744, 1.0128399343123236, 1.0, 0.0021940833772250566,
                       0.0001319120618237448, 1.9664013997902322e-06, 0.004398169938860212,
                       0.008954857974164584, 0.0, nan, nan, 512.0, -0.15964776765886057,
                       0.128302491289424, 86.4608431996092, 3708.8662093613616,
                       504.34605948044646, 12.990729047547852, 50.000000000000014,
                       1475.8789062500002, 287.8952026367188, 4.219547394783266,
                       25.464805595116356, 1399.3706449691283, 142.51276297805447,
                       1.0612818944575424, 318.3100699389547, 147301.71506038337,
                       9557.62146699401, 180.83684912138426],
     'transient t=20': [0.1996511287358037, 0.11518665999872373, 0.023839106095978474,
                        0.28173168686328576, 0.1692437762254631, 0.41015625,
                        0.007151871431276946, 0.004397299115281412, 0.0013655171693717153,
                        0.011934359789399003, 0.012967054391190279, 0.02380218627186512,
                        0.351171875, 0.01069558434301577, 512.0, -0.5885249995141917,
                        0.5994310245082035, 70.51987244116896, 956.2880358574923,
                        184.01568744068837, 9.612631919914644, 50.0, 1475.9765625000002,
                        45.166015625, 4.823746219758067, 22.997805184598967, 674.9765986503293,
                        12.944855735279262, 1.081948765904204, 287.47256480748706,
                        129277.31074569197, 285.6150467620748, 161.95632111132954],
     'transient t=5': [0.33760530903511593, 0.1311642563405766, 0.029492182807914435,
                       0.5410971434488637, 0.4178414036139919, 0.80859375, 0.007587279436725866,
                       0.004916115580174582, 0.0016755782083600873, 0.016326283875701827,
                       0.024693590188896355, 0.02041836170479065, 0.65625, 0.007756858307746225,
                       512.0, -0.5999541631357667, 0.5928843906974746, 54.785968917267574,
                       986.3614482018995, 104.76588009019794, 5.83940970994546,
                       50.00000000000001, 1293.9453125000002, 47.68371582031253,
                       4.8409738848286334, 20.27053938304324, 594.8136400211752,
                       13.075577336535833, 0.7625844246743388, 253.3817422880405,
                       100101.624562669, 289.48641684745394, 121.61874081517674]}


def test_symmetric_shorthand_gives_the_values_before_walls(shorthand_runs):
    """1e-12 relative: the kernel rounds alike on every x86-64 CPU (+, ×, explicit
    FMA, sqrt; no fast-math) and was bit-identical across two machines; only libm's
    exp/log (tails of the normal generator) may differ in the last bit elsewhere.
    Any change of the engine moves these numbers by far more."""
    got = {name: _summary(sol) for name, sol in shorthand_runs.items()}
    assert got.keys() == BEFORE.keys()
    for name in BEFORE:
        np.testing.assert_allclose(got[name], BEFORE[name], rtol=1e-12, atol=0,
                                   err_msg=name)


if __name__ == "__main__":
    import json
    print(json.dumps(record(), indent=1))
