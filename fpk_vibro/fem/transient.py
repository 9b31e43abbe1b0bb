"""The 2-D FPK in time: M dp/dt = L p from a given initial density.

Theory: docs/theory.md, §Transients.

Same generator L and mass matrix M as :func:`fpk_vibro.fem.stationary`.  Schemes:

- ``"bdf2"`` (default): variable-step BDF2, L-stable and second order; the first
  step of a run is implicit Euler.  With ω = dt_n/dt_(n−1):
  ((1+2ω)/(1+ω) M − dt_n L) pⁿ⁺¹ = M((1+ω) pⁿ − ω²/(1+ω) pⁿ⁻¹).
- ``"theta"``: (M − θ dt L) pⁿ⁺¹ = (M + (1−θ) dt L) pⁿ; θ = 1 implicit Euler,
  θ = ½ Crank–Nicolson (stable but undamped at large dt: not L-stable).
- ``"euler"``: implicit Euler (the θ-scheme with θ = 1).

``positivity`` (degree 1 on the structured quad mesh): L is replaced by the
positive tensor-grid generator A of :mod:`fpk_vibro.fem.positivity` (part A,
off-diagonals ≥ 0, column sums 0) and M by the lumped dual-cell masses
diag(m), and the scheme is implicit Euler: diag(m) − dt A is then an M-matrix
(non-positive off-diagonals, columns diagonally dominant), so its inverse is
non-negative and pⁿ⁺¹ ≥ 0 for any dt, with ∫p = mᵀp kept exactly.  BDF2 and
θ < 1 have no such property.  ``"first-order"`` uses A with unit flux factors
(one LU per step size); ``True``/``"quick"``/``"van-albada"`` take the clipped
high-order flux factors g(pⁿ) of part B from the previous step (linearly
implicit: one LU per step, still a generator for any g ≥ 0).  Both are first
order in time.

Because 1ᵀL = 0, every scheme keeps ∫p = 1ᵀM p exactly (to the round-off of the
sparse LU solves).  Each distinct matrix is factorised once (SuperLU) and reused;
the adaptive controller changes the step only when it can grow by ``GROW_MIN`` or
must shrink, so that few distinct matrices arise.

:func:`fpk_vibro.fem.exponential.exponential` is the positivity-preserving alternative of second order in
time: the exponential of the positive generator by uniformisation (non-negative
term by term), exact in time for ``"first-order"`` and the exponential midpoint
rule for the limited flux factors.
"""
from __future__ import annotations

import math
import sys
import time
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..initial import parse_initial, parse_times
from ..model import VibroImpactSystem, check_system
from ..progress import Progress
from ..solution import TransientResult
from .discretisation import Discretisation, build, discretise
from .relaxation import relaxation_time
from .solve import factorised as step_solver, grid_nested_dissection, is_p1, nd_lu
from .initial_density import default_dt, initial_vector as _initial_vector
from .solution import FEMSolution

__all__ = ["transient", "Discretisation", "discretise", "relaxation_time"]

#: Local L1 error per step of the adaptive default (``dt`` and ``tol`` not given).
DEFAULT_TOL = 3e-4
#: SuperLU options of the step matrices a0 M − h L: minimum degree on Aᵀ+A with
#: diagonal pivots preferred gives about two thirds of the fill of COLAMD on these 2-D
#: stencils; without the pivot preference, row swaps at large h destroy the ordering.
SPLU = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.01,
        "options": {"SymmetricMode": True}}
#: An accepted step is lengthened only when the error allows at least this factor:
#: every new step size costs a factorisation.
GROW_MIN = 1.5
#: Adaptive step sizes per octave (the ladder dt·2^(k/LADDER)): few distinct matrices.
LADDER = 2
#: Factorised step matrices kept (least recently used dropped first).
MAX_FACTORS = 16


def transient(system: VibroImpactSystem, *, initial: Any, times: Sequence[float],
              dt: float | None = None, scheme: str | None = None, nx: int | None = None,
              ny: int | None = None, degree: int | None = None, mesh=None,
              y_max: float | None = None,
              theta: float = 0.5, tol: float | None = None, progress: bool | None = None,
              discretisation: Discretisation | None = None,
              positivity: bool | str = False, element: str = "quad",
              grading: float = 0.0, wall_grading: float | None = None,
              rtol: float | None = None, nz: int | None = None) -> list[FEMSolution]:
    """Densities at ``times`` from ``initial`` (docs/theory.md, §Transients).

    Parameters
    ----------
    system : VibroImpactSystem
    initial : dict, callable or Solution
        ``{"mean": (x0, y0), "std": (sx, sy)}`` (the spec shared with the Monte Carlo
        and averaged transients; a zero std is widened to one cell), a callable
        p0(x, y), or a previous solution (e.g. a FEMSolution).  Interpolated at the
        nodes and renormalised to ∫p = 1.
    times : sequence of float
        Strictly increasing output times ≥ 0.
    dt : float, optional
        Fixed steps: the largest time step; each interval between output times is
        split into equal steps so every time is hit exactly.  Not given (and no
        ``tol``): adaptive BDF2 steps with ``tol = DEFAULT_TOL`` (3e-4) and at most
        :func:`default_dt` — a narrow initial packet needs small steps at first;
        with ``positivity``, fixed steps of :func:`default_dt`.
    scheme : {"bdf2", "theta", "euler"}, optional
        Default "bdf2"; with ``positivity`` only "euler" (or "theta" with θ = 1),
        which is the default then.
    degree : {1, 2, 3, 4}, optional
        Default 2 (Q2, nx = 48), or 1 with ``positivity``: on the paper packet Q2
        reaches 0.03 % in about a third of the time Q1 (nx = 128) needs for 0.05 %
        (docs/fem_transient.md).  3 and 4 (Q3/Q4) on the structured quad mesh only,
        as in :func:`fpk_vibro.fem.stationary`.
    nx, ny, mesh, y_max, element, grading, wall_grading
        As in :func:`fpk_vibro.fem.stationary`.
    theta : float
        θ of the θ-scheme, in [1/2, 1].
    tol : float, optional
        Adaptive steps (BDF2 only): the local error of each step, estimated by
        Milne's device against the quadratic extrapolation of the last three
        states, is kept below ``tol`` in L1 (∫|Δp|); ``dt`` is then the first and
        largest step.  Every step matrix is a rung M − g L of a ladder
        g ∝ 2^(−k/2) and the step length follows from it, so LU factors are reused
        (``_march_adaptive``).  None (default): fixed steps of at most ``dt``.
    rtol : float, optional
        Accuracy goal in space and time: degree, nx and the step tolerance are chosen
        until the estimated relative errors of the moments at every output time are
        below it (:mod:`fpk_vibro.fem.transient_accuracy`; each density then has
        ``error_estimate()``).  Not with nx, ny, degree, mesh, dt, tol, positivity or
        discretisation.
    progress : bool, optional
        A progress bar (:mod:`fpk_vibro.progress`; default: on a terminal or in a
        Jupyter notebook, after 2 s; False: never).
    discretisation : Discretisation, optional
        Reuse an assembled mesh and operator (then nx, ny, ... and
        ``positivity`` come from it; :func:`discretise`).
    positivity : bool or {"quick", "van-albada", "first-order"}
        Non-negative densities for any dt by the positive generator and implicit
        Euler (module docstring); degree 1 on the default structured mesh.
        Default False: the Galerkin L of :func:`fpk_vibro.fem.stationary`, which
        undershoots where a narrow packet is under-resolved (−12 % of max p at
        t = 1 for x = 0, y ~ N(1, 0.05²) on nx = 24, measured).

    Returns
    -------
    list of FEMSolution
        One per time, each with ``.time``, ``.mass``, ``.min_density`` and
        ``error_estimate()`` (without ``rtol``: the first call on any of them runs one
        richer transient, in space and time, for all;
        :mod:`fpk_vibro.fem.transient_estimate`); if interrupted (Ctrl-C) the
        finished ones, each with ``partial=True`` in ``info``.
    """
    from .options import Options
    if getattr(system, "external", None) is not None:
        return _coloured(system, locals())
    check_system("fem.transient", system, forcing=True)
    t_out = parse_times(times, "fem.transient")
    gaussian = parse_initial(initial, system) if isinstance(initial, dict) else None
    opts, _ = Options.prepare(system, "transient", locals(), initial=gaussian, times=t_out)
    if opts.rtol is not None:
        from .transient_accuracy import adaptive_transient
        return adaptive_transient(system, initial, t_out, opts.rtol, opts, progress,
                                  march=transient)
    if opts.discretisation is not None:
        positivity = opts.discretisation.positivity
    if positivity == "auto":                 # in a transient "auto" is Galerkin
        positivity = False
    scheme, theta, tol, dt = opts.scheme, opts.theta, opts.tol, opts.dt
    if scheme is None:
        scheme = "euler" if positivity else "bdf2"
    if scheme == "euler":
        scheme, theta = "theta", 1.0
    if dt is None:
        dt = default_dt(system)
        if tol is None and scheme == "bdf2":
            tol = DEFAULT_TOL          # no step given: adaptive steps by default
    disc = opts.discretisation or build(system, opts)
    force = None
    if system.forcing is not None:        # IMEX-BDF2: the forcing explicit
        from .forced import ForcingTerm
        if scheme != "bdf2" or positivity:
            from .._checks import invalid
            raise invalid("fem.transient", "scheme", "'bdf2' without positivity for a "
                          "forced system (IMEX-BDF2)", scheme)
        force = ForcingTerm(system, disc)
    p = _initial_vector(disc, initial)
    M, L = disc.M.tocsc(), disc.L.tocsc()
    lu_cache: dict[float, Any] = {}
    factorised = [0]
    limited = positivity not in (False, "first-order")
    # one nested-dissection order for every step matrix of a Q1 tensor grid (the
    # pattern does not change with the step): ~40 % less factorisation time than MMD
    order = (grid_nested_dissection(*disc.ranks)
             if disc.ranks is not None and all(is_p1(r) for r in disc.ranks) else None)

    def solver_of(K: sp.spmatrix, reuse: bool = True):
        """A solve of K x = b: for the positive generator (an M-matrix step matrix)
        LU or, above the measured size, AMG (:func:`fpk_vibro.fem.solve.factorised`)."""
        if disc.kind == "positive":
            xs, ys = disc.tensor
            return step_solver(K.tocsr(), grid=(np.arange(xs.size), np.arange(ys.size)),
                               reuse=reuse)
        if order is not None:
            return nd_lu(K, order)
        return spla.splu(K.tocsc(), **SPLU).solve

    def solve(a0: float, h: float, rhs: np.ndarray) -> np.ndarray:
        """(a0 M − h L)⁻¹ rhs, through the factors of M − (h/a0) L (one per h/a0)."""
        key = round(h / a0, 14)
        if key not in lu_cache:
            factorised[0] += 1
            lu_cache[key] = solver_of(M - key * L)
        lu_cache[key] = lu_cache.pop(key)          # most recently used last
        return lu_cache[key](rhs) / a0

    def step(p: np.ndarray, p_prev: np.ndarray | None, h: float, h_prev: float | None,
             t_new: float = 0.0):
        if limited:      # flux factors of pⁿ: a new generator, one solve per step
            A = disc.limited_generator(p)
            return solver_of(M - h * A, reuse=False)(M @ p)
        if scheme == "theta":
            return solve(1.0, theta * h, M @ p + (1 - theta) * h * (L @ p))
        return _bdf2(solve, M, p, p_prev, h, h_prev, force, t_new)

    def done(out: list) -> list:     # error_estimate(): one richer run, on demand
        from .transient_estimate import attach
        return attach(out, system, initial, t_out, opts, progress, transient, scheme=scheme,
                      theta=theta, dt=dt, tol=tol)

    if tol is not None:
        return done(_march_adaptive(disc, p, t_out, dt, tol, solve, lu_cache, factorised,
                                    progress, force))
    n_total = int(sum(math.ceil((b - a) / dt - 1e-9) for a, b in zip(np.r_[0.0, t_out[:-1]], t_out)))
    bar = Progress(progress, "fem.transient", total=n_total, unit="step")
    out = TransientResult()
    t_now, p_prev, h_prev, steps, t0 = 0.0, None, None, 0, time.perf_counter()
    try:
        for t_target in t_out:
            span = t_target - t_now
            n = int(math.ceil(span / dt - 1e-9)) if span > 0 else 0
            h = span / n if n else 0.0
            for i in range(n):
                p_new = step(p, p_prev, h, h_prev, t_now + (i + 1) * h)
                p_prev, p, h_prev = p, p_new, h
                steps += 1
                if steps % 50 == 0:
                    bar.update(steps, f"t = {t_now + h:.4g}")
            t_now = float(t_target)
            out.append(_snapshot(disc, p, t_now, steps=steps, scheme=scheme, dt=h or dt,
                                 positivity=positivity))
    except KeyboardInterrupt:
        _mark_partial(out, t_now)
    finally:
        bar.close(f"{steps} steps in {time.perf_counter() - t0:.1f} s")
    return done(out)


def _bdf2(solve, M, p, p_prev, h, h_prev, force=None, t_new=0.0):
    """One variable-step BDF2 step (implicit Euler when there is no previous state);
    ``force(t, h, p*)``: the explicit forcing term at the step's end, p* the linear
    extrapolation (1 + ω) pⁿ − ω pⁿ⁻¹ (IMEX-BDF2: second order, the factors of the
    constant operator kept)."""
    if p_prev is None:
        rhs = M @ p
        if force is not None:
            rhs = rhs + force(t_new, h, p)
        return solve(1.0, h, rhs)
    w = h / h_prev
    rhs = M @ ((1 + w) * p - (w * w / (1 + w)) * p_prev)
    if force is not None:
        rhs = rhs + force(t_new, h, (1 + w) * p - w * p_prev)
    return solve((1 + 2 * w) / (1 + w), h, rhs)


def _snapshot(disc: Discretisation, p: np.ndarray, t: float, **info: Any) -> FEMSolution:
    sol = disc.solution(p.copy(), time=t, **info)
    sol.time = t
    return sol


def _mark_partial(out: TransientResult, t_now: float) -> None:
    out.partial = True
    for s in out:
        s.partial = True
        s.info["partial"] = True        # (kept in its file)
    print(f"\nfem.transient: interrupted at t = {t_now:g}; returning {len(out)} "
          "finished time(s)", file=sys.stderr)


def _march_adaptive(disc, p, t_out, dt_max, tol, solve, lu_cache, factorised,
                    progress: bool | None = None, force=None) -> list[FEMSolution]:
    """BDF2 with step-size control by Milne's device (see :func:`transient`).

    Every step matrix is a rung M − g L of the ladder g = g_max·2^(−k/LADDER),
    g_max = dt_max/1.5: the controller chooses the rung, and each step its length h
    so that h/a0(h/h_prev) = g, the BDF2 leading coefficient a0 = (1+2ω)/(1+ω) with
    ω = h/h_prev.  On a fixed rung h → 1.5 g (ω → 1); a change of rung is smooth
    (ω ≤ 2.26 < 1 + √2, the zero-stability bound of variable-step BDF2) and costs
    no factorisation beyond one per rung.  Output times are read off the quadratic
    through the last three states (its error is of the order of the local error), so
    no step is cut to hit them.
    """
    M = disc.M.tocsc()
    hist = [(0.0, p)]                      # accepted (t, p), newest last, at most 3
    g_max = dt_max / 1.5
    k = 10 * LADDER                        # first rung g_max/1024: the first two
    out = TransientResult()                 # steps are not error-controlled
    steps = rejected = 0
    t_now = 0.0
    bar = Progress(progress, "fem.transient")
    try:
        for t_target in t_out:
            while t_now < t_target - 1e-12 * max(1.0, t_target):
                if steps % 20 == 0:
                    bar.update(t_now / t_out[-1], f"t = {t_now:.4g}")
                g = g_max * 2.0 ** (-k / LADDER)
                prev = hist[-2] if len(hist) >= 2 else None
                if prev is None:           # implicit Euler: a0 = 1, h = g
                    h, p_prev, h_prev = g, None, None
                else:
                    h_prev = t_now - prev[0]
                    c = g / h_prev
                    h = h_prev * ((2 * c - 1) + math.sqrt((2 * c - 1) ** 2 + 4 * c)) / 2
                    p_prev = prev[1]
                t_new = t_now + h
                p_new = _bdf2(solve, M, hist[-1][1], p_prev, h, h_prev, force, t_new)
                err = 0.0
                if len(hist) == 3:         # quadratic extrapolation: error O(h³), like BDF2
                    err = (2.0 / 11.0) * float(disc.unit @ np.abs(p_new - _lagrange(hist, t_new)))
                factor = 2.0 if err == 0 else min(2.0, max(0.2, 0.9 * (tol / err) ** (1 / 3)))
                if err > tol:
                    rejected += 1
                    k += max(1, math.ceil(-LADDER * math.log2(factor)))
                    continue
                t_now = t_new
                hist = (hist + [(t_now, p_new)])[-3:]
                steps += 1
                if factor >= GROW_MIN and k > 0:
                    k -= 1
                while len(lu_cache) > MAX_FACTORS:        # least recently used out
                    lu_cache.pop(next(iter(lu_cache)))
            p_out = _lagrange(hist, float(t_target)) if t_now > t_target else hist[-1][1]
            out.append(_snapshot(disc, p_out, float(t_target), steps=steps,
                                 rejected=rejected, scheme="bdf2", tol=tol,
                                 factorisations=factorised[0]))
    except KeyboardInterrupt:
        _mark_partial(out, t_now)
    finally:
        bar.close()
    return out


def _lagrange(hist: list[tuple[float, np.ndarray]], t: float) -> np.ndarray:
    """The polynomial through the states of ``hist`` (up to three), at time t."""
    ts = [h[0] for h in hist]
    out = np.zeros_like(hist[-1][1])
    for i, (ti, pi) in enumerate(hist):
        w = math.prod((t - tj) / (ti - tj) for j, tj in enumerate(ts) if j != i)
        out += w * pi
    return out


#: fem.transient's keywords a coloured-noise (3-D) transient takes.
_COLOURED_KEYS = ("initial", "times", "dt", "nx", "ny", "nz", "degree", "y_max", "progress")


def _coloured(system: VibroImpactSystem, given: dict) -> list[FEMSolution]:
    from .._checks import InputError
    from .coloured_transient import transient_coloured
    defaults = transient.__kwdefaults__
    for key, value in given.items():
        if key in _COLOURED_KEYS or key in ("system", "Options"):
            continue
        if value is not defaults.get(key) and value != defaults.get(key):
            raise InputError(f"fem.transient: {key} is not an option of the coloured-noise "
                             f"(3-D) transient; it takes {', '.join(_COLOURED_KEYS)}",
                             where="fem.transient", name=key)
    from .options import Options
    kw = {k: given[k] for k in _COLOURED_KEYS}
    Options.prepare(system, "transient", {k: v for k, v in kw.items()
                                          if v is not None and k not in ("initial", "times")},
                    times=kw["times"])
    return transient_coloured(system, **kw)
