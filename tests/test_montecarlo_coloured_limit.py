"""The white-noise limit of Monte Carlo with coloured external noise (issue 35): on the
paper's system with walls (r = 0.92, D2 = 0) E[H] with an Ornstein–Uhlenbeck force of
correlation time τ approaches the white-noise E[H] of the same D1 at first order in τ.

Measured (dt = 0.025, 2048 paths, 16 000 time units each, SE 0.06 %): E[H] relative to
the white 0.15918 is −16.8, −7.78, −3.54, −1.75, −0.76, −0.44 % at τ = 0.4, 0.2, 0.1,
0.05, 0.025, 0.0125, local orders log2(D(2τ)/D(τ)) = 1.11, 1.14, 1.02, 1.20, 0.8 ± 0.3:
first order, not the τ² of the wall-free oscillator's frequency cut-off (there
−(c τ/2 + ω0² τ²) relative, τ² above τ ≈ c/2).  The walls make it first order: ζ is
continuous at an impact while y reverses, so the correlation E[ζ y] built over the
last τ is lost at each impact (the impact rate falls with τ too: 0.0906 white, 0.0897
at τ = 0.025, 0.0861 at 0.1)."""
from __future__ import annotations

import math

from fpk_vibro import OrnsteinUhlenbeck, VibroImpactSystem
from fpk_vibro import montecarlo as mc


def test_white_limit_is_first_order_in_tau():
    """D(τ) = E[H](τ)/E[H](white) − 1 at τ = 0.1, 0.05, 0.025 (the default step, h/τ ≤
    2): negative, shrinking, and halving with τ (order 1 within ±0.35 on the first
    halving, whose SE is ~0.05; τ² would give order 2)."""
    white = VibroImpactSystem.paper(r=0.92, D2=0.0)
    kw = dict(n_paths=2048, t_sample=6000.0, progress=False)
    ref = mc.stationary(white, seed=21, **kw)
    E0, s0 = ref.moments()["E_H"], ref.moments_se()["E_H"]
    D, se = {}, {}
    for i, tau in enumerate((0.1, 0.05, 0.025)):
        sol = mc.stationary(white.replace(external=OrnsteinUhlenbeck(tau=tau)), seed=22 + i,
                            **kw)
        E, s = sol.moments()["E_H"], sol.moments_se()["E_H"]
        D[tau] = E / E0 - 1.0
        se[tau] = math.hypot(s / E0, s0 / E0)
        assert D[tau] < -3 * se[tau], (tau, D[tau], se[tau])
    assert abs(D[0.1]) > abs(D[0.05]) > abs(D[0.025])
    p1 = math.log2(D[0.1] / D[0.05])
    p2 = math.log2(D[0.05] / D[0.025])
    assert 0.65 < p1 < 1.35, (p1, D, se)
    assert 0.4 < p2 < 1.8, (p2, D, se)
    assert abs(D[0.025]) < 0.012
