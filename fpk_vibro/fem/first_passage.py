"""Mean first-passage time and reliability from the discrete generator.

The safe set S = {H < H_c} on the strip is |y| < Y(x) = sqrt(2 (H_c − G(x))) between
the walls the energy H_c reaches (a side it does not bring to a wall ends just inside
the turning point G(A) = H_c).  It is meshed by quadrilaterals fitted to it: nodes
(x_i, η_j Y(x_i)) for a uniform grid in x and η ∈ [−1, 1], so that the absorbing
boundary H = H_c is a mesh boundary (second-order geometry) and y = 0 a mesh line.
On it the same generator L and mass matrix M as for densities are assembled
(:func:`fpk_vibro.fem.generator.assemble`, impact coupling included), and the DOFs on
the absorbing boundary are fixed to zero.  Restricted to the free DOFs f:

- the killed density obeys M_ff dp/dt = L_ff p, and the survival probability is
  R(t) = unit_fᵀ p(t);
- hence ∫₀^∞ R dt = unit_fᵀ (−L_ff)⁻¹ M_ff p0 = τᵀ M_ff p0 with
  τ = (−L_ffᵀ)⁻¹ unit_f: τ is the nodal vector of the mean first-passage time
  τ(x, y) (the backward Kolmogorov equation L* τ = −1, τ = 0 on H = H_c, in the
  adjoint of the very matrix the densities use);
- likewise R(t | p0) = g(t)ᵀ M_ff p0 with M g' = L_ffᵀ g, g(0) = 1: one backward
  march gives the reliability from every start at once (from a point: g(t, x0, y0)).
"""
from __future__ import annotations

import math
import time
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem

from .. import scales
from .._checks import check_int
from ..first_passage import FirstPassage, check_energy, parse_start
from ..model import VibroImpactSystem, check_system
from .generator import assemble, element_for, quadrature_order
from .solution import FEMSolution

__all__ = ["first_passage"]


#: A side without a reached wall ends where Y(x) is this fraction of Y(0)-ish: just
#: inside the turning point (the cells there stay non-degenerate).
END_FRACTION = 1e-3


def safe_set_mesh(system: VibroImpactSystem, H_c: float, nx: int, ny: int
                  ) -> tuple[skfem.MeshQuad1, VibroImpactSystem, np.ndarray]:
    """(mesh of {H < H_c} fitted to its boundary, the system with only the walls H_c
    reaches, mask of the boundary facets that absorb)."""
    X = float(scales.reach(system, H_c))
    ends, walls = [], {}
    for side, sign in (("left", -1), ("right", +1)):
        w = getattr(system, side)
        if w is not None and float(system.potential(w.position)) < H_c:
            ends.append(w.position)
            walls[side] = w
        else:              # the turning point, pulled in so that Y(x_end) > 0
            A = sign * X
            ends.append(A - sign * END_FRACTION * X)
            walls[side] = None
    if not ends[0] < ends[1]:
        raise ValueError(f"fem.first_passage: the safe set H < {H_c:g} is empty on the strip")
    box = (system if (walls["left"], walls["right"]) == (system.left, system.right) else
           VibroImpactSystem(a=system.a, b=system.b, c=system.c, D1=system.D1, D2=system.D2,
                             left=walls["left"], right=walls["right"])
           if any(walls.values()) else
           VibroImpactSystem(a=system.a, b=system.b, c=system.c, D1=system.D1, D2=system.D2,
                             barriers="none"))
    xs = np.linspace(ends[0], ends[1], nx + 1)
    eta = np.linspace(-1.0, 1.0, ny + 1)
    mesh = skfem.MeshQuad1.init_tensor(xs, eta)
    Y = np.sqrt(2.0 * np.maximum(H_c - system.potential(mesh.p[0]), 0.0))
    mesh = skfem.MeshQuad1(np.vstack([mesh.p[0], mesh.p[1] * Y]), mesh.t)
    mid = mesh.p[:, mesh.facets].mean(axis=1)
    on_wall = np.zeros(mid.shape[1], dtype=bool)
    for w in (walls["left"], walls["right"]):
        if w is not None:
            on_wall |= np.abs(mid[0] - w.position) <= 1e-12 * max(1.0, abs(w.position))
    absorbing = np.isin(np.arange(mesh.facets.shape[1]), mesh.boundary_facets()) & ~on_wall
    return mesh, box, absorbing


def first_passage(system: VibroImpactSystem, *, energy: float, start: Any = (0.0, 0.0),
                  times: Sequence[float] | None = None, nx: int = 24,
                  ny: int | None = None, degree: int = 2, n_steps: int = 200
                  ) -> FirstPassage:
    """Mean first-passage time τ(x, y) and reliability R(t) out of {H < energy}.

    Parameters
    ----------
    system : VibroImpactSystem
    energy : float
        The critical energy H_c (above min G on the strip).
    start : (x0, y0), dict or "stationary"
        Where paths start (:func:`fpk_vibro.first_passage.parse_start`); default the
        equilibrium at rest.
    times : sequence of float, optional
        Times at which R(t) must be known; R is computed on a grid up to the largest
        of them and 5 τ.
    nx, ny, degree : int
        Cells across x and y (ny default 2 nx, even) and the Lagrange degree.
    n_steps : int
        BDF2 steps of the reliability march.

    Returns
    -------
    FirstPassage
        ``mean_time(x0, y0)`` evaluates τ_h anywhere; ``reliability(t)`` for the start.

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem, fem
    >>> fp = fem.first_passage(VibroImpactSystem.paper(r=0.92), energy=0.5)
    >>> round(fp.mean_time(), -1) > 0
    True
    """
    where = "fem.first_passage"
    check_system(where, system)
    H_c = check_energy(where, system, energy)
    kind, value = parse_start(where, system, start, H_c)
    nx = check_int("nx", nx, 2, 4096, where=where)
    ny = check_int("ny", 2 * nx if ny is None else ny, 2, 8192, where=where)
    if ny % 2:
        raise ValueError(f"{where}: ny must be even (y = 0 is a mesh line); got {ny}")
    degree = check_int("degree", degree, 1, 2, where=where)
    n_steps = check_int("n_steps", n_steps, 10, 10 ** 6, where=where)
    t0 = time.perf_counter()
    mesh, box, absorbing = safe_set_mesh(system, H_c, nx, ny)
    basis = skfem.CellBasis(mesh, element_for(mesh, degree), intorder=quadrature_order(degree))
    L, M = assemble(box, basis, only_walls=True)
    unit = np.asarray(M.sum(axis=0)).ravel()
    fixed = basis.get_dofs(np.flatnonzero(absorbing)).all()
    free = np.setdiff1d(np.arange(basis.N), fixed)
    L, M = L[free][:, free], M[free][:, free]
    tau = np.zeros(basis.N)
    tau[free] = spla.splu((-L.T).tocsc(), permc_spec="MMD_AT_PLUS_A").solve(unit[free])
    tau_h = FEMSolution(system, mesh, degree, tau, mass=1.0)
    # the start as a functional of nodal fields: v(x0, y0), or ∫ v p0 / ∫ p0
    if kind == "point":
        probe = np.asarray(basis.probes(np.array([[value[0]], [value[1]]])).todense()).ravel()
        weights = probe[free]
    else:
        p0 = _start_density(system, kind, value, basis.doflocs, H_c)[free]
        weights = (M @ p0) / (unit[free] @ p0)

    def at_start(v_free: np.ndarray) -> float:
        return float(weights @ v_free)

    mean = at_start(tau[free])
    t_end = max(5.0 * mean, max(times) if times is not None and len(times) else 0.0)
    T, R = _survival(L, M, t_end, n_steps, at_start)
    info = {"nx": nx, "ny": ny, "degree": degree, "ndofs": int(basis.N),
            "free_dofs": int(free.size), "seconds": time.perf_counter() - t0,
            "x_range": (float(mesh.p[0].min()), float(mesh.p[0].max()))}
    return FirstPassage("fem", system, H_c, (kind, value), mean, 0.0, T, R, None, info,
                        _mean_at=lambda x, y: _tau_at(tau_h, mesh, system, H_c, x, y))


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
        from . import stationary
        p0 = np.maximum(stationary(system).pdf_joint(x, y), 0.0)
    p0 = np.where(system.energy(x, y) < H_c, p0, 0.0)
    if not p0.sum() > 0:
        raise ValueError("fem.first_passage: the start density has no mass inside the "
                         f"safe set H < {H_c:g}")
    return p0


def _survival(L: sp.csr_matrix, M: sp.csr_matrix, t_end: float, n_steps: int, at_start
              ) -> tuple[np.ndarray, np.ndarray]:
    """R(t_k) on [0, t_end] from M g' = Lᵀ g, g(0) = 1 (BDF2; the first tenth of the
    quarter of the steps ten times smaller, for the layer at the absorbing boundary)."""
    Lt = L.T.tocsc()
    h1, n1 = t_end / (10 * n_steps), n_steps // 4
    h2, n2 = t_end / n_steps, n_steps - int(math.ceil(n1 / 10))
    g_prev, g = None, np.ones(L.shape[0])
    T, R = [0.0], [at_start(g)]
    for h, n in ((h1, n1), (h2, n2)):
        euler = spla.splu((M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A")
        bdf2 = spla.splu((1.5 * M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A")
        for k in range(n):
            if k == 0:                 # implicit Euler restarts each step size
                g_prev, g = g, euler.solve(M @ g)
            else:
                g_prev, g = g, bdf2.solve(M @ (2.0 * g - 0.5 * g_prev))
            T.append(T[-1] + h)
            R.append(at_start(g))
    return np.array(T), np.clip(np.array(R), 0.0, 1.0)
