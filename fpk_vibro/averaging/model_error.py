"""The model error of an averaged density against a finite-element density of the
same system: the one formula of the stationary estimate
(:func:`fpk_vibro.averaging.validity.model_error`) and of a transient's
(:meth:`fpk_vibro.averaging.EnergyGridSolution.error_estimate`),

    estimate_k = |q_k(averaging) − q_k(FE)| / scale_k + estimate_k(FE),

for k = E[H], E[x²], E[y²], P_impact (scale_k: :func:`fpk_vibro.keys.moment_scale`,
|q_k(FE)|, at least 1e-3 for P_impact), and the L1 distance of the joint densities
plus FE's own L1 estimate.  An FE figure that is infinite (FE unresolved) makes the
sum infinite.

The transient's FE density (:class:`TransientCheck`) is ``fem.transient(system,
initial=..., times=..., **TRANSIENT_LEVEL)`` (Galerkin Q4 on 16 cells across x) from
the same initial condition at every output time of the averaged transient, solved once
for the whole list on the first ``error_estimate()`` of any member, with FE's own
estimate added.  A fixed level, not an rtol: since issue 31 an FE rtol bounds the L1
error of the density too, which a packet that starts as a point mass cannot meet
quickly (rtol 2e-2: L1 estimate 0.12 at Q4 nx 16, the next level ~900 s, refused),
while its moments, all this check compares, are within ~1e-3 there (measured FE
estimates 7e-4 – 9e-4): the estimate is meaningful for model errors of 1 % and above.
It took 2.3 s (paper case, r = 0.98) and 4.3 s (c = 0.3) from the packet
N((0, 0.5), 0.1²) to t = 1, 5, 20; 3e-2 saved little (2.1 s and 0.7 s) and let FE's
own share reach 3 %.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from ..keys import JUDGED, moment_scale

__all__ = ["check_reference", "judged_keys", "against", "unbounded", "l1", "TransientCheck",
           "transient_model_error", "TRANSIENT_LEVEL", "TRANSIENT_ASSUMES"]

#: fem.transient's accuracy goal for the transient's check (module docstring).
TRANSIENT_LEVEL = {"degree": 4, "nx": 16}
TRANSIENT_ASSUMES = (
    f"the difference to the finite-element transient of the same system from the same "
    f"initial condition at this time (fem.transient Q4, nx 16) plus FE's "
    f"own estimate there; assumes the FE answer is resolved; FE's share is up to "
    f"~1e-3, so the figure is meaningful for model errors of 1 % and above")
#: Added to the assumption when the initial condition has a zero std.
WIDENED = ("; FE widens the initial condition's zero std to one cell, so until the "
           "packet has spread (a few periods) the check is against that wider packet")


def check_reference(sol: Any, reference: Any, where: str) -> Any:
    """``reference`` if it is a finite-element density of ``sol``'s very system (and,
    for a transient's density, of its time); else one :class:`InputError` naming
    ``reference`` (a string, a Monte Carlo answer or the FE answer of another system
    would give a meaningless figure)."""
    from .._checks import InputError, invalid
    if getattr(reference, "kind", None) != "fem" or not callable(
            getattr(reference, "error_estimate", None)):
        raise invalid(where, "reference", "a finite-element solution (fem.stationary, or "
                      "a member of fem.transient) of the same system", reference)
    if reference.system != sol.system:
        mine, theirs = sol.system.to_dict(), reference.system.to_dict()
        keys = [k for k in mine if mine[k] != theirs.get(k)]
        scalars = [k for k in keys if not isinstance(mine[k], dict)]   # walls follow them
        diff = ", ".join(f"{k} = {theirs.get(k)!r} (not {mine[k]!r})"
                         for k in (scalars or keys))
        raise InputError(f"{where}: reference must solve the same system; it has {diff}",
                         where=where, name="reference")
    t_ref, t = reference.snapshot_time(), getattr(sol, "time", None)
    if t_ref != (None if t is None else float(t)):
        what = "a stationary density" if t_ref is None else f"at t = {t_ref}"
        mine = "stationary" if t is None else f"at t = {float(t)}"
        raise InputError(f"{where}: reference is {what}, this density is {mine}; give the "
                         "FE density of the same time", where=where, name="reference")
    return reference


def judged_keys(sol: Any) -> list[str]:
    """The judged moments ``sol`` has (P_impact only with walls)."""
    m = sol.moments()
    return [k for k in JUDGED if k in m]


def against(sol: Any, ref: Any, fe_est: dict[str, Any]) -> dict[str, float]:
    """The per-key model error of ``sol`` against the FE density ``ref`` whose own
    estimate is ``fe_est`` (module docstring): the judged moments and ``L1``."""
    m, r = sol.moments(), ref.moments()
    out = {k: float(abs(m[k] - r[k]) / moment_scale(k, r[k]) + float(fe_est[k]))
           for k in judged_keys(sol)}
    out["L1"] = l1(sol, ref) + float(fe_est["L1"])
    return out


def unbounded(sol: Any) -> dict[str, float]:
    """Every figure infinite: no FE density to compare with."""
    return {k: math.inf for k in judged_keys(sol) + ["L1"]}


def l1(sol: Any, ref: Any) -> float:
    """∫|p_averaging − p_FE| over FE's strip (a Gauss rule on FE's tensor grid)."""
    from ..quadrature import gauss_grid
    xs, ys = ref._tensor
    xq, wx = gauss_grid(np.asarray(xs, float), ref.degree + 2)
    yq, wy = gauss_grid(np.asarray(ys, float), ref.degree + 2)
    total = 0.0
    step = max(1, 400_000 // yq.size)
    for i in range(0, xq.size, step):
        X, Y = np.meshgrid(xq[i:i + step], yq, indexing="ij")
        diff = np.abs(sol.pdf_joint(X, Y) - ref.pdf_joint(X, Y))
        total += float(wx[i:i + step] @ diff @ wy)
    return total


class TransientCheck:
    """The FE transient of an averaged transient's system from its initial condition at
    all its output times: solved on the first :meth:`at` and kept, so the members of
    one list (which share this object) cost one FE transient between them.

    Parameters
    ----------
    system : VibroImpactSystem
    initial : InitialCondition
        The averaged transient's, parsed (:func:`fpk_vibro.initial.parse_initial`).
    times : array_like
        The averaged transient's output times (any order, repeats allowed).
    level : dict
        fem.transient's numerics (default :data:`TRANSIENT_LEVEL`).
    """

    def __init__(self, system: Any, initial: Any, times: Any,
                 level: dict | None = None) -> None:
        self.system, self.level = system, dict(level or TRANSIENT_LEVEL)
        #: The Gaussian spec FE takes, or None for a sampler (which is not kept: the
        #: densities stay picklable whatever the sampler is).
        self.spec = ({"mean": initial.mean, "std": initial.std} if initial.is_gaussian
                     else None)
        self.times = np.unique(np.asarray(times, dtype=float))
        self.seconds: float | None = None
        self._by_time: dict[float, Any] | None = None
        self._reason = ""

    @property
    def assumes(self) -> str:
        """What the estimate rests on (with the widening of a zero std)."""
        zero = self.spec is not None and min(self.spec["std"]) == 0.0
        return TRANSIENT_ASSUMES + (WIDENED if zero else "")

    def at(self, t: float) -> tuple[Any, str]:
        """The FE density at time ``t`` and a description of it, or ``(None, reason)``
        when there is none (a sampler initial condition, FE refused, or FE stopped
        before ``t``)."""
        if self._by_time is None:
            self._solve()
        ref = self._by_time.get(float(t))
        if ref is None:
            return None, self._reason or (f"none: the FE transient stopped before "
                                          f"t = {t:g}")
        return ref, (f"fem.transient Q{ref.degree}, nx {self.level['nx']}: "
                     f"{ref.dofs.size} DOFs ({self.seconds:.1f} s for all "
                     f"{self.times.size} times)")

    def _solve(self) -> None:
        from .._checks import InputError
        from ..references import reference
        self._by_time = {}
        if self.spec is None:
            self._reason = ("none: the initial condition is a sampler initial(n, rng), "
                            "which fem.transient cannot take (it needs a density: a "
                            "Gaussian spec or p0(x, y)); no FE check")
            return
        t0 = time.perf_counter()
        try:
            sols = reference("fem-transient", self.system, initial=dict(self.spec),
                             times=self.times, **self.level)
        except (InputError, ValueError) as exc:
            self._reason = f"none: fem.transient refused ({exc})"
            return
        finally:
            self.seconds = time.perf_counter() - t0
        self._by_time = {float(s.time): s for s in sols}


def transient_model_error(sol: Any, reference: Any = None) -> dict[str, Any]:
    """The model-error estimate of one time of an averaged transient (an
    :class:`~fpk_vibro.averaging.EnergyGridSolution` with ``time``): :func:`against`
    the FE transient at that time, from ``reference`` (an FE density at that time with
    an estimate) or else from the list's shared :class:`TransientCheck`.

    Raises
    ------
    NotImplementedError
        Neither: a density not made by ``averaging.transient`` (e.g. read from a file)
        does not know its initial condition.
    ValueError
        A ``reference`` at another time.
    """
    from .._checks import InputError
    t0 = time.perf_counter()
    check = getattr(sol, "_check", None)
    if reference is not None:
        check_reference(sol, reference, f"{type(sol).__name__}.error_estimate")
        ref, what = reference, f"the given FE density ({type(reference).__name__})"
        assumes = check.assumes if check is not None else TRANSIENT_ASSUMES
    elif check is None:
        raise NotImplementedError(
            f"{type(sol).__name__}: no error estimate: its initial condition is unknown "
            "(only the densities returned by averaging.transient carry it)")
    else:
        ref, what = check.at(sol.time)
        assumes = check.assumes
    out: dict[str, Any]
    if ref is None:
        out = unbounded(sol)
        out.update(assumes=assumes, reference=what)
    else:
        try:
            fe_est = ref.error_estimate()
        except (InputError, ValueError) as exc:
            out = unbounded(sol)
            out.update(assumes=assumes, reference=f"none: the FE density has no estimate "
                       f"({exc})")
        else:
            out = against(sol, ref, fe_est)
            out.update(assumes=assumes, reference=f"{what} (its estimate "
                       f"{max(fe_est[k] for k in judged_keys(sol)):.1g})")
    out["seconds"] = time.perf_counter() - t0
    return out
