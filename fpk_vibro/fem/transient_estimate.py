"""The error estimate of an FE transient: one richer transient, shared by every time.

``fem.transient(...)`` without ``rtol`` gives each density it returns an
:class:`OnDemand` estimator.  The first ``error_estimate()`` of any of them runs ONE
richer transient from the same initial condition (the very object given: a dict
spec, a callable p0(x, y) or a Solution) to the same times, and every density of the
list receives its estimate; later calls, on any member, read it.

The richer run is richer in space and in time:

- space: :func:`~fpk_vibro.fem.estimate.richer_options`, as the stationary estimate
  (degree + 1 on the same mesh, h/2 at degree 4; Galerkin);
- time: an error about a quarter as large.  Adaptive BDF2: the local tolerance 8×
  smaller (the global error goes as tol^(2/3): 8^(-2/3) = 1/4; a 4× smaller one
  gave only 2.6× less error, measured) and the largest step halved (where that
  bound, not the tolerance, sets the step).  Fixed steps: each step split in 2 for the
  second-order schemes (BDF2, Crank–Nicolson) and in 4 for the first-order ones
  (implicit Euler, θ > ½, positivity): the richer run also outputs at the 1/m
  points of each interval between output times, so its steps are exactly those
  split.

It is checked against the budget first (refused in one line naming
``fem.error_estimate``).  The estimate at each time is :func:`estimates`, the
formula of ``fem.transient(..., rtol=...)`` (:mod:`fpk_vibro.fem.transient_accuracy`):
the difference to the richer density (:func:`~fpk_vibro.fem.estimate.difference`)
times 2, plus the tail beyond y_max.  Assumption: the richer run is the more
accurate in space and in time.  ``seconds`` is that of the whole shared estimate
(the richer run and every comparison); ``info["error_estimate"]`` and
``info["under_resolved"]`` are set on every density as for a stationary one.
"""
from __future__ import annotations

import time
from typing import Any, Callable, Sequence

import numpy as np

from .estimate import ASSUMES, SAFETY, _combine, difference, richer_options, truncation

__all__ = ["OnDemand", "attach", "estimates", "give", "time_refinement"]


def estimates(coarse: Sequence, rich: Sequence) -> list[dict[str, float]]:
    """The estimate of each density of ``coarse`` from the density of ``rich`` at the
    same time (the numbers only; :func:`give` adds what they rest on)."""
    return [_combine(difference(a, b), truncation(a), a) for a, b in zip(coarse, rich)]


def give(sols: Sequence, ests: Sequence[dict], *, in_time: str, richer: str,
         seconds: float, **info: Any) -> None:
    """Give each density of ``sols`` its estimate (with ``assumes``, ``richer``,
    ``seconds``), record ``info`` and flag it as a stationary estimate does."""
    for sol, est in zip(sols, ests):
        out: dict[str, Any] = dict(est)
        out["assumes"] = ASSUMES.format(safety=SAFETY) + "; in time, " + in_time
        out["richer"] = richer
        out["seconds"] = float(seconds)
        sol._estimate = out
        sol.info.update(info)
        sol._apply_estimate()


def time_refinement(scheme: str, theta: float) -> int:
    """How many richer steps one fixed step becomes: 2 for the second-order schemes
    (BDF2, θ = ½), 4 for the first-order ones (a quarter of the time error both)."""
    return 2 if scheme == "bdf2" or theta == 0.5 else 4


def _split(times: np.ndarray, m: int) -> tuple[np.ndarray, list[int]]:
    """The times with each interval between them (from 0) cut into ``m`` equal parts,
    and the indices of the given times among them."""
    out: list[float] = []
    pick: list[int] = []
    t_prev = 0.0
    for t in times:
        if t > t_prev:
            out += [t_prev + (t - t_prev) * j / m for j in range(1, m)]
        out.append(float(t))
        pick.append(len(out) - 1)
        t_prev = float(t)
    return np.asarray(out), pick


class OnDemand:
    """The estimator of the densities of one FE transient (module docstring); each
    density holds it as its ``estimator``, which ``error_estimate()`` calls."""

    def __init__(self, sols: list, system: Any, initial: Any, times: np.ndarray, opts: Any,
                 progress: bool | None, march: Callable, *, scheme: str, theta: float,
                 dt: float, tol: float | None) -> None:
        self.sols = sols
        self.system, self.initial, self.opts, self.progress = system, initial, opts, progress
        self.times = np.asarray(times, dtype=float)[:len(sols)]
        self.march = march
        self.scheme, self.theta, self.dt, self.tol = scheme, theta, dt, tol
        self.runs = 0           # richer transients run (one at most)

    def plan(self) -> tuple[Any, np.ndarray, list[int], str]:
        """(options of the richer run, its times, the indices of ours, in-time text)."""
        base = self.opts
        if base.discretisation is not None:
            base = getattr(base.discretisation, "options", None)
            if base is None:
                raise ValueError("error_estimate: this transient's discretisation was not "
                                 "built by fem.build or fem.transient.discretise, so its "
                                 "mesh options are unknown; give them to fem.transient")
        space = richer_options(base, self.sols[-1])
        if self.tol is not None:
            tol, dt = self.tol / 8.0, self.dt / 2.0
            opts = space.replace(scheme="bdf2", dt=dt, tol=tol)
            times, pick = self.times, list(range(self.times.size))
            in_time = (f"adaptive BDF2 with local tolerance {self.tol:.2g} and largest step "
                       f"{self.dt:.2g} against {tol:.2g} and {dt:.2g}")
        else:
            m = time_refinement(self.scheme, self.theta)
            opts = space.replace(scheme=self.scheme, theta=self.theta, dt=self.dt / m,
                                 tol=None)
            times, pick = _split(self.times, m)
            name = "BDF2" if self.scheme == "bdf2" else f"the θ-scheme, θ = {self.theta:g}"
            in_time = f"{name} with each fixed step split in {m}"
        return (opts.replace(positivity=False, discretisation=None, rtol=None), times, pick,
                in_time)

    def __call__(self, sol: Any) -> dict[str, Any]:
        if sol._estimate is None:
            self._run()
        return sol._estimate

    def _run(self) -> None:
        from ..budget import enforce
        t0 = time.perf_counter()
        opts, times, pick, in_time = self.plan()
        # the richer run is ~2-4x the DOFs and 1.6-4x the steps: refused in one line
        # where it would not fit
        enforce(opts.estimate(self.system, "transient", times), "fem.error_estimate")
        self.runs += 1
        rich = self.march(self.system, initial=self.initial, times=times,
                          progress=self.progress, mesh=opts.mesh, nx=opts.nx, ny=opts.ny,
                          y_max=opts.y_max, degree=opts.degree, element=opts.element,
                          grading=opts.grading, wall_grading=opts.wall_grading,
                          scheme=opts.scheme, theta=opts.theta, dt=opts.dt, tol=opts.tol)
        if getattr(rich, "partial", False):
            raise KeyboardInterrupt("error_estimate: the richer transient was interrupted")
        ests = estimates(self.sols, [rich[i] for i in pick])
        richer = (f"degree {opts.degree}, {rich[-1].dofs.size} DOFs, "
                  + (f"tol {opts.tol:.2g}" if opts.tol is not None else f"dt {opts.dt:.2g}"))
        give(self.sols, ests, in_time=in_time, richer=richer,
             seconds=time.perf_counter() - t0)


def attach(sols: list, *args: Any, **kw: Any) -> list:
    """Give every density of ``sols`` one shared :class:`OnDemand` (arguments as its)."""
    shared = OnDemand(sols, *args, **kw)
    for s in sols:
        s.estimator = shared
    return sols
