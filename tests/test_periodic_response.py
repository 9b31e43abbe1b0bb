"""PeriodicResponse: the result type of fem.periodic / montecarlo.periodic (method-agnostic)."""
import json

import numpy as np
import pytest

from fpk_vibro import Harmonic, VibroImpactSystem, exact
from fpk_vibro._checks import InputError
from fpk_vibro.periodic import PeriodicResponse


@pytest.fixture(scope="module")
def response():
    s = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, delta=0.6, r=1.0,
                          forcing=Harmonic(0.05, 0.9))
    g = exact.gibbs(s.replace(forcing=None))
    phases = np.arange(4) * np.pi / 2
    return PeriodicResponse("exact", s, phases, [g] * 4, g, amplitude=0.2, lag=7.0,
                            mean_x=0.0, estimate=lambda: {"amplitude": 1e-3, "lag": 2e-3,
                                                          "mean_x": 0.0},
                            info={"K": 3, "list": [1, 2]})


def test_access_and_phase_moments(response):
    g = response.average()
    assert response.at(3) is g and len(response) == 4
    assert response.lag == pytest.approx(7.0 - 2 * np.pi)
    m = response.moments_vs_phase()
    assert set(m) == {"E_x", "E_x2", "E_y2", "E_H"}
    assert np.all(m["E_x2"] == g.moments()["E_x2"])
    rates = response.impact_rates()
    assert set(rates) == {"left", "right"}
    assert np.all(rates["left"] == g.impacts()["left"]["rate"])
    assert response.mean_at(response.lag) == pytest.approx(0.2)


def test_estimate_and_dict(response):
    est = response.error_estimate()
    assert est["amplitude"] == 1e-3 and est["lag"] == 2e-3
    assert len(est["phases"]) == 4 and "E_H" in est["average"]
    d = response.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["info"] == {"K": 3} and d["estimate"]["lag"] == 2e-3


def test_save_load_round_trip(response, tmp_path):
    response.error_estimate()
    path = response.save(tmp_path / "run")
    assert (path / "manifest.json").is_file()
    back = PeriodicResponse.load(path)
    assert back.method == "exact" and back.system == response.system
    assert np.array_equal(back.phases, response.phases)
    assert (back.amplitude, back.lag, back.mean_x) == (response.amplitude, response.lag,
                                                       response.mean_x)
    assert back.error_estimate()["lag"] == 2e-3
    x = np.linspace(-0.5, 0.5, 7)
    assert np.array_equal(back.at(2).pdf_x(x), response.at(2).pdf_x(x))
    response.save(path)                       # overwrites its own directory


@pytest.mark.parametrize("bad", [4, -5, 1.0, True])
def test_at_refuses(response, bad):
    with pytest.raises(InputError, match="PeriodicResponse.at: i must be"):
        response.at(bad)


def test_refusals(response, tmp_path):
    g = response.average()
    with pytest.raises(InputError, match="phases"):
        PeriodicResponse("x", response.system, [7.0], [g], g, amplitude=0, lag=0, mean_x=0)
    with pytest.raises(InputError, match="solutions must be one per phase"):
        PeriodicResponse("x", response.system, [0.0, 1.0], [g], g, amplitude=0, lag=0,
                         mean_x=0)
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="path must be"):
        response.save(tmp_path / "f")
    with pytest.raises(InputError, match="manifest.json"):
        PeriodicResponse.load(tmp_path / "none")
    d = tmp_path / "bad"
    d.mkdir()
    (d / "manifest.json").write_text('{"format": "other"}')
    with pytest.raises(InputError, match="not a periodic response"):
        PeriodicResponse.load(d)
