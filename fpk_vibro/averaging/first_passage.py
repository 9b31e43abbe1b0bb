"""Mean first-passage time and reliability of the averaged energy (docs/impacts.md).

The averaged energy is the diffusion dH = m(H) dt + σ(H) dW on (H_min, ∞), reflected
at the floor H_min of the potential.  Its mean exit time through H_c solves
Pontryagin's equation m τ' + ½ σ² τ'' = −1 with τ(H_c) = 0 and τ' bounded at H_min:

    τ(H0) = ∫_{H0}^{H_c} 2 F(u) / (σ²(u) p_s(u)) du,    F(u) = ∫_{H_min}^u p_s,

p_s the averaged stationary density (:func:`fpk_vibro.averaging.stationary`).  The
reliability R(t) comes from the conservative finite-volume generator of
:mod:`fpk_vibro.averaging.transient` on (H_min, H_c) with the top face absorbing
(p = 0 beyond it), by its eigen-decomposition, on its own grid of times (up to 5 τ
or the largest requested time, at most 40 τ) and at the requested times.

τ is integrated in logarithms (g = 2F/(σ² p_s) scaled by its largest value), so it
is finite up to the float range; a larger one (e.g. the paper's case with
H_c = 100: τ ~ 10^1000s) is refused in one line with its magnitude.  The
eigen-decomposition resolves the slowest rate only while eps ‖A‖ τ is small; beyond
that (τ ≳ 10^9 on the paper's case) R(t) is the exponential law exp(−t/τ) of the
quasi-stationary regime, whose error O(1/(λ τ)) (λ the relaxation rate) is then
far below the decomposition's (``info["survival_method"]``).
"""
from __future__ import annotations

import math
import time
from typing import Any, Sequence

import numpy as np
from scipy import integrate, linalg

from .._checks import InputError, invalid
from ..first_passage import (FirstPassage, check_energy, check_times, merge_requested,
                             parse_start, survival_at)
from ..safe_sets import SafeSet, parse_safe_set
from ..model import VibroImpactSystem, check_system
from ..orbits import energy_floor, orbit_nodes
from .coefficients import coefficients
from .stationary import stationary
from .energy_grid import energy_faces
from .options import Options
from .transient import averaged_operator

__all__ = ["first_passage", "energy_threshold", "log10_mean_time", "model_error"]

#: Largest accepted eps ‖A‖ τ of the eigen-decomposition (else the exponential law).
RESOLVABLE = 1e-3
#: Largest τ returned (beyond: refused with its magnitude).
MAX_TAU = 1e300
#: The tabulated R stops at this many τ (R ~ e^-40) even if later times are asked.
HORIZON = 40.0


def _log_tau(system: VibroImpactSystem, sol, H_c: float, n_grid: int
             ) -> tuple[np.ndarray, np.ndarray]:
    """(u, ln τ(u)) on a grid of [floor, H_c] (quadratically graded at the floor):
    τ(u) = ∫_u^{H_c} g, g = 2F/(σ² p_s), with ln p_s = ln T − Φ − ln Z (no
    underflow) and the integral scaled by max g."""
    floor = energy_floor(system)
    u = floor + (H_c - floor) * np.linspace(0.0, 1.0, n_grid + 1) ** 2
    with np.errstate(all="ignore"):
        lnp = np.log(orbit_nodes(system, u[1:], sol.n_theta).period) - sol.phi(u[1:]) \
            - math.log(sol.Z)
        p = np.concatenate([[0.0], np.exp(lnp)])
        p[0] = sol.pdf_energy(u[:1])[0]
        F = integrate.cumulative_trapezoid(p, u, initial=0.0)
        _, _, s2 = coefficients(system, u[1:])
        lng = np.empty_like(u)
        lng[1:] = math.log(2.0) + np.log(F[1:]) - np.log(s2) - lnp
        g1, g2 = np.exp(lng[1] - lng[2]), 1.0           # g[0] = 2 g[1] − g[2], scaled
        lng[0] = lng[2] + np.log(max(2.0 * g1 - g2, 1e-300))
    top = float(np.max(lng))
    gs = np.exp(lng - top)
    # τ(u_i)/e^top = ∫_{u_i}^{H_c} g/e^top, summed from the top (no cancellation)
    pieces = 0.5 * (gs[1:] + gs[:-1]) * np.diff(u)
    tail = np.concatenate([np.cumsum(pieces[::-1])[::-1], [0.0]])
    with np.errstate(divide="ignore"):
        return u, top + np.log(tail)


def log10_mean_time(system: VibroImpactSystem, H_c: float, H0: float | None = None,
                    n_grid: int = 4000) -> float:
    """log10 of the averaged τ from the energy H0 (default: the floor), even where τ
    itself overflows: the magnitude an unresolvable mean time is refused with."""
    u, ltau = _log_tau(system, stationary(system), H_c, n_grid)
    H0 = u[0] if H0 is None else H0
    return float(np.interp(H0, u, ltau)) / math.log(10.0)


def first_passage(system: VibroImpactSystem, *, energy: float | None = None,
                  displacement: Any = None, impact_speed: float | None = None,
                  start: Any = (0.0, 0.0), times: Sequence[float] | None = None,
                  n_grid: int = 4000, n_cells: int = 400) -> FirstPassage:
    """τ(H0) and R(t | start) out of a safe set under stochastic averaging.

    Averaging follows the energy only, so every safe set is mapped to an energy
    threshold H_c (:func:`energy_threshold`; ``info["H_c"]``, ``info["mapped"]``): an
    orbit of energy H reaches the displacement bound x_b within one period once H >
    G(x_b), and impacts a wall faster than u_c once H > G(x_w) + u_c²/2.  The mapping
    assumes the energy nearly constant over an orbit (the averaging assumption); it
    errs by the time the orbit takes to reach the bound (at most a period) and by the
    phase it forgets.

    Parameters
    ----------
    system : VibroImpactSystem
    energy : float, optional
        The critical energy H_c: the safe set {H < H_c}.
    displacement : float or (float, float), optional
        b (|x| < b) or (x_lo, x_hi): H_c = the smallest G over the bounds inside the
        strip.  The set must contain the bottom of the potential on the strip (x = 0,
        or the wall nearest to it), which every orbit passes; else refused, naming the
        engines that compute it.
    impact_speed : float, optional
        u_c: the first impact faster than u_c; H_c = min over walls of G(x_w) + u_c²/2.
        Exactly one of ``energy``, ``displacement``, ``impact_speed``
        (:func:`fpk_vibro.safe_sets.parse_safe_set`).
    start : (x0, y0), dict or "stationary"
        As in :func:`fpk_vibro.fem.first_passage`; a point enters through its
        energy H(x0, y0) only (averaging forgets the phase).
    times : sequence of float, optional
        Times at which R(t) must be known, in any order (checked by
        :func:`fpk_vibro.first_passage.check_times`); R is tabulated on its own grid
        (to 5 τ or the largest of them, at most 40 τ) and evaluated at these.
    n_grid : int
        Quadrature nodes of the τ integral (quadratically graded at the floor).
    n_cells : int
        Finite-volume cells of the reliability.  Both are declared (range, default)
        by :class:`fpk_vibro.averaging.Options`, mode "first_passage", which also
        refuses a call beyond the budget (:mod:`fpk_vibro.budget`).

    Returns
    -------
    FirstPassage
        ``mean_time(x0, y0)`` = τ(H(x0, y0)).

    Raises
    ------
    InputError
        For an invalid argument, naming it; for a mean time beyond the float range
        (naming ``energy``, with its magnitude).
    """
    where = "averaging.first_passage"
    check_system(where, system)
    if displacement is None and impact_speed is None and energy is not None:
        H_c = check_energy(where, system, energy)
        safe = SafeSet("energy", energy=H_c)
    else:
        safe = parse_safe_set(where, system, energy=energy, displacement=displacement,
                              impact_speed=impact_speed)
    H_c, mapped = energy_threshold(where, system, safe)
    kind, value = parse_start(where, system, start, safe)
    if kind == "gaussian":
        x, y, w = _gauss_hermite(value)
        if not np.sum(w[system.energy(x, y) < H_c]) > 0.0:
            raise invalid(where, "start", f"a Gaussian with mass inside the safe set H < "
                          f"{H_c:g}", start, "none of its quadrature nodes falls inside")
    requested = check_times(where, times)
    opts, _ = Options.prepare(system, "first_passage", locals())
    n_grid, n_cells = opts.n_grid, opts.n_cells
    sol = stationary(system)
    u, ltau = _log_tau(system, sol, H_c, n_grid)
    if not ltau[0] < math.log(MAX_TAU):
        raise InputError(
            f"{where}: energy = {H_c:g} gives a mean first-passage time of about "
            f"10^{ltau[0] / math.log(10.0):.0f}, beyond the float range (at most "
            f"{MAX_TAU:g} is returned); choose a lower energy", where=where, name="energy")
    tau = _Tau(u, np.exp(ltau), H_c, system)
    mean = float(_mean_from(kind, value, system, tau, sol, H_c))
    info: dict[str, Any] = {"n_grid": n_grid, "n_cells": n_cells, "H_c": H_c,
                            "mapped": mapped}
    t_req = float(requested[-1]) if requested is not None else 0.0
    t_end = min(max(5.0 * mean, t_req), HORIZON * float(tau.values[0]))
    t_end = max(t_end, 5.0 * mean)
    T = np.linspace(0.0, t_end, 801)
    survival = _eigen_survival(system, sol, H_c, n_cells, kind, value, mean, info)
    if survival is None:
        def survival(t):
            return np.exp(-np.asarray(t, float) / mean)
    R = np.clip(survival(T), 0.0, 1.0)
    T, R = merge_requested(T, R, requested, exact=survival)
    return FirstPassage("averaging", system, H_c if safe.kind == "energy" else None,
                        (kind, value), mean, 0.0, T, np.clip(R, 0.0, 1.0), None, info,
                        _mean_at=tau, safe_set=safe)


def energy_threshold(where: str, system: VibroImpactSystem, safe: SafeSet
                     ) -> tuple[float, str]:
    """The energy H_c averaging uses for ``safe`` and the mapping in words
    (:func:`first_passage`); one InputError where it does not apply."""
    if safe.kind == "energy":
        return float(safe.energy), f"H_c = {safe.energy:.6g} (given)"
    if safe.kind == "impact_speed":
        u_c = float(safe.speed)
        Hs = [(float(system.potential(w.position)) + 0.5 * u_c * u_c, side)
              for side, w in system.walls]
        H_c, side = min(Hs)
        return H_c, (f"H_c = G(x_w) + u_c²/2 = {H_c:.6g} ({side} wall, u_c = {u_c:g}): "
                     "the first impact faster than u_c is the first at an energy above it")
    lo, hi = system.x_bounds
    bottom = 0.0 if lo <= 0.0 <= hi else (hi if hi < 0 else lo)
    if not safe.x_lo < bottom < safe.x_hi and not (bottom in (lo, hi) and
                                                   safe.x_lo <= bottom <= safe.x_hi):
        from ..safe_sets import SUPPORTED_BY
        others = [m for m in SUPPORTED_BY.get("displacement", ()) if m != "averaging"]
        use = f"; use {', '.join(others)}" if others else ""
        raise InputError(f"{where}: averaging maps a displacement set to an energy "
                         f"threshold only when it contains x = {bottom:g}, which every "
                         f"orbit passes; {safe.describe()} does not{use}", where=where,
                         name="displacement")
    bounds = [(float(system.potential(b)), b) for b in (safe.x_lo, safe.x_hi)
              if math.isfinite(b)]
    H_c, b = min(bounds)
    return H_c, (f"H_c = G(x_b) = {H_c:.6g} at the bound x_b = {b:g}: the orbit of "
                 "energy H reaches it within one period once H exceeds it")


class _Tau:
    """τ(H(x, y)) (picklable: no closure)."""

    def __init__(self, u, values, H_c, system) -> None:
        self.u, self.values, self.H_c, self.system = u, values, H_c, system

    def of_energy(self, H):
        return np.where(H < self.H_c, np.interp(H, self.u, self.values), 0.0)

    def __call__(self, x, y):
        return self.of_energy(self.system.energy(x, y))


def _eigen_survival(system, sol, H_c, n_cells, kind, value, mean, info):
    """R(t) = Σ_k c_k e^{λ_k t} of the finite-volume generator with the top face
    absorbing, or None when the decomposition cannot resolve τ (eps ‖A‖ τ above
    RESOLVABLE, or an operator that overflows): the caller uses exp(−t/τ)."""
    info["survival_method"] = "exponential law exp(-t/tau) (quasi-stationary)"
    with np.errstate(all="ignore"):
        faces = energy_faces(system, H_c, n_cells)
        A = averaged_operator(system, faces, sol).toarray()
        c, h = 0.5 * (faces[1:] + faces[:-1]), np.diff(faces)
        # the top face absorbs: flux ½ σ² p_s(H_c)/p_s(c_N) p_N / (H_c − c_N)
        _, _, s2c = coefficients(system, np.array([H_c]))
        Tf, Tc = (orbit_nodes(system, np.array([x])).period[0] for x in (H_c, c[-1]))
        ratio = Tf / Tc * np.exp(sol.phi(np.array([c[-1]]))[0] - sol.phi(np.array([H_c]))[0])
        A[-1, -1] -= 0.5 * s2c[0] * ratio / (H_c - c[-1]) / h[-1]
    if not np.all(np.isfinite(A)):
        return None
    rounding = 1.1e-16 * float(np.abs(A).sum(axis=0).max()) * mean
    info["rounding_error"] = rounding
    if rounding > RESOLVABLE:
        return None
    q0 = _start_masses(system, kind, value, sol, faces, H_c) / h       # cell densities
    lam, V = linalg.eig(A)
    coef = linalg.solve(V, q0)
    w = (h @ V) * coef
    info["tau_fv"] = float(h @ linalg.solve(-A, q0))
    info["survival_method"] = "eigen-decomposition of the finite-volume generator"
    lam_c = np.minimum(lam.real, 0.0) + 1j * lam.imag

    def survival(t):
        with np.errstate(under="ignore"):
            return np.real(w @ np.exp(np.outer(lam_c, np.asarray(t, float))))
    return survival


def _mean_from(kind, value, system, tau, sol, H_c) -> float:
    if kind == "point":
        return tau.of_energy(float(system.energy(*value)))
    if kind == "stationary":
        H = np.linspace(energy_floor(system), H_c, 20001)
        w = sol.pdf_energy(H)
        return float(np.trapezoid(w * tau.of_energy(H), H) / np.trapezoid(w, H))
    x, y, w = _gauss_hermite(value)
    inside = system.energy(x, y) < H_c
    return float(np.sum(w[inside] * tau.of_energy(system.energy(x[inside], y[inside])))
                 / np.sum(w[inside]))


def _gauss_hermite(value, n: int = 48):
    """Nodes and weights of the Gaussian start (a zero std is a point)."""
    (mx, my), (sx, sy) = value["mean"], value["std"]
    t, w = np.polynomial.hermite_e.hermegauss(n)
    w = w / w.sum()
    X, Y = np.meshgrid(mx + sx * t, my + sy * t, indexing="ij")
    return X.ravel(), Y.ravel(), np.outer(w, w).ravel()


def _start_masses(system, kind, value, sol, faces, H_c) -> np.ndarray:
    """P(H ∈ cell) of the start, conditioned on the safe set."""
    if kind == "point":
        H0 = float(system.energy(*value))
        q = np.zeros(faces.size - 1)
        q[min(max(np.searchsorted(faces, H0) - 1, 0), q.size - 1)] = 1.0
        return q
    if kind == "stationary":
        H = np.linspace(faces[0], faces[-1], 40001)
        cdf = integrate.cumulative_trapezoid(sol.pdf_energy(H), H, initial=0.0)
        q = np.diff(np.interp(faces, H, cdf))
    else:
        x, y, w = _gauss_hermite(value)
        Hs = system.energy(x, y)
        q, _ = np.histogram(Hs, bins=faces, weights=w)
    return q / q.sum()


MODEL_ERROR_ASSUMES = (
    "the difference to the finite-element first passage of the same system, safe set and "
    "start (fem.first_passage at its default accuracy, or the given one) plus FE's own "
    "estimate; assumes FE resolves the system; reliability: the largest "
    "|R_averaging − R_FE| over the times both grids cover")


def _start_spec(start: tuple) -> Any:
    """The ``start`` argument that gives back ``FirstPassage.start``."""
    kind, value = start
    if kind == "stationary":
        return "stationary"
    if kind == "gaussian":
        return {"mean": tuple(value["mean"]), "std": tuple(value["std"])}
    return tuple(value)


def _set_spec(system: VibroImpactSystem, safe: SafeSet) -> dict[str, Any]:
    """The keyword that gives back ``safe`` (a bound beyond a wall as the wall)."""
    if safe.kind == "energy":
        return {"energy": safe.energy}
    if safe.kind == "impact_speed":
        return {"impact_speed": safe.speed}
    lo, hi = system.x_bounds
    return {"displacement": (safe.x_lo if math.isfinite(safe.x_lo) else lo,
                             safe.x_hi if math.isfinite(safe.x_hi) else hi)}


def _same_set(a: SafeSet, b: SafeSet) -> bool:
    """Two safe sets equal up to rounding of their numbers."""
    if a.kind != b.kind:
        return False
    va, vb = np.atleast_1d(np.asarray(a.value, float)), np.atleast_1d(np.asarray(b.value, float))
    return bool(np.all((va == vb) | np.isclose(va, vb, rtol=1e-12, atol=0.0)))


def model_error(fp: FirstPassage, reference: FirstPassage | None = None) -> dict[str, Any]:
    """The model error of an averaged first passage (:meth:`FirstPassage.error_estimate`)::

        mean_time   = |τ_averaging − τ_FE| / τ_FE + mean_time(FE)
        reliability = max_t |R_averaging(t) − R_FE(t)| + reliability(FE)

    over the union of both time grids up to the shorter one's end (R linear between
    grid times).  FE: ``reference``, or ``fem.first_passage`` of the same system,
    energy and start at its default accuracy (reached through
    :mod:`fpk_vibro.references`, name ``"fem-first-passage"``: the FE first passage
    builds on averaging, so it is not imported here).

    Returns
    -------
    dict
        ``mean_time``, ``reliability`` (infinite where FE refuses or has no
        estimate), ``reference`` (what FE solve, or FE's reason), ``seconds``,
        ``assumes``.

    Raises
    ------
    ValueError
        A ``reference`` that is not an FE first passage of the same energy and start.
    """
    from .._checks import InputError
    from ..references import reference as solve_reference
    where = "averaging.first_passage"
    t0 = time.perf_counter()
    out: dict[str, Any] = {"mean_time": math.inf, "reliability": math.inf,
                           "assumes": MODEL_ERROR_ASSUMES}
    safe = fp.safe_set
    if reference is not None:
        if not isinstance(reference, FirstPassage) or reference.method != "fem" or \
                not _same_set(reference.safe_set, safe) or reference.start != fp.start:
            got = (f"{reference.method} first passage out of "
                   f"{reference.safe_set.describe()}, start {reference.start[1]!r}")\
                if isinstance(reference, FirstPassage) else type(reference).__name__
            raise ValueError(f"{where}: error_estimate: reference must be the FE first "
                             f"passage out of {safe.describe()} from {fp.start[1]!r}; "
                             f"got {got}")
        ref, what = reference, "the given FE first passage"
    else:
        try:
            ref = solve_reference("fem-first-passage", fp.system,
                                  **_set_spec(fp.system, safe),
                                  start=_start_spec(fp.start))
        except (InputError, ValueError, MemoryError, TypeError) as exc:
            out["reference"] = "none: fem.first_passage refused (" + \
                " ".join(str(exc).split()) + ")"
            out["seconds"] = time.perf_counter() - t0
            return out
        what = "fem.first_passage at its default accuracy"
    try:
        fe = ref.error_estimate()
    except ValueError as exc:
        out["reference"] = f"none: the FE first passage has no estimate ({exc})"
        out["seconds"] = time.perf_counter() - t0
        return out
    t_end = min(float(fp.times[-1]), float(ref.times[-1]))
    t = np.union1d(fp.times, ref.times)
    t = t[t <= t_end]
    dR = float(np.max(np.abs(survival_at(fp.times, fp.survival, t)
                             - survival_at(ref.times, ref.survival, t))))
    out.update(mean_time=abs(fp.mean - ref.mean) / ref.mean + float(fe["mean_time"]),
               reliability=dR + float(fe["reliability"]),
               reference=(f"{what} (nx = {ref.info.get('nx')}, τ = {ref.mean:.6g}, its "
                          f"estimate {fe['mean_time']:.1g} of τ, {fe['reliability']:.1g} "
                          "of R)"),
               seconds=time.perf_counter() - t0)
    return out
