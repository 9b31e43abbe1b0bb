"""The structured-mesh evaluation (fpk_vibro/fem/tensor_eval.py) against the general
skfem path (2-D basis, probes, inverse bilinear map) on the same p_h: moments,
resolution diagnostics, level split, power balance, impacts and every pdf agree to
1e-12 for degrees 1 and 2 (issue 23, §5: the tensor path is what runs at 10⁶ DOFs;
the measured times are in the benchmark and docs/measurements.md, §Scale)."""
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, fem
from fpk_vibro.fem import FEMSolution
from fpk_vibro.model import Wall

P = VibroImpactSystem.paper
TOL = 1e-12
CASES = {
    "paper": (P(r=0.92), dict(nx=24, ny=48)),      # (the default solve is Q4: no 2-D basis)
    "coarse_negative": (P(r=0.92), dict(nx=4, ny=2, positivity=False)),   # moments of p₊
    "r0": (P(r=0.0, D2=0.0), dict(nx=16, ny=32, positivity=False)),
    "double_well": (VibroImpactSystem(a=-1.0, b=1.0, c=0.1, D1=0.05, delta=2.0, r=0.9),
                    dict(nx=20, ny=40)),
    "asymmetric": (VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01,
                                     left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95)),
                   dict(nx=18, ny=36)),
    "one_wall_graded": (VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.02, right=Wall(0.5, r=0.8)),
                        dict(nx=16, ny=32, grading=2.0)),
}


def _pair(name, degree):
    system, kw = CASES[name]
    kw = dict(kw)
    if degree == 2 and "nx" in kw:
        kw["nx"], kw["ny"] = max(2, kw["nx"] // 2), max(2, kw["ny"] // 2)
    sol = fem.stationary(system, degree=degree, **kw)
    assert sol._tensor is not None
    general = FEMSolution(sol.system, sol.mesh, sol.degree, sol.dofs, mass=sol.mass,
                          info={"nonnegative": sol.info.get("nonnegative", False)})
    return sol, general


def _close(a, b, scale=None):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = np.max(np.abs(b)) if scale is None else scale
    assert np.max(np.abs(a - b), initial=0.0) <= TOL * max(scale, 1e-300)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("name", sorted(CASES))
def test_tensor_path_agrees_with_skfem_path(name, degree):
    sol, gen = _pair(name, degree)
    assert gen._field() is None
    # moments and the resolution diagnostics (which density they are of, too)
    m, g = sol.moments(), gen.moments()
    assert m.keys() == g.keys()
    for k in m:
        _close(m[k], g[k])
    r, rg = sol.resolution(), gen.resolution()
    assert r["moments_of"] == rg["moments_of"] and r["under_resolved"] == rg["under_resolved"]
    _close(r["negative_mass"], rg["negative_mass"], scale=1.0)
    _close(r["moment_shift"], rg["moment_shift"], scale=max(rg["moment_shift"], 1e-3))
    for level in (0.05, sol.system.barrier_energy if sol.system.has_barrier else 0.3, 2.0):
        for positive in (False, True):
            _close(sol.energy_split(level, positive=positive),
                   gen.energy_split(level, positive=positive), scale=sol.mass)
    # power balance and the wall statistics
    pb, pg = sol.power_balance(), gen.power_balance()
    for k in ("noise", "damping", "impacts"):
        _close(pb[k], pg[k], scale=pg["noise"])
    _close(pb["residual"], pg["residual"], scale=1.0)
    ims, img = sol.impacts(), gen.impacts()
    for side in img:
        for k in img[side]:
            _close(ims[side][k], img[side][k])
    # every pdf, at points inside, on the mesh lines, on the edges and outside
    x0, x1, Y = sol._x0, sol._x1, sol.y_max
    xs, ys = sol._tensor
    x = np.concatenate([np.linspace(x0 - 0.1, x1 + 0.1, 61), xs[::3], [x0, x1]])
    y = np.concatenate([np.linspace(-1.1 * Y, 1.1 * Y, 47), ys[::3], [-Y, Y]])
    X, Yg = np.meshgrid(x, y)
    _close(sol.pdf_joint(X, Yg), gen.pdf_joint(X, Yg))
    _close(sol.pdf_x(x), gen.pdf_x(x))
    _close(sol.pdf_y(y), gen.pdf_y(y))
    H = np.linspace(0.0, 3.0, 31)
    _close(sol.pdf_energy(H), gen.pdf_energy(H))


def test_tensor_path_never_builds_the_2d_basis():
    """Solve, moments, power balance, impacts and pdfs of a tensor density run on
    the 1-D bases only (the 2-D basis of 10⁶ cells took 2 s and ~1 GB a pass)."""
    for degree in (1, 2):
        sol = fem.stationary(P(r=0.92), nx=16, ny=32, degree=degree)
        sol.moments(), sol.power_balance(), sol.impacts(), sol.resolution()
        sol.pdf_joint(0.1, 0.2), sol.pdf_x([0.0]), sol.pdf_y([0.0]), sol.pdf_energy([0.1])
        sol.impact_speed_pdf("right", [0.1, 0.5])
        assert sol._basis is None


def test_tensor_point_values_at_nodes_are_the_dofs():
    """At the DOF locations (vertices, and Q2 edge/cell midpoints) p_h is the DOF."""
    for degree in (1, 2):
        sol = fem.stationary(P(r=0.92), nx=10, ny=20, degree=degree)
        X = sol._doflocs().doflocs
        _close(sol.pdf_joint(X[0], X[1]), sol.dofs)
