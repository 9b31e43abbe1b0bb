"""The periodic steady state under harmonic plus random excitation:
:func:`periodic`, found directly by harmonic balance.

Design: harmonic balance (:mod:`fpk_vibro.fem.harmonic`).  The FPK is linear in p
and the forcing only adds the drift F cos(Ωt + φ0) in y, so the generator is
L(t) = L0 + F cos ψ L1 and the periodic density's Fourier coefficients in time
solve one block-tridiagonal system coupling neighbouring harmonics.  Why this and
not a block-cyclic system over one period or Newton–Krylov on the period map:
the periodic density is smooth in time (the forcing is one harmonic and the
noise smooths), so its coefficients decay exponentially in k and a handful of
harmonics give round-off (measured on the paper system, F = 0.05, Ω = 0.9:
‖p_k‖ falls 15-20× per k); no time step is taken, so there is neither a time
discretisation error nor a march through the relaxation time 1/c (dozens of
periods); a time-collocation over one period would need ~10² steps for the same
accuracy, and the period map ~10² implicit steps per Krylov iteration.  The price
is K + 1 sparse LUs of the size of a stationary solve (one complex per harmonic).

Error estimate: the difference to one richer level (degree k + 1 on the same mesh,
or h/2 at degree 4, and K + 2 harmonics), as for the stationary density
(:mod:`fpk_vibro.fem.estimate`, whose ``error_estimate(sol, richer=...)`` makes
each phase's and the average's), and SAFETY × the difference for the mean x̄,
amplitude A and lag θ of E[x](t).  With ``rtol`` the mesh is refined (nx, ny
doubled) until the largest of them meets it.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import skfem

from .._checks import invalid
from ..forcing import TWO_PI, check_phases
from ..model import VibroImpactSystem
from ..periodic import PeriodicResponse
from .estimate import SAFETY, error_estimate
from .compare import AIMED, worst
from .generator import assemble_tensor, element_for, tensor_index
from .harmonic import HarmonicSystem, Harmonics, forcing_matrix, moment_rows
from .ladder import WALL_GRADING
from .mesh import Domain, StripEnd, domain, structured_mesh, wall_restitutions
from .nonnegative import correct
from .periodic_options import (DEFAULT_RTOL, MAX_HARMONICS, MAX_SECONDS, START_HARMONICS,
                               START_NX)
from .solution import FEMSolution

__all__ = ["periodic", "forced_domain"]


def periodic(system: VibroImpactSystem, phases: Any, *, rtol: float | None = None,
             nx: int | None = None, ny: int | None = None, degree: int | None = None,
             harmonics: int | None = None, y_max: float | None = None,
             wall_grading: float | None = None) -> PeriodicResponse:
    """The periodic density p(x, y, t + 2π/Ω) = p(x, y, t) of a forced system.

    Parameters
    ----------
    system : VibroImpactSystem
        With ``forcing=Harmonic(amplitude=F, frequency=Ω, phase=φ0)``.
    phases : sequence of float
        Phases φ = (Ωt + φ0) mod 2π in [0, 2π) at which to give the density.
    rtol : float, optional
        Accuracy goal for every output (each phase's and the average's L1 error and
        relative moments, the amplitude (relative) and lag (radians) of E[x]):
        nx, ny doubled until met.  Default 1e-3 (best effort, flagged
        ``info["rtol_not_reached"]`` where missed) when none of nx, ny, degree,
        harmonics is given.
    nx, ny : int, optional
        Cells across x and y (default 12, and h_y ≈ 1.5 h_x).
    degree : {1, 2, 3, 4}, optional
        Lagrange degree (default 3; the estimate's richer level is degree + 1, or
        h/2 at degree 4).
    harmonics : int, optional
        K, the highest harmonic kept; default: raised from 4 by 4 until
        ‖p_K‖ < rtol/10 (lumped L1, relative to ‖p_0‖ = 1).
    y_max : float, optional
        Velocity truncation; default the unforced tail rule plus Ω times the linear
        response amplitude (the density moves with the mean response).
    wall_grading : float, optional
        x-grading toward walls with r < 1 (default 2, as the stationary rtol solve).

    Returns
    -------
    PeriodicResponse
        ``.at(i)``: the :class:`FEMSolution` at ``phases[i]`` (non-negative, its
        correction in its estimate); ``.average()``: the period average (p_0);
        ``.amplitude``, ``.lag``, ``.mean_x``; ``.error_estimate()``.

    Raises
    ------
    InputError
        One line: an unforced system, bad phases or options.

    Examples
    --------
    >>> import numpy as np
    >>> from fpk_vibro import VibroImpactSystem, Harmonic, fem
    >>> s = VibroImpactSystem.paper(r=0.8, forcing=Harmonic(0.05, 0.9))
    >>> r = fem.periodic(s, np.arange(4) * np.pi / 2, degree=2, nx=8, harmonics=3)
    >>> 0.03 < r.amplitude < 0.06
    True
    """
    from .options import Options
    where = "fem.periodic"
    if isinstance(system, VibroImpactSystem) and system.forcing is None:
        raise invalid(where, "system", "a system with forcing=Harmonic(amplitude, "
                      "frequency)", "forcing=None", "use fem.stationary for an unforced "
                      "system")
    phases = check_phases(where, phases)
    opts, _ = Options.prepare(system, "periodic", locals())
    given = opts.nx or opts.ny or opts.harmonics or opts._degree_given
    rtol = opts.rtol if opts.rtol is not None or given else DEFAULT_RTOL
    t0 = time.perf_counter()
    dom = forced_domain(system, opts.y_max)
    deg = opts.degree if opts._degree_given else 3
    grading = opts.wall_grading
    if grading is None:
        grading = WALL_GRADING if any(not w.elastic for _, w in system.walls) else 1.0
    nx = START_NX if opts.nx is None else opts.nx
    ny = opts.ny if opts.ny is not None else _default_ny(dom, nx)
    goal = rtol if rtol is not None else DEFAULT_RTOL
    K = opts.harmonics
    while True:
        level = _Level(system, dom, deg, nx, ny, grading)
        harm = level.solve(K, goal)
        rdeg, rnx, rny = (deg + 1, nx, ny) if deg < 4 else (4, 2 * nx, 2 * ny)
        richer = _Level(system, dom, rdeg, rnx, rny, grading)
        rharm = richer.solve(harm.K + 2, goal)
        out = _response(system, phases, level, harm, richer, rharm)
        est = out.error_estimate()
        reached = _worst(est, out) <= goal
        spent = time.perf_counter() - t0
        if (rtol is None or reached or 2 * nx > 4096
                or spent * 8.0 > MAX_SECONDS):
            break
        nx, ny = 2 * nx, 2 * ny
    out.info.update(seconds=time.perf_counter() - t0, rtol=rtol,
                    estimated_error=_worst(est, out))
    if rtol is not None and not reached:
        out.info["rtol_not_reached"] = True
    return out


def forced_domain(system: VibroImpactSystem, y_max: float | None) -> Domain:
    """The truncated strip of the forced density: the unforced one (walls, tail cut)
    widened by the linear response, x by A = F/√((a − Ω²)² + (cΩ)²) at a cut side
    (up to the wall there) and y by Ω A (capped at the unforced y_max)."""
    f = system.forcing
    base = domain(system.replace(forcing=None), y_max)
    A = f.amplitude / math.hypot(system.a - f.frequency ** 2, system.c * f.frequency)
    x0, x1 = base.x0, base.x1
    ends = list(base.walls)
    for i, (side, wall) in enumerate((("left", system.left), ("right", system.right))):
        cut = x0 if i == 0 else x1
        if wall is not None and cut == wall.position:
            continue
        shift = min(A, x1 - x0)
        new = cut - shift if i == 0 else cut + shift
        if wall is not None and (new <= wall.position if i == 0 else new >= wall.position):
            new, r = wall.position, wall_restitutions(system)[i]
        else:
            r = 1.0
        ends[i] = StripEnd(new, r, -1 if i == 0 else 1)
        x0, x1 = (new, x1) if i == 0 else (x0, new)
    ym = base.y_max if y_max is not None else base.y_max + min(f.frequency * A, base.y_max)
    return Domain(x0, x1, float(ym), tuple(ends), base.beyond)


def _default_ny(dom: Domain, nx: int) -> int:
    ratio = (2.0 * dom.y_max) / (dom.x1 - dom.x0) / 1.5
    return max(2, 2 * int(round(0.5 * nx * min(ratio, 4.0))))


@dataclass
class _Level:
    """One discretisation: tensor mesh, L0, M, L1, moment rows."""
    system: VibroImpactSystem
    dom: Domain
    degree: int
    nx: int
    ny: int
    grading: float

    def __post_init__(self) -> None:
        t0 = time.perf_counter()
        self.mesh, self.xs, self.ys = structured_mesh(self.dom, self.nx, self.ny,
                                                      wall_grading=self.grading)
        unforced = self.system.replace(forcing=None)
        op = assemble_tensor(unforced, self.xs, self.ys, self.degree, self.dom)
        Mx, My = op.mass_factors
        self.L0, self.M, self.unit = op.L, op.M, op.unit
        self.L1 = forcing_matrix(op.xbasis, op.ybasis, Mx)
        self.rows = moment_rows(op.xbasis, op.ybasis, Mx, My)
        self.order = None
        if self.degree == 2:
            basis = skfem.CellBasis(self.mesh, element_for(self.mesh, 2), intorder=1)
            self.order = tensor_index(op.xbasis, op.ybasis, basis)
        self.seconds = time.perf_counter() - t0

    def solve(self, K: int | None, goal: float) -> Harmonics:
        """The harmonics; K chosen (module docstring of :func:`periodic`) if None.
        Raising K reuses the factorisations and starts from the last solution."""
        f = self.system.forcing
        if getattr(self, "harmonic", None) is None:
            self.harmonic = HarmonicSystem(self.L0, self.M, self.L1, self.unit,
                                           f.amplitude, f.frequency)
        fixed = K is not None
        K = START_HARMONICS if K is None else K
        h = None
        while True:
            h = self.harmonic.solve(K, start=h)
            tail = h.tail(self.unit)
            if fixed or tail[-1] <= 0.1 * goal * tail[0] or K >= MAX_HARMONICS:
                h.info["tail"] = float(tail[-1] / tail[0])
                return h
            K = min(K + 4, MAX_HARMONICS)

    def solution(self, p: np.ndarray, **info: Any) -> FEMSolution:
        dofs = p if self.order is None else p[self.order]
        sol = FEMSolution(self.system, self.mesh, self.degree, dofs, residual=0.0,
                          info={"ndofs": int(p.size), "discretisation": "galerkin",
                                "assembly": "tensor", "y_max": self.dom.y_max, **info},
                          tensor=(self.xs, self.ys), mass=float(self.unit @ p))
        return correct(sol)


def _harmonic(level: _Level, h: Harmonics) -> tuple[float, float, float]:
    """(x̄, A, θ) of E[x](t) from p_0 and p_1: E[x] = x̄ + 2 Re(X_1 e^{iψ})."""
    xbar = float(level.rows["x"] @ h.coef[0].real)
    X1 = complex(level.rows["x"] @ h.coef[1]) if h.K >= 1 else 0j
    return xbar, 2.0 * abs(X1), (-math.atan2(X1.imag, X1.real)) % TWO_PI


def _response(system, phases, level, harm, richer, rharm) -> PeriodicResponse:
    sols, rich = [], []
    for phi in phases:
        sols.append(level.solution(harm.at(phi), phase=float(phi), K=harm.K))
        rich.append(richer.solution(rharm.at(phi), phase=float(phi), K=rharm.K))
    avg = level.solution(harm.coef[0].real, phase="average", K=harm.K)
    ravg = richer.solution(rharm.coef[0].real, phase="average", K=rharm.K)
    for s, r in zip(sols + [avg], rich + [ravg]):
        s._estimate = error_estimate(s, richer=r)
        s._estimate["E_x"] = SAFETY * abs(s.mean_x() - r.mean_x())   # (absolute)
        s._estimate["harmonics"] = f"K = {harm.K} (richer K = {rharm.K})"
    (xb, A, th), (rxb, rA, rth) = _harmonic(level, harm), _harmonic(richer, rharm)
    dth = abs((th - rth + math.pi) % TWO_PI - math.pi)
    estimate = {"mean_x": SAFETY * abs(xb - rxb), "amplitude": SAFETY * abs(A - rA),
                "lag": SAFETY * dth,
                "assumes": "the difference to one level richer in space (degree + 1, or "
                           "h/2 at degree 4) and in time (K + 2 harmonics), times "
                           f"{SAFETY:g}"}
    f = system.forcing
    Y1 = complex(level.rows["y"] @ harm.coef[1]) if harm.K >= 1 else 0j
    info = {"degree": level.degree, "nx": level.nx, "ny": level.ny, "harmonics": harm.K,
            "harmonic_tail": harm.info["tail"], "gmres_iterations": harm.iterations,
            "backward_error": harm.residual, "ndofs": int(level.unit.size),
            "unknowns": int(level.unit.size * (2 * harm.K + 1)),
            "solve_seconds": harm.seconds, "richer_solve_seconds": rharm.seconds,
            "y_max": level.dom.y_max, "x0": level.dom.x0, "x1": level.dom.x1,
            "forcing_work": f.amplitude * Y1.real,
            "richer": f"degree {richer.degree}, {richer.nx} x {richer.ny} cells, "
                      f"K = {rharm.K}"}
    return PeriodicResponse("fem", system, phases, sols, avg, amplitude=A, lag=th,
                            mean_x=xb, estimate=estimate, info=info)


def _worst(est: dict, out: PeriodicResponse) -> float:
    """The largest estimated error: every phase's and the average's L1 and relative
    moments, the amplitude relative to max(A, 1e-3 of the strip), the lag (rad)."""
    parts = [worst(e, AIMED) for e in est["phases"] + [est["average"]]]
    scale = max(out.amplitude, 1e-3 * (out.info["x1"] - out.info["x0"]))
    parts += [est["amplitude"] / scale, est["lag"]]
    return float(max(parts))
