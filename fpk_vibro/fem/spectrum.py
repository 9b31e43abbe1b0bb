"""The stationary power spectrum and correlation by finite elements: :func:`spectrum`.

For q = x or y with FE stationary mean m, the correlation of the centred signal is

    R(τ) = ∫ (q − m) [e^{τ𝓛} ((q − m) p_s)] dx dy,

𝓛 the FPK operator (walls included), and the two-sided density is
S(ω) = (1/π) Re ∫₀^∞ R(τ) e^{−iωτ} dτ (:mod:`fpk_vibro.spectrum`).  On the FE level
``M dp/dt = L p`` (the conservative Galerkin generator of :func:`fem.stationary
<fpk_vibro.fem.stationary>`, tensor assembly) with p_s its normalised null vector:

- u0 = M⁻¹ b, b_i = ∫ φ_i (q − m) p_s: the L² projection of (q − m) p_s.  Its mass is
  ∫ (q − m) p_s = 0, and since q − m lies in the FE space, gᵀu0 = ∫ (q − m)² p_s
  exactly: R(0) is the FE stationary variance, and ∫ S dω = Var q holds on the FE
  level, not only in the limit;
- g_i = ∫ (q − m) φ_i, and S(ω) = (1/π) Re gᵀ (iωM − L)⁻¹ M u0.

At ω = 0 the matrix is singular on p_s, but the right-hand side has zero mass and
gᵀp_s = 0, so H(0) is well defined; the reduced model (rational Krylov with a few
complex shifts over the band, one sparse LU each: :mod:`fpk_vibro.fem.spectrum_krylov`)
works in the zero-mass subspace and never meets the singularity.  H is evaluated for
every ω from the small model, and R(τ) from its poles and residues on lags up to
about ten decay times.  Per-ω sparse solves would cost one complex LU per ω.

The error estimate (two coarser levels, Richardson with the measured rate; the
reduced model's last change; the truncated strip) and the choice of shifts:
:mod:`fpk_vibro.fem.spectrum_level`.  With ``rtol`` (default 1e-3, best effort) nx and
ny grow until the estimated max over ω of |error| / max S is below it.

Measured (``fpk-vibro bench fem-spectrum``): docs/measurements.md, §FE spectra.
"""
from __future__ import annotations

import math
import time
import warnings
from typing import Any

from .._checks import InputError
from ..model import VibroImpactSystem, check_system
from ..spectrum import Spectrum, check_omega, check_signal
from .ladder import (COST_POWER, FIRST_NY, MAX_NX, MAX_SECONDS, WALL_GRADING, start_degree,
                     start_nx)
from .spectrum_level import (COARSER, SHIFTS, Level, coarser, estimate, lags, shifts,
                             solve_level)

__all__ = ["spectrum", "DEFAULT_RTOL"]

#: The accuracy goal when none of nx, ny, degree, rtol is given (best effort).
DEFAULT_RTOL = 1e-3
#: The default's time limit (s); an explicit rtol has the stationary ladder's 30 s.
DEFAULT_SECONDS = 10.0
#: The reduced model's tolerance (its round-to-round change) relative to the goal.
KRYLOV_SHARE = 0.01


def spectrum(system: VibroImpactSystem, omega: Any, of: str = "x", *, nx: int | None = None,
             ny: int | None = None, degree: int | None = None, rtol: float | None = None,
             y_max: float | None = None) -> Spectrum:
    """The two-sided power spectral density S(ω) and correlation R(τ) of the stationary
    displacement or velocity (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
        Without forcing (not stationary) or coloured noise (``montecarlo.spectrum``
        does that).
    omega : array_like
        Frequencies in rad/s, ≥ 0, strictly increasing.
    of : {"x", "y"}
    nx, ny : int, optional
        Cells across x and y (``ny`` even), as in :func:`fem.stationary
        <fpk_vibro.fem.stationary>`; given, there is no adaptation and the estimate is
        made on first demand (two coarser levels).
    degree : {1, 2, 3, 4}, optional
        Lagrange degree; default 4 (below rtol = 3e-3; 3 and 2 above, as the stationary
        ladder starts).
    rtol : float, optional
        Accuracy goal: the estimated max over ω of |error| / max S; nx and ny grow
        until it is met.  Not with nx, ny or degree.  Default 1e-3 when none of them is
        given, as a best effort (a RuntimeWarning and ``info["rtol_not_reached"]``
        where missed within 10 s); an explicit rtol not reached within 30 s is
        refused in one line.
    y_max : float, optional
        Velocity truncation (default: the energy-tail rule of fem.stationary).

    Returns
    -------
    Spectrum
        Method "fem": ``.density`` on ``omega``, ``.correlation(tau)`` up to about ten
        decay times, ``.variance`` (the FE Var q), ``.mean``, ``.error_estimate()``;
        ``info``: the level (degree, nx, ny, ndofs), the reduced basis size, seconds.

    Raises
    ------
    InputError
        One line: bad omega or of, a forced or coloured system, bad options.

    Examples
    --------
    >>> import numpy as np
    >>> from fpk_vibro import VibroImpactSystem, fem
    >>> s = VibroImpactSystem(a=1.0, b=0.0, c=0.2, D1=0.01, barriers="none")
    >>> sp = fem.spectrum(s, np.linspace(0.0, 2.0, 41), nx=12, ny=12, degree=3)
    >>> exact = 0.01 / np.pi / ((1 - sp.omega**2) ** 2 + (0.2 * sp.omega) ** 2)
    >>> err = np.max(np.abs(sp.density - exact)) / exact.max()
    >>> bool(err < sp.error_estimate()["relative"] < 1e-3)
    True
    """
    where = "fem.spectrum"
    _refuse(where, system)
    w = check_omega(where, omega)
    q = check_signal(where, of)
    given = _numerics(where, system, nx, ny, degree, rtol, y_max)
    if given["nx"] is not None or given["ny"] is not None or given["degree"] is not None:
        return _fixed(system, w, q, given)
    return _adaptive(system, w, q, given)


def _refuse(where: str, system: Any) -> None:
    if isinstance(system, VibroImpactSystem) and system.forcing is not None:
        raise InputError(f"{where}: a forced system has no stationary spectrum (forcing="
                         f"{system.forcing!r}: its response is periodic); use fem.periodic",
                         where=where, name="forcing")
    if isinstance(system, VibroImpactSystem) and system.external is not None:
        raise InputError(f"{where}: does not handle coloured external noise (external="
                         f"OrnsteinUhlenbeck(tau={system.external.tau:g})); "
                         "montecarlo.spectrum does", where=where, name="external")
    check_system(where, system)


def _numerics(where, system, nx, ny, degree, rtol, y_max) -> dict[str, Any]:
    """The numerics validated as fem.stationary validates them (one line each)."""
    from .options import Options
    declared = Options.declared()
    out = {k: declared[k].validate(k, v, where) for k, v in
           (("nx", nx), ("ny", ny), ("rtol", rtol), ("y_max", y_max))}
    out["degree"] = None if degree is None else declared["degree"].validate("degree", degree,
                                                                            where)
    if out["rtol"] is not None:
        for k in ("nx", "ny", "degree"):
            if out[k] is not None:
                raise InputError(f"{where}: {k} must not be given with rtol (rtol chooses "
                                 "the mesh; give one or the other)", where=where, name=k)
    dom = _domain(where, system, out["y_max"])
    out["domain"] = dom
    return out


def _domain(where: str, system: VibroImpactSystem, y_max: float | None):
    from .mesh import domain
    try:
        return domain(system, y_max)
    except ValueError as exc:
        raise InputError(f"{where}: y_max must be given: {exc}", where=where,
                         name="y_max") from None


def _run(system, omega, q, dom, degree, nx, ny, grading, tol, band=None):
    """One level solved and reduced (``band``: the shifts and check grid, made from
    this level when None)."""
    level = Level(system, dom, degree, nx, ny, grading)
    if band is None:
        band = shifts(level, omega)
    out = solve_level(level, q, omega, *band, tol)
    out["omega"], out["shifts"] = omega, band
    return out


def _result(system, omega, q, fine: dict, estimate, seconds: float, **info) -> Spectrum:
    lev, model = fine["level"], fine["model"]
    lags = fine["lags"]
    kinfo = fine["info"]
    record = {"degree": lev.degree, "nx": lev.nx, "ny": lev.ny, "ndofs": lev.ndofs,
              "wall_grading": lev.grading, "basis_size": kinfo["size"],
              "krylov_rounds": kinfo["rounds"], "krylov_change": kinfo["change"],
              "shifts": kinfo["shifts"], "lu_seconds": kinfo["lu_seconds"],
              "krylov_seconds": kinfo["seconds"], "level_seconds": lev.seconds,
              "seconds": seconds, "max_pole_real": model.growth,
              "modal": bool(model.modal), **info}
    return Spectrum("fem", system, q, omega, fine["S"], variance=model.variance, lags=lags,
                    correlation=model.correlation(lags), estimate=estimate, info=record,
                    mean=fine["mean"])


def _fixed(system, omega, q, given) -> Spectrum:
    """nx, ny or degree given: one level, its estimate on first demand."""
    from ..budget import enforce
    from .options import Options
    t0 = time.perf_counter()
    degree = given["degree"] or 4
    opts = Options(nx=given["nx"], ny=given["ny"], degree=degree, y_max=given["y_max"],
                   positivity=False)
    opts.validate_for(system, "stationary")
    enforce(_cost(system, opts), "fem.spectrum")
    _, nx, ny = opts.grid(system, "fem.spectrum")
    dom, grading = given["domain"], _grading(system)
    tol = KRYLOV_SHARE * DEFAULT_RTOL
    fine = _run(system, omega, q, dom, degree, nx, ny, grading, tol)
    fine["lags"] = lags(fine["model"])

    def on_demand() -> dict[str, Any]:
        coarse = [_run(system, omega, q, dom, *lv, grading, tol, fine["shifts"])
                  for lv in coarser(degree, nx, ny)]
        return estimate(fine, coarse, fine["lags"], q)

    return _result(system, omega, q, fine, on_demand, time.perf_counter() - t0)


def _cost(system: VibroImpactSystem, opts):
    """A level's cost for :func:`fpk_vibro.budget.enforce`: the stationary solve's
    (fem.Options.estimate) with the complex LU of every shift held at once (twice a
    real factor's memory and time each)."""
    from ..budget import Cost
    c = opts.estimate(system, "stationary")
    k = 1.0 + 2.0 * SHIFTS
    return Cost(c.memory * k, c.work, c.unit, c.seconds * k, c.key or "nx", c.note)


def _grading(system: VibroImpactSystem) -> float:
    return WALL_GRADING if any(not w.elastic for _, w in system.walls) else 1.0


def _adaptive(system, omega, q, given) -> Spectrum:
    """rtol (or the default): levels refined until the estimate meets it."""
    from ..budget import enforce
    from .options import Options
    where = "fem.spectrum"
    t0 = time.perf_counter()
    best_effort = given["rtol"] is None
    goal = DEFAULT_RTOL if best_effort else given["rtol"]
    limit = DEFAULT_SECONDS if best_effort else MAX_SECONDS
    dom, grading = given["domain"], _grading(system)
    degree = start_degree(goal)
    opts = Options(degree=degree, y_max=given["y_max"], positivity=False)
    nx = start_nx(system, opts)
    ny = min(max(opts.replace(nx=nx).grid(system, where)[2], FIRST_NY[0]), FIRST_NY[1])
    tol = KRYLOV_SHARE * goal
    solved: dict[tuple[int, int], dict] = {}
    history, band = [], None
    while True:
        levels = [(degree, nx, ny)] + coarser(degree, nx, ny)
        t1 = time.perf_counter()
        for lv in levels:
            if lv[1:] not in solved:
                if lv[1:] == (nx, ny):
                    enforce(_cost(system, opts.replace(nx=nx, ny=ny)), where)
                solved[lv[1:]] = _run(system, omega, q, dom, *lv, grading, tol, band)
                band = solved[lv[1:]]["shifts"]
        fine = solved[(nx, ny)]
        fine["lags"] = lags(fine["model"])
        est = estimate(fine, [solved[lv[1:]] for lv in levels[1:]], fine["lags"], q)
        history.append(f"degree {degree}, nx {nx}, ny {ny}: {est['relative']:.2g}")
        if est["relative"] <= goal:
            break
        rho = est["rate"]
        rate = math.log(1.0 / rho) / math.log(1.0 / COARSER) if 0 < rho < 1 else 1.0
        rate = min(max(rate, 1.0), 8.0)
        f = (est["relative"] / (0.5 * goal)) ** (1.0 / rate) if math.isfinite(
            est["relative"]) else 2.0
        f = min(max(f, 1.25), 4.0)
        spent = time.perf_counter() - t0
        step = time.perf_counter() - t1           # (this level and its coarser ones)
        if best_effort and spent + step * f ** (2 * COST_POWER) > limit:
            # the largest level that fits the time left
            f = max(1.0, (limit - spent) / step) ** (1.0 / (2 * COST_POWER))
        predicted = step * f ** (2 * COST_POWER)
        if spent + predicted > limit or nx * f > MAX_NX or f < 1.25:
            why = (f"the next level would pass nx = {MAX_NX}" if nx * f > MAX_NX else
                   f"no finer level fits the {limit:g} s limit" if f < 1.25 else
                   f"the next level (nx = {int(math.ceil(nx * f))}) would take the solve to "
                   f"~{spent + predicted:.0f} s > {limit:g} s")
            if not best_effort:
                raise InputError(f"{where}: rtol = {goal:g} is not reached: the estimate is "
                                 f"{est['relative']:.2g} at degree {degree}, nx = {nx}, ny = "
                                 f"{ny}, and {why}; give a larger rtol, or nx and degree",
                                 where=where, name="rtol")
            est["not_reached"] = why
            break
        nx, ny = int(math.ceil(nx * f)), 2 * int(math.ceil(ny * f / 2))
    info = {"rtol": goal, "adapt_levels": "; ".join(history)}
    if "not_reached" in est:
        info["rtol_not_reached"] = est["not_reached"]
        warnings.warn(f"{where}: the default solve (rtol = {goal:g}, best effort within "
                      f"{limit:g} s) stopped at degree {degree}, nx = {nx} with an "
                      f"estimated error of {est['relative']:.2g}: {est['not_reached']}; give "
                      "rtol (up to 30 s) or nx and degree", RuntimeWarning, stacklevel=3)
    return _result(system, omega, q, fine, est, time.perf_counter() - t0, **info)
