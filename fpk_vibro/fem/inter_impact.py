"""The time between successive impacts from the stationary FE density.

Theory (docs/impacts.md).  At a wall the impact flux J(v) = |v| p(x_w, v) on the
outflow half (its integral the wall's rate ν_w) restarts paths at (x_w, −φ(v)),
φ(v) = v r(v) (a number r: r v).  The time T to the next impact, on any wall, is the
first passage to the walls with the walls *absorbing*, started from that
post-impact distribution with weight J/ν, ν = Σ_w ν_w.  Its mean is 1/ν exactly
(Kac's lemma: the impacts are a stationary point process of rate ν).

Discretisation.  The FE generator of the stationary density is
L = A − Σ_w (P − P_r)ᵀ W P (:mod:`fpk_vibro.fem.impact`): the interior J·∇q, the
outflow −PᵀWP and the re-injection S_w = P_rᵀ W P.  Dropping the re-injection gives the
generator of the walls-absorbing process, L_a = L − Σ_w S_w (the same conservative
weak form; its adjoint imposes τ = 0 on the outflow half of each wall weakly, the
upwind condition of the backward equation there).  The post-impact distribution
enters as the load b = Σ_w S_w p (∫ b q = ∫ J/… q(x_w, −φ(v)) dv: the line measure
tested against the basis, never projected), ν = 1ᵀ b, and with the outflow vector
o_w = Pᵀ w of wall w:

- mean: τ = (−L_aᵀ)⁻¹ 𝟙ᴹ (𝟙ᴹ = M 1, the backward equation L*τ = −1), E[T] = τᵀ b / ν.
  For the null vector p of L, L_a p = −b, so τᵀ b = 𝟙ᴹᵀ p = 1: the discrete
  identity E[T] = 1/ν holds to round-off on the Galerkin density (on a density
  corrected to p ≥ 0, or solved by another scheme, to the size of that change);
- per wall pair: h_j = (−L_aᵀ)⁻¹ o_j gives P(next on j | last on i) = h_jᵀ b_i / ν_i
  (Σ_j h_j = 1: the probabilities sum to one) and k_j = (−L_aᵀ)⁻¹ M h_j the mean
  time on that route, E[T; next on j | i] = k_jᵀ b_i / ν_i;
- density: the survival from every start, M g′ = L_aᵀ g, g(0) = 1 (BDF2 as for first
  passage, :func:`fpk_vibro.fem.passage_parts.survival`), R(t) = gᵀ b / ν and
  f(t) = −R′(t) = gᵀ d, d = −L_a M⁻¹ b / ν (exact for the semi-discrete system: no
  differencing of R).  Beyond the march R and f continue with the decay rate of its
  last stretch.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .generator import assemble, assemble_tensor, mesh_domain
from .impact import coupling_parts, wall_parts_1d

__all__ = ["InterImpact", "inter_impact", "N_STEPS", "HORIZON"]

#: BDF2 steps per 5 mean inter-impact times (a quarter of them ten times shorter
#: first, for the returns of slow rebounds).
N_STEPS = 400
#: The march runs to this many mean times at least (R is continued beyond).
HORIZON = 12.0
_PIVOT = 0.1


@dataclass
class InterImpact:
    """The inter-impact statistics of one stationary FE density (module docstring).

    Attributes
    ----------
    rate : float
        ν = Σ_w ν_w from the operator (the impacts' total rate).
    mean : float
        E[T] = τᵀ b / ν (the Kac identity makes it 1/ν).
    pairs : dict
        ``"left->right"`` etc.: ``probability`` and ``mean_time`` (mean of T given
        that the impact on the first wall is followed by one on the second).
    times, survival, density : ndarray
        R(t) and f(t) on the march's time grid.
    decay : float
        The decay rate of R on the last stretch (continuation beyond ``times``).
    """

    rate: float
    mean: float
    pairs: dict[str, dict[str, float]]
    info: dict[str, Any] = field(default_factory=dict)
    _march_args: tuple | None = None
    _march: tuple | None = None

    def _marched(self) -> tuple:
        """(times, survival, density, decay): the march, made on first use."""
        if self._march is None:
            T, R, F = _march(*self._march_args)
            tail = max(len(T) // 10, 2)
            with np.errstate(divide="ignore", invalid="ignore"):
                decay = float(np.log(R[-tail] / R[-1]) / (T[-1] - T[-tail])) \
                    if R[-1] > 0 else math.inf
            if not (decay > 0 and math.isfinite(decay)):
                decay = 1.0 / self.mean
            self._march, self._march_args = (T, R, F, decay), None
        return self._march

    times = property(lambda self: self._marched()[0])
    survival = property(lambda self: self._marched()[1])
    density = property(lambda self: self._marched()[2])
    decay = property(lambda self: self._marched()[3])

    def pdf(self, t: np.ndarray) -> np.ndarray:
        """f(t): piecewise linear on the grid, exponential beyond it."""
        t = np.asarray(t, dtype=float)
        out = np.interp(t, self.times, self.density)
        beyond = t > self.times[-1]
        return np.where(beyond, self.density[-1] * np.exp(-self.decay * (t - self.times[-1])),
                        out)


def _real_walls(sol, dom) -> list[tuple[str, Any]]:
    """(side, StripEnd) of the ends that are walls of the system (not a truncated
    side's elastic end, nor the elastic cut before a wall beyond the support)."""
    out = []
    for side, end in zip(("left", "right"), dom.walls):
        wall = getattr(sol.system, side)
        if wall is not None and abs(end.x - wall.position) <= 1e-9 * max(1.0, dom.x1 - dom.x0):
            out.append((side, end))
    return out


def _operator(sol, speed_limit: float | None = None):
    """(L, M, p, walls) on the solution's own discretisation: the Galerkin generator
    (tensor or general assembly), the density's coefficient vector and, per wall of
    the system, (side, S_w, o_w)."""
    s, degree = sol.system, sol.degree
    dom = mesh_domain(s, sol.mesh)
    walls = []
    if sol._tensor is not None:
        xs, ys = sol._tensor
        op = assemble_tensor(s, xs, ys, degree, dom)
        xb, yb, P2 = sol._tensor_factors()
        p = P2.ravel()
        xd = op.xbasis.doflocs[0]
        for side, end in _real_walls(sol, dom):
            P, Pr, w = wall_parts_1d(op.ybasis, end, dom.y_max, 2 * degree + 1, speed_limit)
            iw = int(np.argmin(np.abs(xd - end.x)))
            E = sp.csr_matrix(([1.0], ([iw], [iw])), shape=(op.xbasis.N, op.xbasis.N))
            ew = np.zeros(op.xbasis.N)
            ew[iw] = 1.0
            walls.append((side, sp.kron(E, Pr.T @ sp.diags(w) @ P).tocsr(),
                          np.kron(ew, P.T @ w)))
        return op.L, op.M, op.unit, p, walls
    basis = sol.basis
    L, M = assemble(s, basis)
    for side, end in _real_walls(sol, dom):
        P, Pr, w = coupling_parts(basis, end, dom.y_max, 2 * degree + 1, speed_limit)
        walls.append((side, (Pr.T @ sp.diags(w) @ P).tocsr(), P.T @ w))
    return L, M, np.asarray(M.sum(axis=0)).ravel(), sol.dofs, walls


def inter_impact(sol, n_steps: int = N_STEPS) -> InterImpact:
    """The :class:`InterImpact` of a stationary :class:`~fpk_vibro.fem.FEMSolution`
    (module docstring).  Raises ValueError for a system without walls."""
    L, M, unit, p, walls = _operator(sol)
    if not walls:
        raise ValueError("inter_impact: the system has no wall the density reaches: "
                         "there are no impacts")
    S = sum(Sw for _, Sw, _ in walls)
    La = (L - S).tocsc()
    b_w = {side: Sw @ p for side, Sw, _ in walls}
    nu_w = {side: float(np.sum(b)) for side, b in b_w.items()}
    b = sum(b_w.values())
    nu = float(np.sum(b))
    if not nu > 0:
        raise ValueError("inter_impact: the density has no impact flux (rate 0)")
    lu = spla.splu((-La.T).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=_PIVOT)
    tau = lu.solve(unit)
    mean = float(tau @ b) / nu
    pairs: dict[str, dict[str, float]] = {}
    for j, _, o_j in walls:
        h = lu.solve(o_j)
        k = lu.solve(M @ h)
        for i, bi in b_w.items():
            if nu_w[i] <= 0:
                continue
            prob = float(h @ bi) / nu_w[i]
            pairs[f"{i}->{j}"] = {"probability": prob,
                                  "mean_time": float(k @ bi) / nu_w[i] / prob
                                  if prob > 0 else math.nan}
    beta = b / nu
    d = -(La @ spla.splu(M.tocsc()).solve(beta))
    return InterImpact(nu, mean, pairs,
                       {"rate_by_wall": nu_w, "n_steps": n_steps, "ndofs": int(p.size),
                        "tau_max": float(np.max(tau))},
                       _march_args=(La, M, beta, d, mean, n_steps))


def _march(La, M, beta, d, scale, n_steps):
    """(T, R, f) from M g′ = L_aᵀ g, g(0) = 1 by BDF2: n_steps/4 steps of h/10, then
    steps h = 5 scale / n_steps to :data:`HORIZON` scale."""
    Lt = La.T.tocsc()
    h2 = 5.0 * scale / n_steps
    h1, n1 = h2 / 10.0, n_steps // 4
    n2 = max(1, int(math.ceil((HORIZON * scale - n1 * h1) / h2)))
    g_prev, g = None, np.ones(La.shape[0])
    T, R, F = [0.0], [float(g @ beta)], [float(g @ d)]
    for h, n in ((h1, n1), (h2, n2)):
        euler = spla.splu((M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A",
                          diag_pivot_thresh=_PIVOT)
        bdf2 = spla.splu((1.5 * M - h * Lt).tocsc(), permc_spec="MMD_AT_PLUS_A",
                         diag_pivot_thresh=_PIVOT)
        for k in range(n):
            if k == 0:                 # implicit Euler restarts each step size
                g_prev, g = g, euler.solve(M @ g)
            else:
                g_prev, g = g, bdf2.solve(M @ (2.0 * g - 0.5 * g_prev))
            T.append(T[-1] + h)
            R.append(float(g @ beta))
            F.append(float(g @ d))
    return np.array(T), np.clip(np.array(R), 0.0, 1.0), np.array(F)
