"""Finite elements with walls anywhere: the exact Gibbs density on an asymmetric strip
at the design order, conservation with a different r on each wall, and the symmetric
shorthand bit for bit as before walls could be given one by one."""
import hashlib

import numpy as np
import pytest
from scipy import integrate

from fpk_vibro import VibroImpactSystem, Wall, fem

ASYM = dict(a=1.0, b=0.2, c=0.025, D1=0.01)


def gibbs_moments(system):
    """E[x], E[x²], E[y²], E[H] of p ∝ exp(−c H / D1) on the strip, by quadrature."""
    beta = system.c / system.D1
    lo, hi = system.x_bounds

    def avg(f):
        w = lambda x: np.exp(-beta * system.potential(x))
        num = integrate.quad(lambda x: f(x) * w(x), lo, hi, epsabs=0, epsrel=1e-13)[0]
        return num / integrate.quad(w, lo, hi, epsabs=0, epsrel=1e-13)[0]
    Ey2 = 1.0 / beta
    return {"E_x": avg(lambda x: x), "E_x2": avg(lambda x: x * x), "E_y2": Ey2,
            "E_H": avg(system.potential) + 0.5 * Ey2}


def errors(sol, exact):
    m = sol.moments()
    got = {"E_x": sol.mean_x(), "E_x2": m["E_x2"], "E_y2": m["E_y2"], "E_H": m["E_H"]}
    return {k: abs(got[k] / exact[k] - 1) for k in exact}


def test_asymmetric_elastic_walls_are_the_gibbs_density_at_order_two():
    """Q1: errors fall 4× per halving of h (measured: E[x] 4.3e-4, 1.1e-4, 2.7e-5 at
    nx = 32, 64, 128); Q2 at nx = 32 within 3e-7."""
    s = VibroImpactSystem(**ASYM, left=Wall(-0.4), right=Wall(0.8))
    exact = gibbs_moments(s)
    assert exact["E_x"] > 0.1                       # the asymmetry shows
    e = [errors(fem.stationary(s, nx=n, y_max=4.0, positivity=False), exact)
         for n in (32, 64, 128)]
    for k in ("E_x", "E_x2", "E_H"):
        orders = np.log2([e[i][k] / e[i + 1][k] for i in range(2)])
        assert np.all(orders > 1.8), (k, orders)
    q2 = errors(fem.stationary(s, nx=32, degree=2, y_max=4.0), exact)
    assert max(q2.values()) < 3e-7, q2


def test_each_wall_keeps_mass_with_its_own_restitution():
    s = VibroImpactSystem(**ASYM, D2=0.01, left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95))
    sol = fem.stationary(s, nx=48)
    assert abs(sol.mass - 1) < 1e-12 and sol.min_density >= -1e-6 * sol.dofs.max()
    tr = fem.transient(s, initial={"mean": (0.2, 0.3), "std": (0.1, 0.2)}, times=[2.0, 6.0],
                       nx=16)
    assert all(abs(t.mass - 1) < 1e-11 for t in tr)
    # the less elastic left wall takes more energy: fewer fast states near it than near
    # the right wall, relative to the elastic-walls density
    el = fem.stationary(s.replace(left=Wall(-0.4), right=Wall(0.8)), nx=48)
    assert sol.moments()["E_H"] < el.moments()["E_H"]


def test_walls_on_one_side_of_the_equilibrium_and_at_it():
    """Preload (right wall at x = −0.1) and zero offset (x = 0): normalised,
    non-negative, all mass left of the wall."""
    for wall in (Wall(-0.1, r=0.8), Wall(0.0, r=0.8)):
        s = VibroImpactSystem(a=1.0, b=0.0, c=0.05, D1=0.01, right=wall)
        sol = fem.stationary(s, nx=48)
        assert abs(sol.mass - 1) < 1e-12
        assert sol.min_density >= -1e-6 * sol.dofs.max()
        assert sol.mean_x() < wall.position
        assert sol.pdf_x(np.array([wall.position + 0.05]))[0] == 0.0


#: E[H] and the SHA-1 of the nodal values at nx = 32 (Q1, default options) and of a
#: transient (nx = 16), computed with the code before walls could be given one by one
#: (commit 1ddf3bc) by the same calls as the tests below.
BEFORE = {
    "paper092": ("2e9a3faa06a1f489", 0.16611374305448173),
    "paper098_right": ("8c09f3b02218bc8b", 0.36848662045694963),
    "none": ("0fb8d431a883a687", 0.19540847635599926),
    "hard03": ("b134024e9ad8ab80", 0.07202652851462772),
}


@pytest.mark.parametrize("name", sorted(BEFORE))
def test_symmetric_shorthand_is_bit_identical(name):
    s = {"paper092": VibroImpactSystem.paper(r=0.92),
         "paper098_right": VibroImpactSystem.paper(r=0.98, barriers="right"),
         "none": VibroImpactSystem(a=1, b=0.2, c=0.05, D1=0.01, barriers="none"),
         "hard03": VibroImpactSystem.paper(r=0.3, D1=0.002)}[name]
    sol = fem.stationary(s, nx=32)
    assert (hashlib.sha1(sol.dofs.tobytes()).hexdigest()[:16], sol.moments()["E_H"]) \
        == BEFORE[name]
    if s.has_barrier:            # the same system given by walls, so the same bits
        assert VibroImpactSystem(a=s.a, b=s.b, c=s.c, D1=s.D1, D2=s.D2, left=s.left,
                                 right=s.right) == s


def test_transient_bit_identical():
    s = VibroImpactSystem.paper(r=0.92)
    tr = fem.transient(s, initial={"mean": (0.0, 1.0), "std": (0.0, 0.05)}, times=[1.0, 3.0],
                       nx=16)
    assert hashlib.sha1(tr[-1].dofs.tobytes()).hexdigest()[:16] == "e21f17611704fb6b"
