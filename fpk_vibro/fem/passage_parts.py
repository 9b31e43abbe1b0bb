"""The mean first-passage time τ and the reliability R on one part of the safe set.

On a part's mesh (:mod:`fpk_vibro.fem.safe_set`) the same generator L and mass
matrix M as for densities are assembled (:func:`fpk_vibro.fem.generator.assemble`,
impact coupling included), and the DOFs on the absorbing boundary are fixed to zero.
The equations (τ = (−L_ffᵀ)⁻¹ unit_f, the backward march of R) and the rounding
estimate of τ: :mod:`fpk_vibro.fem.first_passage`.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem

from .._checks import InputError
from .generator import assemble, element_for, quadrature_order
from .safe_set import safe_set_mesh
from .solution import FEMSolution

__all__ = ["RESOLVABLE", "NEGATIVE", "solve_part", "unresolvable", "TauField", "survival"]


#: Largest accepted relative error of τ from rounding alone (module docstring).
RESOLVABLE = 1e-3
#: A τ_h below −NEGATIVE τ_max is a breakdown.  Milder undershoots are the
#: discretisation's (Q2 next to a turning point on coarse meshes: −3 % at nx = 8, one
#: wall at 0.6 and H_c = 0.25) and are measured by the error estimate.
NEGATIVE = 0.1
#: SuperLU's threshold for keeping a diagonal pivot (its default 1 is partial
#: pivoting).  On the mesh graded toward walls with r < 1 partial pivoting left the
#: diagonal often and filled the factors 1.5 times (softening b = −0.2, r = 0.5,
#: nx = 32: 853 000 against 571 000 ungraded); at 0.1, 550 000, τ the same to 1e-13
#: and the call 20 % faster.  The backward error is checked on every solve.
PIVOT = 0.1
#: Machine epsilon, with the growth of the sparse LU (measured: the estimate is
#: 20-60 times the spread of τ between two orderings of the factorisation).
_EPS = 1.1e-16


def mean_time_solve(L, M, unit: np.ndarray) -> tuple[np.ndarray, float, float, float]:
    """(τ, its estimated relative rounding error, max τ, the solve's normwise backward
    error) of −Lᵀ τ = unit on the free DOFs
    (``L``, ``M`` restricted to them); the error is infinite where τ is not finite and
    at least 1 where the solve broke down (a negative τ, a backward error > 1e-8)."""
    lu = spla.splu((-L.T).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=PIVOT)
    n = unit.size
    with np.errstate(all="ignore"):
        tau = lu.solve(unit)
        # rounding: the slowest mode v of −L_ff (one inverse iteration from 1) is
        # where the mean time lives; a perturbation eps |L| of the matrix moves its
        # rate by about eps 1ᵀ|L||v| / unitᵀ|v|, i.e. τ by that times τ.
        v = np.abs(lu.solve(M @ np.ones(n), trans="T"))
        tau_max = float(np.max(tau))
        error = _EPS * float(np.ones(n) @ (abs(L) @ v)) / float(unit @ v) * abs(tau_max)
        # normwise backward error of the solve (a breakdown, not conditioning)
        residual = float(np.linalg.norm(unit + L.T @ tau, np.inf)
                         / (spla.norm(L, np.inf) * np.linalg.norm(tau, np.inf)
                            + np.linalg.norm(unit, np.inf)))
    if not (np.all(np.isfinite(tau)) and math.isfinite(error)):
        error = math.inf
    elif np.min(tau) < -NEGATIVE * tau_max or residual > 1e-8:
        error = max(error, 1.0)       # a negative mean time: a solver breakdown
    return tau, error, tau_max, residual


def solve_part(system, part, H_c, nx, ny, degree, kind, value) -> dict[str, Any]:
    """τ on one part of the safe set, the start's functional, and the estimated
    relative rounding error of τ."""
    mesh, box, absorbing = safe_set_mesh(system, part, H_c, nx, ny, degree)
    basis = skfem.CellBasis(mesh, element_for(mesh, degree), intorder=quadrature_order(degree))
    L, M = assemble(box, basis, only_walls=True)
    unit = np.asarray(M.sum(axis=0)).ravel()
    fixed = basis.get_dofs(np.flatnonzero(absorbing)).all()
    free = np.setdiff1d(np.arange(basis.N), fixed)
    L, M = L[free][:, free], M[free][:, free]
    tau = np.zeros(basis.N)
    tau[free], error, tau_max, residual = mean_time_solve(L, M, unit[free])
    if kind == "point":
        probe = np.asarray(basis.probes(np.array([[value[0]], [value[1]]])).todense()).ravel()
        weights, weight = probe[free], 1.0
    else:
        p0 = _start_density(system, kind, value, basis.doflocs, H_c)[free]
        weight = float(unit[free] @ p0)
        weights = (M @ p0) / weight if weight > 0 else np.zeros(free.size)

    def at_start(v_free: np.ndarray, weights=weights) -> float:
        return float(weights @ v_free)

    return {"part": part, "mesh": mesh, "L": L, "M": M, "ndofs": int(basis.N),
            "free": int(free.size), "tau_h": FEMSolution(system, mesh, degree, tau, mass=1.0),
            "mean": at_start(tau[free]), "tau_max": tau_max, "error": error,
            "residual": residual, "weight": max(weight, 0.0), "at_start": at_start}


def unresolvable(where, system, H_c, kind, value, part) -> InputError:
    """The one-line refusal of a mean time that double precision cannot resolve."""
    err, tau_max = part["error"], part["tau_max"]
    limit = RESOLVABLE / err * tau_max if math.isfinite(err) and err > 0 and tau_max > 0 \
        else math.nan
    est = ""
    try:
        from ..averaging.first_passage import log10_mean_time
        H0 = float(system.energy(*value)) if kind == "point" else None
        est = f"; averaging estimates τ ~ 10^{log10_mean_time(system, H_c, H0):.0f}"
    except Exception:  # averaging does not apply (e.g. two wells): no estimate
        pass
    bound = f"τ is beyond the ~{limit:.1g} this mesh resolves" if limit == limit else \
        "τ is beyond what this mesh resolves"
    return InputError(f"{where}: energy = {H_c:g} gives a mean first-passage time that "
                      f"double precision cannot resolve: rounding alone changes τ by an "
                      f"estimated {err:.2g} × τ ({bound}{est}); choose a lower energy",
                      where=where, name="energy")


class TauField:
    """τ_h(x, y) on the solved parts (picklable: no closure)."""

    def __init__(self, system, H_c, parts) -> None:
        self.system, self.H_c, self.parts = system, H_c, parts

    def __call__(self, x, y) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        out = np.zeros(x.shape)
        inside = self.system.energy(x, y) < self.H_c
        covered = np.zeros(x.shape, dtype=bool)
        for tau_h, mesh, (lo, hi) in self.parts:
            sel = (x >= lo) & (x <= hi)
            covered |= sel
            out[sel] = _tau_at(tau_h, mesh, self.system, self.H_c, x[sel], y[sel])
        if np.any(inside & ~covered):
            spans = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for _, _, (lo, hi) in self.parts)
            raise ValueError(f"fem.first_passage: mean_time(x0, y0) is known on the part(s) "
                             f"of the safe set holding the start (x in {spans}); this point "
                             "lies in another one")
        return out


def _tau_at(tau_h: FEMSolution, mesh, system, H_c: float, x, y) -> np.ndarray:
    """τ_h(x, y): 0 outside the safe set; a point between the curved boundary and the
    mesh's straight edge (where τ is O(h²)) is read on the edge."""
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    inside = (system.energy(x, y) < H_c) & (x >= mesh.p[0].min()) & (x <= mesh.p[0].max())
    top = mesh.p[:, mesh.p[1] >= 0]
    order = np.lexsort((-top[1], top[0]))           # per x, the highest node first
    xs, first = np.unique(top[0][order], return_index=True)
    edge = np.interp(x, xs, top[1][order][first]) * (1.0 - 1e-9)
    yc = np.clip(y, -edge, edge)
    out = np.zeros(x.shape)
    if np.any(inside):
        out[inside] = tau_h.pdf_joint(x[inside], yc[inside])
    return out


def _start_density(system, kind, value, points, H_c) -> np.ndarray:
    """Nodal values of the start density (zero outside the safe set)."""
    x, y = points[0], points[1]
    if kind == "gaussian":
        (mx, my), (sx, sy) = value["mean"], value["std"]
        hx, hy = np.ptp(x) / 64, np.ptp(y) / 64
        p0 = (np.exp(-0.5 * ((x - mx) / max(sx, hx)) ** 2)
              * np.exp(-0.5 * ((y - my) / max(sy, hy)) ** 2))
    else:
        from .stationary import stationary
        p0 = np.maximum(stationary(system).pdf_joint(x, y), 0.0)
    return np.where(system.energy(x, y) < H_c, p0, 0.0)


def survival(L: sp.csr_matrix, M: sp.csr_matrix, scale: float, t_end: float,
              n_steps: int, at_start) -> tuple[np.ndarray, np.ndarray]:
    """R(t_k) on [0, t_end] from M g' = Lᵀ g, g(0) = 1 (BDF2).  The step is set by the
    mean time ``scale``: 5 scale / n_steps (n_steps/4 steps ten times smaller first,
    for the layer at the absorbing boundary), widened if t_end needs more than
    8 n_steps steps."""
    Lt = L.T.tocsc()
    h2 = max(5.0 * scale / n_steps, t_end / (8 * n_steps))
    h1, n1 = h2 / 10.0, n_steps // 4
    n2 = max(1, int(math.ceil((t_end - n1 * h1) / h2 - 1e-9)))
    g_prev, g = None, np.ones(L.shape[0])
    T, R = [0.0], [at_start(g)]
    for h, n in ((h1, n1), (h2, n2)):
        euler = spla.splu((M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A",
                          diag_pivot_thresh=PIVOT)
        bdf2 = spla.splu((1.5 * M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A",
                         diag_pivot_thresh=PIVOT)
        for k in range(n):
            if k == 0:                 # implicit Euler restarts each step size
                g_prev, g = g, euler.solve(M @ g)
            else:
                g_prev, g = g, bdf2.solve(M @ (2.0 * g - 0.5 * g_prev))
            T.append(T[-1] + h)
            R.append(at_start(g))
    return np.array(T), np.clip(np.array(R), 0.0, 1.0)
