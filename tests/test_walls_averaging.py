"""Averaging with walls anywhere: exact checks, closed forms, preload, regression, errors."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import beta as B

from fpk_vibro import Solution, VibroImpactSystem as V, Wall, averaging, exact
from fpk_vibro.orbits import (energy_floor, energy_loss, energy_loss_first_order,
                              require_single_well, wall_energies)

from conftest import gauss_total

KW = dict(epsabs=1e-15, epsrel=1e-12, limit=500)
BASE = dict(a=1.0, b=0.2, c=0.025, D1=0.01)
ASYM = V(**BASE, left=Wall(-0.4), right=Wall(0.8))              # r = 1 both, D2 = 0
PRELOAD = V(**BASE, D2=0.01, right=Wall(-0.1, 0.8))


def integral(f, points):
    """∫ f over consecutive intervals of ``points`` (adaptive quadrature)."""
    return sum(quad(lambda t: float(f(np.array([t]))[0]), u, v, **KW)[0]
               for u, v in zip(points[:-1], points[1:]))


def energy_points(sol):
    """The floor, the wall energies and the end of the Φ panels: where p(H) kinks."""
    s = sol.system
    return sorted({energy_floor(s), *wall_energies(s), sol.H_end})


# -- the exact check: r = 1 at both walls, D2 = 0 -------------------------------------
GIBBS_WALLS = {
    "asymmetric": ASYM,
    "preload": V(**BASE, right=Wall(-0.1)),
    "one_side": V(**BASE, left=Wall(0.2), right=Wall(0.8)),
    "zero_offset": V(a=1.0, b=0.0, c=0.025, D1=0.01, right=Wall(0.0)),
    "side_well": V(a=-1.0, b=1.0, c=0.05, D1=0.02, left=Wall(1.1), right=Wall(2.0)),
}


@pytest.mark.parametrize("name", list(GIBBS_WALLS))
def test_gibbs_recovered_for_any_walls(name):
    system = GIBBS_WALLS[name]
    avg, ref = averaging.stationary(system), exact.gibbs(system)
    floor = energy_floor(system)
    H = floor + np.array([1e-9, 1e-3, 0.02, 0.05, 0.08, 0.1, 0.2, 0.3, 0.34, 0.5, 1.0])
    np.testing.assert_allclose(avg.pdf_energy(H), ref.pdf_energy(H), rtol=1e-8, atol=0)
    m, mr = avg.moments(), ref.moments()
    assert set(m) == set(mr) == {"E_H", "E_x2", "E_y2", "E_x4", "E_y4", "P_impact"}
    for k in m:
        assert m[k] == pytest.approx(mr[k], rel=1e-8), k
    assert avg.mean_x() == pytest.approx(ref.mean_x(), rel=1e-8)
    lo, hi = system.x_bounds
    x = np.linspace(max(lo, -1.5), min(hi, 2.5), 9)
    np.testing.assert_allclose(avg.pdf_x(x), ref.pdf_x(x), rtol=1e-8, atol=0)
    y = np.array([0.0, 1e-3, 0.05, 0.3, 0.8])
    np.testing.assert_allclose(avg.pdf_y(y), ref.pdf_y(y), rtol=1e-8, atol=0)


def test_asymmetric_gibbs_reference():
    """The Gibbs solution itself on walls (−0.4, 0.8): normalised, E[x] > 0, moments by quad."""
    g = exact.gibbs(ASYM)
    assert integral(g.pdf_x, [-0.4, 0.0, 0.8]) == pytest.approx(1.0, rel=1e-12)
    pts = [0.0, *wall_energies(ASYM), 30.0]
    assert integral(g.pdf_energy, pts) == pytest.approx(1.0, rel=1e-10)
    assert integral(lambda h: h * g.pdf_energy(h), pts) == pytest.approx(g.moments()["E_H"],
                                                                          rel=1e-10)
    Ex = integral(lambda x: x * g.pdf_x(x), [-0.4, 0.0, 0.8])
    assert g.mean_x() == pytest.approx(Ex, rel=1e-12) and g.mean_x() > 0.1
    assert exact.gibbs(V.paper(r=1.0, D2=0.0)).mean_x() == 0.0


@pytest.mark.parametrize("walls, match", [
    (dict(left=Wall(-0.4, 0.9), right=Wall(0.8)), "left r=0.9"),
    (dict(left=Wall(-0.4), right=Wall(0.8), D2=0.01), "D2"),
])
def test_gibbs_only_for_elastic_walls(walls, match):
    with pytest.raises(ValueError, match=match):
        exact.gibbs(V(**BASE, **walls))


# -- the zero offset: a linear spring with its wall at the equilibrium ---------------
def zero_offset(a, c, D1, D2, r):
    """Closed form of the averaged solution (docs/averaging_walls.md): every orbit is
    half an ellipse, T = π/ω, δ = (1 − r²)H, f = α/(β + γH)."""
    w = math.sqrt(a)
    lam1 = c + (1.0 - r * r) * w / math.pi                     # the energy decay rate
    lam = lam1 / D1
    out = dict(T=math.pi / w, m=lambda H: D1 + D2 * H / a - lam1 * H,
               s2=lambda H: 2 * D1 * H + D2 * H * H / a)
    if D2 == 0:
        EH, EH2, Esq = 1 / lam, 2 / lam ** 2, math.sqrt(math.pi) / (2 * math.sqrt(lam))
        out["pH"] = lambda H: lam * np.exp(-lam * H)
    else:
        nu = D2 / (2 * a * D1)
        k = lam / nu                                            # p ∝ (1 + νH)^−κ
        EH, EH2 = 1 / (nu * (k - 2)), 2 / (nu ** 2 * (k - 2) * (k - 3))
        Esq = (k - 1) * B(1.5, k - 1.5) / math.sqrt(nu)
        out["pH"] = lambda H: (k - 1) * nu * (1 + nu * H) ** -k
    out["moments"] = dict(E_H=EH, E_x2=EH / a, E_y2=EH, E_x4=1.5 * EH2 / a ** 2,
                          E_y4=1.5 * EH2, P_impact=1.0)
    out["E_x"] = -2 * math.sqrt(2) / (math.pi * w) * Esq
    out["lam"] = lam
    return out


@pytest.mark.parametrize("a, c, D1, D2, r", [
    (1.0, 0.025, 0.01, 0.0, 0.8), (2.25, 0.05, 0.02, 0.0, 0.5), (1.0, 0.0, 0.01, 0.0, 0.9),
    (1.0, 0.025, 0.01, 0.01, 0.8), (0.64, 0.1, 0.02, 0.004, 0.95),
])
def test_zero_offset_closed_form(a, c, D1, D2, r):
    system = V(a=a, b=0.0, c=c, D1=D1, D2=D2, right=Wall(0.0, r))
    ref = zero_offset(a, c, D1, D2, r)
    H = np.array([0.0, 1e-6, 0.01, 0.1, 0.5, 2.0])
    T, m, s2 = averaging.coefficients(system, H)
    np.testing.assert_allclose(T, ref["T"], rtol=1e-13)
    np.testing.assert_allclose(m, ref["m"](H), rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(s2, ref["s2"](H), rtol=1e-12, atol=0)
    sol = averaging.stationary(system)
    H = np.linspace(0.0, 10.0 / ref["lam"], 23)
    np.testing.assert_allclose(sol.pdf_energy(H), ref["pH"](H), rtol=1e-8, atol=0)
    for k, v in ref["moments"].items():
        assert sol.moments()[k] == pytest.approx(v, rel=1e-8), k
    assert sol.mean_x() == pytest.approx(ref["E_x"], rel=1e-8)
    if D2 == 0:            # p(x): half a Gaussian of variance 1/(λω²); p(y): a Gaussian
        lam, x, y = ref["lam"], np.linspace(-3, 0, 7) / math.sqrt(a * ref["lam"]), H
        px = 2 * math.sqrt(lam * a / (2 * math.pi)) * np.exp(-0.5 * lam * a * x * x)
        np.testing.assert_allclose(sol.pdf_x(x), px, rtol=1e-8, atol=0)
        py = math.sqrt(lam / (2 * math.pi)) * np.exp(-0.5 * lam * y * y)
        np.testing.assert_allclose(sol.pdf_y(y), py, rtol=1e-8, atol=0)
        assert sol.pdf_x(np.array([1e-9, 0.3])).tolist() == [0.0, 0.0]


# -- preload: the right wall left of the equilibrium ----------------------------------
def test_preload_density():
    sol = averaging.stationary(PRELOAD)
    GR = float(PRELOAD.potential(-0.1))
    assert energy_floor(PRELOAD) == GR
    H = np.linspace(0.0, 2.0, 401)
    p = sol.pdf_energy(H)
    assert np.all(p >= 0) and np.all(p[H <= GR] == 0) and np.all(p[H > GR] > 0)
    assert integral(sol.pdf_energy, energy_points(sol)) == pytest.approx(1.0, rel=1e-10)
    assert integral(sol.pdf_x, [-3.0, -0.1]) == pytest.approx(1.0, rel=1e-10)
    assert integral(sol.pdf_y, [-3.0, 0.0, 3.0]) == pytest.approx(1.0, rel=1e-10)
    assert sol.pdf_x(np.array([-0.05, 0.0, 0.3])).tolist() == [0.0, 0.0, 0.0]
    m = sol.moments()
    assert m["P_impact"] == 1.0 and m["E_H"] > GR
    Ex = integral(lambda x: x * sol.pdf_x(x), [-3.0, -0.1])
    assert sol.mean_x() == pytest.approx(Ex, rel=1e-9) and sol.mean_x() < -0.1
    T, m_, s2 = averaging.coefficients(PRELOAD, np.array([GR, GR + 1e-3]))
    assert T[0] == 0 and s2[0] == 0 and m_[0] == pytest.approx(0.01 + 0.01 * 0.01)
    with pytest.raises(ValueError, match="H"):
        averaging.coefficients(PRELOAD, np.array([0.5 * GR]))


def test_asymmetric_restitutions_consistent(tmp_path):
    """Walls (−0.4, 0.8) with r = 0.7, 0.95 and parametric noise: p(H) has kinks at both
    wall energies; every marginal integrates to 1 and gives the moments."""
    system = V(**BASE, D2=0.01, left=Wall(-0.4, 0.7), right=Wall(0.8, 0.95))
    sol = averaging.stationary(system)
    m, pts = sol.moments(), energy_points(sol)
    assert integral(sol.pdf_energy, pts) == pytest.approx(1.0, rel=1e-10)
    assert integral(lambda h: h * sol.pdf_energy(h), pts) == pytest.approx(m["E_H"], rel=1e-10)
    xb = [-0.4, 0.0, 0.4, 0.8]                      # p(y) kinks where y²/2 = E_j − E_i
    E = [0.0, *wall_energies(system)]
    ks = {math.sqrt(2 * (e2 - e1)) for e1 in E for e2 in E if e2 > e1}
    yb = sorted({-4.0, 0.0, 4.0, *ks, *(-k for k in ks)})
    assert gauss_total(sol.pdf_x, xb, 200) == pytest.approx(1.0, rel=1e-12)
    assert gauss_total(lambda x: x * x * sol.pdf_x(x), xb, 200) == pytest.approx(m["E_x2"],
                                                                                 rel=1e-12)
    assert gauss_total(lambda x: x * sol.pdf_x(x), xb, 200) == pytest.approx(sol.mean_x(),
                                                                            rel=1e-12)
    assert gauss_total(sol.pdf_y, yb, 200) == pytest.approx(1.0, rel=1e-9)
    assert gauss_total(lambda y: y * y * sol.pdf_y(y), yb, 200) == pytest.approx(m["E_y2"],
                                                                                rel=1e-9)
    back = Solution.load(sol.save(tmp_path / "asym"))             # three Φ regimes
    assert back.moments() == sol.moments() and back.mean_x() == sol.mean_x()
    z = np.linspace(-0.5, 1.0, 13)
    for f in ("pdf_x", "pdf_y", "pdf_energy"):
        assert np.array_equal(getattr(back, f)(np.abs(z)), getattr(sol, f)(np.abs(z)))


# -- the impact loss per quasi-period -------------------------------------------------
def test_energy_loss_forms():
    H = np.linspace(0.0, 2.0, 41)
    for r in (0.92, 0.5):                            # walls at ±Δ: the paper's (1 − r⁴)
        s = V.paper(r=r)
        expect = (1.0 - r ** 2 * r ** 2) * np.maximum(H - s.barrier_energy, 0.0)
        assert np.array_equal(energy_loss(s, H), expect)
        assert np.array_equal(energy_loss(s.replace(left=Wall(-0.6, r)), H), expect)
    one = V.paper(r=0.7, barriers="right")
    assert np.array_equal(energy_loss(one, H), energy_loss_first_order(one, H))
    s = V(**BASE, left=Wall(-0.4, 0.7), right=Wall(0.8, 0.9))
    GL, GR = (float(s.potential(x)) for x in (-0.4, 0.8))
    kL, kR = 1 - 0.7 ** 2, 1 - 0.9 ** 2

    def compound(H, first, second):                # impacts one after the other
        (k1, G1), (k2, G2) = first, second
        d1 = k1 * max(H - G1, 0.0)
        return d1 + k2 * max(H - d1 - G2, 0.0)
    for h in H:
        both = 0.5 * (compound(h, (kR, GR), (kL, GL)) + compound(h, (kL, GL), (kR, GR)))
        assert float(energy_loss(s, h)) == pytest.approx(both, rel=1e-14, abs=1e-300)
    between = H[(H > GL) & (H < GR)]                 # only the left wall is reached
    np.testing.assert_allclose(energy_loss(s, between), kL * (between - GL), rtol=1e-14)
    for r in (0.99, 0.999):                          # first order in 1 − r: the sum
        s = V(**BASE, left=Wall(-0.4, r), right=Wall(0.8, r ** 0.5))
        gap = energy_loss_first_order(s, H) - energy_loss(s, H)
        assert np.all(gap >= 0) and np.max(gap) < 4 * (1 - r) ** 2 * H.max()


# -- applicability --------------------------------------------------------------------
@pytest.mark.parametrize("system, why", [
    (V(a=-1.0, b=1.0, c=0.05, D1=0.05, left=Wall(-2.0), right=Wall(1.5)),
     "local maximum at x = 0 inside"),
    (V(a=1.0, b=-2.0, c=0.05, D1=0.05, left=Wall(-0.5), right=Wall(1.0)),
     "local maximum at x = 0.707107"),
    (V(a=-1.0, b=1.0, c=0.05, D1=0.05, left=Wall(0.2), right=Wall(3.0)),
     "decreases with |x|"),
    (V(a=1.0, b=-2.0, c=0.05, D1=0.05, left=Wall(0.8), right=Wall(1.5)),
     "decreases with |x|"),
    (V(a=0.0, b=0.0, c=0.05, D1=0.05, left=Wall(-1.0), right=Wall(0.5)), "free particle"),
])
def test_where_averaging_does_not_apply(system, why):
    for call in (lambda: averaging.stationary(system),
                 lambda: averaging.coefficients(system, np.array([0.1])),
                 lambda: require_single_well(system)):
        with pytest.raises(ValueError, match="increasing in") as err:
            call()
        assert why in str(err.value) and "\n" not in str(err.value)


# -- the transient averaged FPK on asymmetric walls -----------------------------------
@pytest.mark.parametrize("system, x0", [
    (V(**BASE, D2=0.01, left=Wall(-0.4, 0.7), right=Wall(0.8, 0.95)), 0.3),
    (PRELOAD, -0.3),
])
def test_transient_relaxes_to_stationary(system, x0):
    sols = averaging.transient(system, initial={"mean": (x0, 0.0), "std": (0.05, 0.05)},
                               times=[0.0, 400.0], n_cells=200)
    faces = sols[0].faces
    assert faces[0] == energy_floor(system) and set(wall_energies(system)) <= set(faces)
    st = averaging.stationary(system)
    assert all(abs(s.mass - 1) < 1e-12 and s.min_density >= 0 for s in sols)
    for k, v in sols[-1].moments().items():
        assert v == pytest.approx(st.moments()[k], rel=1e-3), k
    assert sols[-1].mean_x() == pytest.approx(st.mean_x(), rel=1e-3)


# -- walls at ±Δ (or one wall, or none): bit for bit their walls, to 1e-12 what they were
SYSTEMS = {
    "paper_0.92": V.paper(r=0.92),
    "paper_0.98": V.paper(r=0.98),
    "right": V.paper(r=0.9, barriers="right"),
    "left": V.paper(r=0.7, barriers="left"),
    "none": V.paper(barriers="none"),
    "softening": V.paper(r=0.5, b=-0.5, D1=0.2),
    "quartic": V(a=0.0, b=1.0, c=0.05, D1=0.02, D2=0.01, delta=0.5, r=0.9),
    "no_damping": V.paper(r=0.5, c=0.0),
}
INF = math.inf
REF = {  # computed at commit 21ee7c8, before averaging knew asymmetric walls
    'paper_0.92': [
        0.17129554275859615, 0.10298930101359519, 0.2375283453634981, 0.02073439140098955,
        0.1363168949725527, 0.35083370806670233, 4.383079079367761, 3.84553350006069,
        2.209190296093789, 0.799504478043382, 0.029753493510437864, 0.6140360611353344,
        0.9874378344596804, 0.8651617090733347, 0.5524587537112106, 0.7273032226814421,
        0.05034136322784875, 0.47926829931965637, 0.059628326845235766, 6.237064741233536,
        5.1129290120322555, 0.00923990516917125, 0.0047936842675515255, 0.0010285469555688209,
        0.005265882101437251
    ],
    'paper_0.98': [
        0.21606710711737043, 0.10523239046107351, 0.3247590648769611, 0.021427588967061213,
        0.28034398753954115, 0.4118393911334563, 3.971177327081606, 3.4841478260932037,
        2.0044405648103503, 0.845693089983161, 0.11607997947727942, 0.6436195889777813,
        0.9679364718472253, 0.8603619114237283, 0.5922913761267947, 0.6589545877512537,
        0.11586788864332198, 0.43422885359433594, 0.11748814722297182, 6.237064741233536,
        5.1129290120322555, 0.00923990516917125, 0.005338339727747934, 0.0010285469555688209,
        0.005265882101437251
    ],
    'right': [
        0.23798199095972403, 0.18473397961303598, 0.2814825664030389, 0.09747435903373138,
        0.21235753324479537, 0.4704683709640458, 3.575322739230433, 3.1368412748835492,
        1.9790057224938207, 1.0174197126378455, 0.13438655706950917, 0.5438760127328189,
        0.8416472204940657, 0.7434763043310743, 0.4957929273778649, 0.7017716000514026,
        0.08562075167369447, 0.39094408695839344, 0.08078237545587255, 6.237064741233536,
        5.611246883822281, 0.00923990516917125, 0.005795900877347239, 0.0010285469555688209,
        0.004820392180516979
    ],
    'left': [
        0.17972908548959218, 0.14741178324237578, 0.20662927595330752, 0.05417111783501086,
        0.10367886420140265, 0.3887345085102229, 4.127178229955886, 3.6210166087867823,
        2.279419335389436, 0.9383775982721071, 0.026852780615976773, 0.5419747833202445,
        0.9011634602170253, 0.7843952032581224, 0.48122051148463757, 0.7794276139019173,
        0.028485056323605408, 0.4512867907337388, 0.034114012052617465, 6.237064741233536,
        5.611246883822281, 0.00923990516917125, 0.005024877949720691, 0.0010285469555688209,
        0.004820392180516979
    ],
    'none': [
        0.5504611993538187, 0.45538399882512665, 0.5821535995300475, 0.6338480035246312,
        1.2317011450393214, 2.199833744912006, 1.9300437449199137, 1.327541304191125,
        0.9351634178552771, 0.36498890897230746, 0.4232395457046724, 0.5959946669692726,
        0.5380976027090352, 0.39672536670265973, 0.5622557227836043, 0.1643096460699432,
        0.24054108050955975, 0.0925118010710825, 6.237064741233536, 6.109564755612306,
        0.00923990516917125, 0.006847939026850571, 0.0010285469555688209, 0.004447573750341761
    ],
    'softening': [
        0.46720172849392433, 0.11663061576502247, 0.8239938021215663, 0.024883843594961187,
        1.5953627903748138, 0.6757852904899472, 1.9319568234132565, 1.9580412331665915,
        1.434061064463607, 0.8875459907968338, 0.36860983548552684, 0.7891429910330982,
        0.8629289629862871, 0.8403733161137663, 0.7756748005171566, 0.36637830637508684,
        0.26017080434053114, 0.3021631131456921, 0.2291341640814829, 6.407917401762596,
        4.793874992980916, 0.19927727791735234, 0.18780031400413036, 0.019826934667371995,
        0.10573951105723203
    ],
    'quartic': [
        0.10315349218537741, 0.08225487276028437, 0.20018274620348542, 0.012248476334538776,
        0.10381889148644854, 0.7518934539939663, INF, 4.651094280697914, 1.2076538448357896,
        0.41120543127739545, 0.013386401176667215, 0.0, 1.0113376463582744, 1.0039640163454926,
        0.0, 0.8099570165005613, 0.03362203611879547, 0.0, 0.03433580579339681,
        6.553834156689138, 3.187825420176596, 0.014397352366241088, -0.018732178054836242,
        0.00388298941059491, 0.016396502764287706
    ],
    'no_damping': [
        0.16520391546597832, 0.10903792291704652, 0.21912271851856752, 0.022471894963425644,
        0.09822937498866106, 0.37002158212820246, 3.423726235073261, 3.3985950024442495,
        2.7680033371432584, 0.8644299837080927, 0.0014018938760218507, 0.6840703735879876,
        0.9229565439333096, 0.861136190001462, 0.6229105438875425, 0.6538835449263768,
        0.010055993409508166, 0.544902954105314, 0.015871942316636658, 6.237064741233536,
        5.1129290120322555, 0.010494493728638862, 0.009077451758477555, 0.0010285469555688209,
        0.005265882101437251
    ],
    # the transient's flux became Scharfetter–Gummel's (issue 30: starts far above the
    # stationary energies); same limit, within 1e-7 at n_cells = 3200
    'transient': [
        0.09061896704036168, 0.07567325403133243, 0.10427765250701856, 0.012870275423723628,
        0.030796341762040748, 0.11331247140556089, 0.303010907937971, 1.270280605303433,
        0.8843434716473028, 0.2248438927309615, 1.178998373160763, 0.0022261866160345877
    ],
}


def regression_values(name, walls=False):
    """The values of REF: moments, p(H), p(x), p(y), p(x, y), T, m, σ² (stationary), or
    moments, p(x), p(y) of one transient time (``walls``: the system given wall by wall)."""
    H, X, Y = (np.array([0.0, 0.05, 0.2, 0.35, 0.8]), np.array([-0.55, 0.0, 0.3, 0.6]),
               np.array([0.0, -1.1]))
    if name == "transient":
        tr = averaging.transient(_walls(SYSTEMS["paper_0.92"], walls), times=[5.0], n_cells=64,
                                 initial={"mean": (0.3, 0.0), "std": (0.05, 0.05)})[0]
        return list(tr.moments().values()) + list(tr.pdf_x(X)) + list(tr.pdf_y(Y))
    s = _walls(SYSTEMS[name], walls)
    sol = averaging.stationary(s)
    T, m, s2 = averaging.coefficients(s, H[1:3])
    with np.errstate(divide="ignore"):
        pH = sol.pdf_energy(H)
    return (list(sol.moments().values()) + list(pH) + list(sol.pdf_x(X)) + list(sol.pdf_y(Y))
            + list(sol.pdf_joint(X[:2], Y)) + list(T) + list(m) + list(s2))


def _walls(s, walls=True):
    """``s`` given wall by wall instead of by the shorthand (``walls`` False: ``s``)."""
    if not walls:
        return s
    return V(a=s.a, b=s.b, c=s.c, D1=s.D1, D2=s.D2, left=s.left, right=s.right)


@pytest.mark.parametrize("name", [n for n in REF if n != "none"])
def test_symmetric_shorthand_bit_identical_to_its_walls(name):
    """Bit for bit, in one process: the shorthand and the same walls one by one."""
    got = [float(v) for v in regression_values(name)]
    walls = [float(v) for v in regression_values(name, walls=True)]
    assert [v.hex() for v in walls] == [v.hex() for v in got]


@pytest.mark.parametrize("name", list(REF))
def test_symmetric_results_as_before_walls(name):
    """REF at 1e-12 relative (0 and ∞ exactly): round-off of another CPU's BLAS and
    vectorised exp/log (measured across two machines: last bits of the transient,
    the stationary values identical); any change of the method moves them by far more."""
    got = [float(v) for v in regression_values(name)]
    np.testing.assert_allclose(got, REF[name], rtol=1e-12, atol=0)
