"""fem.transient with harmonic forcing (issue 34): IMEX-BDF2 (the forcing explicit
from the extrapolated density, the constant operator's factors kept)."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fpk_vibro import Harmonic, VibroImpactSystem, fem
from fpk_vibro._checks import InputError

T = 2 * math.pi


def _linear():
    return VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none",
                             forcing=Harmonic(0.1, 0.9, 0.5))


def test_mean_is_the_forced_ode_and_second_order_in_time():
    """The mean of the linear oscillator obeys the forced ODE exactly; the error of
    IMEX-BDF2 falls 4× per halved step (space resolved: Q3 on a Gaussian)."""
    s = _linear()
    ode = solve_ivp(lambda t, m: [m[1], -m[0] - 0.1 * m[1] + 0.1 * math.cos(0.9 * t + 0.5)],
                    (0, 6), [0.2, 0.0], rtol=1e-12, atol=1e-14)
    errors = []
    for dt in (0.4, 0.2, 0.1):
        r = fem.transient(s, initial={"mean": (0.2, 0.0), "std": (0.3, 0.3)}, times=[6.0],
                          dt=dt, degree=3, nx=16, ny=16)
        errors.append(abs(r[-1].mean_x() - ode.y[0, -1]))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((rates > 1.7) & (rates < 2.3)), (errors, rates)


def test_relaxes_to_the_periodic_state():
    """From a Gaussian, after 10 relaxation times of the mean (2/c: 8 periods) the
    moments at phases 0 and π/2 are fem.periodic's within the two estimates
    (periodic's and the transient's)."""
    s = VibroImpactSystem.paper(r=0.8).replace(c=0.4, forcing=Harmonic(0.1, 1.0))
    per = fem.periodic(s, [0.0, math.pi / 2], degree=2, nx=10, harmonics=4)
    est = per.error_estimate()
    n = math.ceil(10 * 2 / 0.4 / T)
    tr = fem.transient(s, initial={"mean": (0.0, 0.0), "std": (0.2, 0.2)},
                       times=[n * T, (n + 0.25) * T], dt=T / 160, degree=2, nx=10,
                       y_max=per.info["y_max"])
    for i in range(2):
        m, mp, te = tr[i].moments(), per.at(i).moments(), tr[i].error_estimate()
        for k in ("E_x2", "E_y2", "E_H", "P_impact"):
            assert abs(m[k] / mp[k] - 1) <= est["phases"][i][k] + te[k], (i, k)
        assert te["E_x2"] < 0.01
        assert abs(tr[i].mean_x() - per.at(i).mean_x()) <= est["phases"][i]["E_x"] + \
            te.get("E_x", 0.0) + 1e-3 * abs(per.at(i).mean_x())


def test_refuses_positivity_with_forcing():
    with pytest.raises(InputError, match="fem.transient"):
        fem.transient(_linear(), initial={"mean": (0.0, 0.0), "std": (0.3, 0.3)},
                      times=[1.0], positivity=True, nx=16, ny=16)
