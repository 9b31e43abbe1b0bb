"""Monte Carlo impact-speed densities: the histogram of the speeds recorded at each
located impact against the exact Rayleigh density (r = 1, D2 = 0), kept only when
asked for, saved and loaded, and its bad inputs."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fpk_vibro import Solution, VibroImpactSystem, Wall
from fpk_vibro import montecarlo as mc
from fpk_vibro.montecarlo import _setup as S

# r = 1, D2 = 0: p(x, y) = p_X(x) N(y; 0, σ²), σ² = D1/c, so the speed just before an
# impact, whose density is ∝ u p(x_w, u), is Rayleigh(σ) at either wall
EXACT = VibroImpactSystem(a=1.0, b=0.2, c=0.025, D1=0.01, left=Wall(-0.4, r=1.0),
                          right=Wall(0.8, r=1.0))
SIG2 = EXACT.D1 / EXACT.c


def rayleigh_bins(edges):
    """Exact mean density of the Rayleigh law over each bin."""
    cdf = -np.expm1(-edges ** 2 / (2.0 * SIG2))
    return np.diff(cdf) / np.diff(edges)


@pytest.fixture(scope="module")
def exact_run():
    return mc.stationary(EXACT, seed=11, n_paths=1024, t_sample=2000.0,
                         quantities=("x", "impacts"), progress=False)


@pytest.mark.parametrize("wall", ["left", "right"])
def test_impact_speeds_follow_the_rayleigh_density(exact_run, wall):
    edges, dens, se = exact_run.impact_speed_histogram(wall)
    assert edges[0] == 0.0 and edges.size == 101
    # the bins cover the impacts: sqrt(2 (H_max − G(x_w))) is several σ
    assert edges[-1] > 4.0 * math.sqrt(SIG2)
    assert exact_run.overflow[f"impacts_{wall}"] < 1e-3
    z = (dens - rayleigh_bins(edges)) / se
    assert np.all(np.isfinite(z))
    # per bin within 4 SE, with the multiple-testing slack of 1 bin in 100
    assert np.sum(np.abs(z) > 4.0) <= 1, np.round(z, 1)
    # and no systematic misfit: the sum of squares is that of 100 independent errors
    assert 0.6 < np.mean(z ** 2) < 1.6
    # the density holds every impact counted for the wall
    mass = float(np.sum(dens * np.diff(edges)))
    assert mass == pytest.approx(1.0 - exact_run.overflow[f"impacts_{wall}"], abs=1e-12)
    # impact_speed_pdf is the histogram, zero beyond it
    mid = 0.5 * (edges[1:] + edges[:-1])
    assert np.array_equal(exact_run.impact_speed_pdf(wall, mid), dens)
    assert exact_run.impact_speed_pdf(wall, [-0.1, edges[-1] * 1.01]).tolist() == [0.0, 0.0]
    # its mean is the recorded mean speed (to the bin width)
    u = exact_run.impacts()[wall]
    mean_h = float(np.sum(mid * dens * np.diff(edges)))
    assert mean_h == pytest.approx(u["mean_speed"], abs=0.5 * (edges[1] - edges[0]))
    assert u["mean_speed"] == pytest.approx(math.sqrt(math.pi * SIG2 / 2.0),
                                            abs=4 * u["mean_speed_se"])


def test_impact_speeds_are_only_kept_when_asked():
    kw = dict(seed=3, n_paths=256, t_sample=100.0, progress=False)
    plain = mc.stationary(EXACT, quantities=("x",), **kw)
    asked = mc.stationary(EXACT, quantities=("x", "impacts"), **kw)
    assert "impacts" not in plain.quantities and "impacts" in asked.quantities
    assert not any(k.startswith(("edges_u", "density_u")) for k in plain._arrays)
    # the default histograms do not include it, and their kernel array is empty
    assert "impacts" not in mc.QUANTITIES and "impacts" in mc.ALL_QUANTITIES
    hist = S.Histograms(EXACT, mc.QUANTITIES, S.check_bins("bins", 50, "t"), 4, 1.0)
    assert hist.hu.shape == (4, 2, 0)
    # counting the speeds changes nothing else, to the bit
    assert plain.moments() == asked.moments() and plain.impacts() == asked.impacts()
    assert np.array_equal(plain.histogram("x")[1], asked.histogram("x")[1])
    with pytest.raises(ValueError, match="quantities including 'impacts'"):
        plain.impact_speed_histogram("left")
    with pytest.raises(ValueError, match="wall"):
        asked.impact_speed_pdf("middle", [0.1])


def test_impact_speed_histogram_survives_save_and_load(tmp_path, exact_run):
    path = exact_run.save(tmp_path / "mc.npz")
    back = Solution.load(path)
    for wall in ("left", "right"):
        for a, b in zip(exact_run.impact_speed_histogram(wall),
                        back.impact_speed_histogram(wall)):
            assert np.array_equal(a, b, equal_nan=True)
    assert back.overflow == exact_run.overflow


def test_given_edges_and_one_wall():
    one = VibroImpactSystem.paper(r=0.8, D2=0.0, barriers="right")
    edges = np.linspace(0.0, 2.0, 41)
    sol = mc.stationary(one, seed=5, n_paths=256, t_sample=200.0, progress=False,
                        quantities=("impacts",), bins={"impacts": edges})
    e, dens, se = sol.impact_speed_histogram("right")
    assert np.array_equal(e, edges) and dens.sum() > 0 and np.all(np.isfinite(se))
    with pytest.raises(ValueError, match="wall"):
        sol.impact_speed_histogram("left")


@pytest.mark.parametrize("call, name", [
    (lambda: mc.transient(EXACT, initial={"mean": (0.0, 0.0), "std": (0.1, 0.1)},
                          times=[1.0], quantities=("impacts",), n_paths=64), "quantities"),
    (lambda: mc.stationary(VibroImpactSystem.paper(barriers="none"), quantities=["impacts"],
                           n_paths=64, t_sample=10.0), "quantities"),
    (lambda: mc.stationary(EXACT, quantities=["impacts", "impact"], n_paths=64,
                           t_sample=10.0), "quantities"),
    (lambda: mc.stationary(EXACT, quantities=["impacts"], bins={"impacts": [0.5, 1.0, 1.5]},
                           n_paths=64, t_sample=10.0), "bins['impacts']"),
    (lambda: mc.stationary(EXACT, quantities=["impacts"], bins={"impacts": 0},
                           n_paths=64, t_sample=10.0), "bins['impacts']"),
])
def test_bad_impact_requests_are_one_line_errors(call, name):
    with pytest.raises(ValueError) as err:
        call()
    msg = str(err.value)
    assert name in msg and "\n" not in msg
