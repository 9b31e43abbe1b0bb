"""The parameters of one Monte Carlo step size, as the compiled kernels take them.

:func:`step_params` builds them in one place: a :class:`StepParams` record of
floats (the model, the step's coefficients, the walls and the histogram bins) and a
:class:`StepFlags` record of integers.  numba passes named tuples by value and
the kernels read the fields by name.

A side without a wall has ``lo`` = −inf (``hi`` = +inf), so no flight crosses it:
the kernels need no case for which walls exist (``StepFlags.mode`` only records
it).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..model import VibroImpactSystem
from ._laws import CONSTANT, encode, pack

__all__ = ["StepParams", "StepFlags", "step_params", "wall_laws", "kick_gain"]

# which walls exist (StepFlags.mode)
MODE_NONE, MODE_RIGHT, MODE_BOTH, MODE_LEFT = 0, 1, 2, 3


class StepParams(NamedTuple):
    """The float parameters of a step of size h (all float64, so numba types the
    record as one homogeneous tuple)."""
    a: float                #: linear stiffness
    b: float                #: cubic stiffness
    hh: float               #: h/2
    ec: float               #: e^{−c h}
    sd0: float              #: sqrt(D1 s²), s² = (1 − e^{−2ch})/c: the OU kick without D2
    d1s2: float             #: D1 s²
    d2s2: float             #: D2 s²
    lo: float               #: the left wall x_L (−inf: none)
    hi: float               #: the right wall x_R (+inf: none)
    r_right: float          #: restitution of the right wall (NaN for a law of u: the
                            #: kernels then take :func:`wall_laws`)
    barrier_energy: float   #: energy above which a path can impact (P_impact)
    h0: float = 0.0         #: energy histogram: first edge and inverse bin width
    h_iw: float = 0.0
    x0: float = 0.0         #: x histogram
    x_iw: float = 0.0
    y0: float = 0.0         #: y histogram
    y_iw: float = 0.0
    jx0: float = 0.0        #: joint histogram, x axis
    jx_iw: float = 0.0
    jy0: float = 0.0        #: joint histogram, y axis
    jy_iw: float = 0.0
    f_lo: float = 0.0       #: the force F(x_L) at the left wall (0: none)
    f_hi: float = 0.0       #: F(x_R)
    r_left: float = 1.0     #: restitution of the left wall
    u_iw_left: float = 0.0  #: inverse bin widths of the impact-speed histograms
    u_iw_right: float = 0.0
    e_iw_left: float = 0.0  #: inverse bin widths of the impact-energy histograms
    e_iw_right: float = 0.0
    g_iw: float = 0.0       #: inverse bin width of the inter-impact time histogram
    f_amp: float = 0.0      #: harmonic forcing F cos(Ω t + φ0): F (0: none)
    f_omega: float = 0.0    #: Ω
    f_phase: float = 0.0    #: φ0
    z_e: float = 0.0        #: coloured external noise ζ (OU, τ): e^{−h/τ} (0: white)
    z_s: float = 0.0        #: sqrt((D1/τ)(1 − e^{−2h/τ})): ζ's exact step's noise
    z_k: float = 0.0        #: κ(h/τ), the kicks' gain on ζ (:func:`kick_gain`)


class StepFlags(NamedTuple):
    """The integer parameters of a step."""
    mode: int               #: which walls exist (``MODE_*``)
    has_d2: int             #: 1 with parametric noise D2 > 0
    max_impacts: int        #: impacts allowed per free-flight sub-step
    forced: int = 0         #: 1 with harmonic forcing (the kicks add F cos(Ω t + φ0))
    coloured: int = 0       #: 1 with coloured external noise (the kicks add ζ)


def step_params(system: VibroImpactSystem, dt: float, max_impacts: int
                ) -> tuple[StepParams, StepFlags]:
    """The kernels' records for one step size (histogram bins left 0:
    :meth:`fpk_vibro.montecarlo._histograms.Histograms.with_bins`).

    With coloured external noise (``system.external``, :mod:`fpk_vibro.noise`) the
    y part of the step's O carries the parametric noise alone (``sd0`` = ``d1s2`` =
    0), ζ advances exactly over the step, ζ ← ``z_e`` ζ + ``z_s`` ξ, and the kicks
    add ``z_k`` ζ (:func:`kick_gain`)."""
    c = system.c
    s2 = -math.expm1(-2.0 * c * dt) / c if c > 0 else 2.0 * dt   # Var of OU / D
    lo, hi = system.x_bounds                  # ∓inf where there is no wall
    f_lo, f_hi = (-float(system.restoring_force(xb)) if math.isfinite(xb) else 0.0
                  for xb in (lo, hi))
    (kl, pl, _, _), (kr, pr, _, _) = (encode(w) for w in (system.left, system.right))
    p = StepParams(
        a=float(system.a), b=float(system.b), hh=float(0.5 * dt), ec=math.exp(-c * dt),
        sd0=math.sqrt(system.D1 * s2), d1s2=float(system.D1 * s2),
        d2s2=float(system.D2 * s2), lo=float(lo), hi=float(hi),
        r_right=float(pr[0]) if kr == CONSTANT else math.nan,
        barrier_energy=float(system.barrier_energy), f_lo=f_lo, f_hi=f_hi,
        r_left=float(pl[0]) if kl == CONSTANT else math.nan)
    ou = getattr(system, "external", None)
    if ou is not None:
        e = math.exp(-dt / ou.tau)
        var = ou.variance(system.D1)
        p = p._replace(sd0=0.0, d1s2=0.0, z_e=e, z_k=kick_gain(dt, ou.tau),
                       z_s=math.sqrt(var * -math.expm1(-2.0 * dt / ou.tau)))
    fo = getattr(system, "forcing", None)
    if fo is not None:
        p = p._replace(f_amp=float(fo.amplitude), f_omega=float(fo.frequency),
                       f_phase=float(fo.phase))
    flags = StepFlags(
        mode={"none": MODE_NONE, "right": MODE_RIGHT, "both": MODE_BOTH,
              "left": MODE_LEFT}[system.barriers],
        has_d2=1 if system.D2 > 0 else 0, max_impacts=int(max_impacts),
        forced=1 if fo is not None else 0, coloured=1 if ou is not None else 0)
    return p, flags


def kick_gain(h: float, tau: float) -> float:
    """κ = sqrt(tanh(u)/u), u = h/(2τ): the gain on ζ in the kicks of a step h.

    The kicks sample ζ at the step ends (the merged kick h κ ζ_k at t_k), and the
    long-time sum of h ζ_k has the intensity h (D1/τ) coth(u) per unit time where ζ's
    integral has 2 D1: κ² = tanh(u)/u makes the kicks' zero-frequency intensity 2 D1
    exactly, for every h/τ.  κ = 1 − (h/τ)²/24 + O(h⁴), so the scheme keeps its
    second order; without it (κ = 1) the relative bias is about (h/τ)²/12 (1.3e-3 at
    h = τ/8, ×50 at h = 2τ), which would bind the step to τ.  On the linear
    oscillator (a = 1, c = 0.025, D1 = 0.01; the scheme's exact discrete Lyapunov
    covariance) the bias of E[H] with κ is 4.7e-4, 4.9e-4, 3.5e-4, 3e-5 at h = 0.05
    and τ = 0.5, 0.1, 0.02, 0.002 (h/τ from 0.1 to 25), and κ E[ζ_k y_k] estimates
    E[ζ y] to 1.9e-4, 3e-4, 4.5e-4, 5e-5 there (:meth:`coloured moments
    <fpk_vibro.montecarlo.MonteCarloSolution.coloured_moments>`).

    >>> round(kick_gain(0.05, 0.5), 6), round(kick_gain(0.05, 1e-4), 4)
    (0.999584, 0.0632)
    """
    u = 0.5 * h / tau
    return math.sqrt(math.tanh(u) / u) if u > 1e-8 else 1.0


def wall_laws(system: VibroImpactSystem) -> np.ndarray:
    """The walls' restitution laws as the kernels take them: packed in one array
    (:func:`._laws.pack`, the encoding of :func:`._laws.encode`; an absent wall is
    elastic, never hit).  A Python callable is tabulated up to the speed of a
    path 60 typical energies above the bottom of the potential."""
    from ._step_size import typical_energy
    u_max = math.sqrt(2.0 * 60.0 * typical_energy(system)) if any(
        w.law is not None and w.law.kind == "callable" for _, w in system.walls) else 1e3
    return pack(system.left, system.right, u_max)


def _positions(*names: str) -> tuple[int, ...]:
    return tuple(StepParams._fields.index(n) for n in names)


# the field positions, for code that indexes the record (the tests' scalar references)
(P_A, P_B, P_HH, P_EC, P_SD0, P_D1S2, P_D2S2, P_LO, P_HI, P_R, P_GD, P_H0, P_HIW, P_X0,
 P_XIW, P_Y0, P_YIW, P_JX0, P_JXIW, P_JY0, P_JYIW, P_FLO, P_FHI, P_RL, P_UWL,
 P_UWR, P_EWL, P_EWR, P_GW, P_FAMP, P_FOMEGA, P_FPHASE, P_ZE, P_ZS,
 P_ZK) = range(len(StepParams._fields))
NP = len(StepParams._fields)
I_MODE, I_D2, I_MAXK, I_FORCED, I_COLOURED = range(len(StepFlags._fields))
NI = len(StepFlags._fields)
