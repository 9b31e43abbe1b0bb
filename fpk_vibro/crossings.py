"""Level crossings, peaks and the Rice/Poisson reliability, from a joint density.

For a stationary density p(x, y) the rate at which paths cross the level x = b going
up is the flux of probability through the line x = b (Rice's formula):

    ν⁺(b) = ∫_{y>0} y p(b, y) dy,        ν⁻(b) = ∫_{y<0} |y| p(b, y) dy,

and in the stationary state ν⁻(b) = ν⁺(b) (as many paths cross down as up).  Beyond
a wall the strip ends and ν± = 0.  At a wall x_w every path that arrives impacts and
leaves again, so ν⁺ at the right wall (the arriving flux) is that wall's impact rate,
and so is ν⁻ there at the left wall; ν⁺ at the left wall is the departing flux,
the same rate once more.

Peaks.  With white noise x(t) has infinitely many local maxima per unit time (its
acceleration is white), so a *peak* here is the engineering one: the largest x of
one excursion above the mean m = E[x].  Excursions start at the upcrossings of m, so
peaks occur at the rate ν⁺(m); a peak exceeds b > m at least once for every
excursion that crosses b, so from a density alone the rate of peaks above b is
ν⁺(b) — exact when an excursion crosses b at most once (the narrow-band limit), an
upper bound otherwise — and P(peak > b) = ν⁺(b)/ν⁺(m).  Below the mean every peak
is above b: the rate is ν⁺(m), the probability 1.  Monte Carlo can count the peaks
directly.

Rice/Poisson reliability.  Treating the exits from a displacement band
x_lo < x < x_hi as a Poisson stream, R(t) ≈ exp(−(ν⁺(x_hi) + ν⁻(x_lo)) t) from a
stationary start.  The crossings of a lightly damped oscillator come in clumps (an
envelope above the level crosses it once per period for a while), so the true
decay rate is lower and this estimate is conservative at low levels; at high levels
the crossings become rarer and less clumped and the two rates approach each other
(tests/test_crossings.py measures both against the finite-element first passage).

Quadrature.  ν±(b) is Gauss–Legendre on panels of width σ/16 in y (σ² = E[y²], the
density's velocity scale), from 0 to 12σ and on while the outer part still adds more
than 1e-15 of the total (a heavier tail), vectorised over b.  On a finite-element
density (piecewise polynomial in y, kinks at its mesh lines) this is within ~1e-6
relative of the exact trace integral (measured on the paper's case); on a Monte
Carlo histogram it is the histogram's own flux.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._checks import check_points, invalid
from .model import VibroImpactSystem

__all__ = ["upcrossing_rate", "downcrossing_rate", "peak_rate",
           "peak_exceedance", "rice_reliability", "PANELS_PER_SIGMA"]

#: Gauss–Legendre panels per velocity scale σ = sqrt(E[y²]) (8 nodes each).
PANELS_PER_SIGMA = 16
_NODES = 8
#: The first reach of the y quadrature, in σ; doubled while the tail still counts.
_REACH = 12.0
_MAX_DOUBLINGS = 6
_TAIL = 1e-15
#: Points per call of pdf_joint (memory of the engines' evaluators).
_CHUNK = 200_000


def _levels(where: str, b: Any) -> tuple[np.ndarray, bool]:
    """``b`` as a float array (finite numbers) and whether it was a scalar."""
    arr = check_points("b", b, where=where)
    return np.asarray(arr, dtype=float), np.ndim(arr) == 0


def _out(values: np.ndarray, scalar: bool) -> Any:
    return float(values.reshape(())) if scalar else values


def _velocity_scale(sol: Any) -> float:
    m = sol.moments()
    s = math.sqrt(float(m["E_y2"])) if "E_y2" in m else math.nan
    if not (math.isfinite(s) and s > 0):
        raise ValueError(f"{type(sol).__name__}: E[y²] = {m.get('E_y2')!r} gives no "
                         "velocity scale for the crossing-rate quadrature")
    return s


def _panel_nodes(lo: float, hi: float, n_panels: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(_NODES)
    e = np.linspace(lo, hi, n_panels + 1)
    h = 0.5 * np.diff(e)[:, None]
    return ((0.5 * (e[1:] + e[:-1]))[:, None] + h * t).ravel(), (h * w).ravel()


def _flux(sol: Any, b: np.ndarray, sign: float) -> np.ndarray:
    """∫ |y| p(b, y) dy over sign·y > 0, for each b (flat), by panels (module docstring)."""
    sigma = _velocity_scale(sol)
    total = np.zeros(b.size)
    lo, hi, n = 0.0, _REACH * sigma, int(_REACH * PANELS_PER_SIGMA)
    for _ in range(_MAX_DOUBLINGS + 1):
        y, w = _panel_nodes(lo, hi, n)
        outer = y >= lo + 0.875 * (hi - lo)            # the outer eighth of this stretch
        part, tail = np.empty(b.size), np.empty(b.size)
        step = max(1, _CHUNK // y.size)
        for i in range(0, b.size, step):          # chunks of levels, not a loop per level
            shape = (min(step, b.size - i), y.size)
            p = np.asarray(sol.pdf_joint(np.broadcast_to(b[i:i + step, None], shape),
                                         np.broadcast_to(sign * y, shape)), dtype=float)
            f = p * (y * w)
            part[i:i + step] = f.sum(axis=1)
            tail[i:i + step] = np.abs(f[:, outer]).sum(axis=1)
        total += part
        if not np.any(tail > _TAIL * np.abs(total)):
            break
        lo, hi = hi, 2.0 * hi                     # the tail still counts: one more stretch
    return np.maximum(total, 0.0)                 # a raw Galerkin density's dips


def _crossing(where: str, sol: Any, b: Any, sign: float) -> Any:
    levels, scalar = _levels(where, b)
    flat = levels.ravel()
    lo, hi = sol.system.x_bounds
    inside = (flat >= lo) & (flat <= hi)
    out = np.zeros(flat.size)
    if np.any(inside):
        out[inside] = _flux(sol, flat[inside], sign)
    return _out(out.reshape(levels.shape), scalar)


def upcrossing_rate(sol: Any, b: Any) -> Any:
    """ν⁺(b) = ∫_{y>0} y p(b, y) dy: upcrossings of x = b per unit time.

    Parameters
    ----------
    sol : Solution
        Any solution with a joint density (``pdf_joint``) and ``moments()["E_y2"]``;
        a stationary one for a crossing *rate* (a transient snapshot gives the
        instantaneous flux).
    b : float or array_like
        Levels; finite numbers.  Outside the strip between the walls ν⁺ = 0.

    Returns
    -------
    float or ndarray
        A float for a number, an array of b's shape otherwise.  At the right wall it
        is that wall's impact rate (``sol.impacts()["right"]["rate"]``).

    Raises
    ------
    InputError
        For NaN, ±inf or a non-number among the levels (one line naming ``b``).

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> from fpk_vibro.exact import gibbs
    >>> sol = gibbs(VibroImpactSystem(a=1, b=0, c=0.1, D1=0.01, barriers="none"))
    >>> nu = upcrossing_rate(sol, [0.0, 0.3])
    >>> bool(abs(nu[0] - 1 / (2 * 3.141592653589793)) < 1e-12)    # ω0/2π at b = 0
    True
    >>> upcrossing_rate(gibbs(VibroImpactSystem.paper(r=1.0, D2=0.0)), 0.7)
    0.0
    """
    return _crossing("upcrossing_rate", sol, b, 1.0)


def downcrossing_rate(sol: Any, b: Any) -> Any:
    """ν⁻(b) = ∫_{y<0} |y| p(b, y) dy: downcrossings of x = b per unit time (equal to
    ν⁺(b) in a stationary state; at the left wall, its impact rate).  Arguments and
    refusals as :func:`upcrossing_rate`."""
    return _crossing("downcrossing_rate", sol, b, -1.0)


def peak_rate(sol: Any, b: Any) -> Any:
    """The rate of peaks above ``b``; a peak is the largest x of one excursion above
    the mean m = E[x] (module docstring).

    From a density alone this is ν⁺(max(b, m)): exact when an excursion crosses b at
    most once (narrow band), an upper bound otherwise; for b ≤ m every peak counts
    and the rate is ν⁺(m), the rate of excursions.  Arguments as
    :func:`upcrossing_rate`.

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> from fpk_vibro.exact import gibbs
    >>> sol = gibbs(VibroImpactSystem(a=1, b=0, c=0.1, D1=0.01, barriers="none"))
    >>> float(peak_rate(sol, -1.0)) == float(peak_rate(sol, 0.0))
    True
    """
    levels, scalar = _levels("peak_rate", b)
    m = float(sol.mean_x())
    return _out(np.asarray(upcrossing_rate(sol, np.maximum(levels, m))), scalar)


def peak_exceedance(sol: Any, b: Any) -> Any:
    """P(peak > b) = ν⁺(max(b, m)) / ν⁺(m) (module docstring): 1 at and below the
    mean, 0 beyond the right wall.  Arguments as :func:`upcrossing_rate`.

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> from fpk_vibro.exact import gibbs
    >>> sol = gibbs(VibroImpactSystem(a=1, b=0, c=0.1, D1=0.01, barriers="none"))
    >>> p = peak_exceedance(sol, [0.0, 0.2])     # Rayleigh: exp(−b²/2σ²), σ² = 0.1
    >>> bool(p[0] == 1.0 and abs(p[1] - math.exp(-0.2)) < 1e-12)
    True
    """
    levels, scalar = _levels("peak_exceedance", b)
    m = float(sol.mean_x())
    nu = np.asarray(upcrossing_rate(sol, np.append(np.maximum(levels.ravel(), m), m)))
    if not nu[-1] > 0:
        raise ValueError(f"peak_exceedance: the density has no upcrossings of its mean "
                         f"m = {m:.6g}")
    return _out(np.minimum(nu[:-1] / nu[-1], 1.0).reshape(levels.shape), scalar)


def _band(where: str, displacement: Any) -> tuple[float, float]:
    rule = "a number b > 0 (the band |x| < b) or a pair x_lo < x_hi of finite numbers"
    if isinstance(displacement, (bool, str, bytes)) or displacement is None:
        raise invalid(where, "displacement", rule, displacement)
    try:
        arr = np.asarray(displacement, dtype=float)
    except (TypeError, ValueError):
        raise invalid(where, "displacement", rule, displacement) from None
    if arr.ndim == 0:
        arr = np.array([-arr, arr]) if arr > 0 else np.array([np.nan, np.nan])
    if arr.shape != (2,) or not np.all(np.isfinite(arr)) or not arr[0] < arr[1]:
        raise invalid(where, "displacement", rule, displacement)
    return float(arr[0]), float(arr[1])


def rice_reliability(sol: Any, t: Any, *, displacement: Any) -> Any:
    """The Rice/Poisson estimate R(t) ≈ exp(−(ν⁺(x_hi) + ν⁻(x_lo)) t) of staying in
    x_lo < x < x_hi from a stationary start (module docstring).

    Parameters
    ----------
    sol : Solution
        A stationary solution with a joint density.
    t : float or array_like
        Times ≥ 0.
    displacement : float or (float, float)
        The band: b > 0 for |x| < b, or (x_lo, x_hi) (as
        ``fem.first_passage(..., displacement=...)``).  A bound beyond a wall is
        never crossed (rate 0).

    Returns
    -------
    float or ndarray
        R at ``t`` (a float for a number).

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem
    >>> from fpk_vibro.exact import gibbs
    >>> sol = gibbs(VibroImpactSystem(a=1, b=0, c=0.1, D1=0.01, barriers="none"))
    >>> nu = 2 * upcrossing_rate(sol, 0.5)
    >>> bool(abs(rice_reliability(sol, 10.0, displacement=0.5) - math.exp(-10 * nu)) < 1e-15)
    True
    """
    where = "rice_reliability"
    times = check_points("t", t, where=where)
    if np.any(times < 0):
        raise invalid(where, "t", "times >= 0", t)
    x_lo, x_hi = _band(where, displacement)
    rate = float(upcrossing_rate(sol, x_hi)) + float(downcrossing_rate(sol, x_lo))
    R = np.exp(-rate * np.asarray(times, dtype=float))
    return float(R) if np.ndim(times) == 0 else R
