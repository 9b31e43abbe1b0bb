"""One FE level of :func:`fpk_vibro.fem.spectrum.spectrum`, its reduced model, and the
error estimate from two coarser levels.

A :class:`Level` assembles (L, M) on the structured tensor mesh exactly as
:func:`fem.stationary <fpk_vibro.fem.stationary>` does (Kronecker assembly, the same
strip and wall grading), solves for p_s and gives u0 = M⁻¹ b and g for q = x or y
(:mod:`fpk_vibro.fem.spectrum`: the 1-D mass matrices weighted by q make both, and
the Kronecker structure makes M⁻¹ two 1-D solves).  :func:`solve_level` reduces it
(:mod:`fpk_vibro.fem.spectrum_krylov`) with the shifts of :func:`shifts`:
:data:`SHIFTS` over [0, 3 ω̄], ω̄ = sqrt(Var y / Var x) (Rice's mean frequency of x,
from p_s), each σ = ω_j (:data:`DAMPING` + i), plus one per octave up to the largest
ω asked for beyond that: three, as on the paper system six shifts saved rounds but
cost more in LUs than the rounds did.

:func:`estimate` (per ω, summed):

- discretisation: the spectra of two coarser levels (:func:`coarser`: nx and ny
  times 3/4, twice; same degree and strip) give the differences d₁ (coarsest to
  middle) and d₂ (middle to the level returned).  With the measured contraction
  ρ = max d₂ / max d₁ (within :data:`RHO_RANGE`) the error of the level returned is
  SAFETY · ρ/(1 − ρ) · d₂: the tail of the geometric series the levels follow
  (Richardson with a measured rate).  d₂ is floored by S times its largest
  relative size, as d₂ crosses zero where the error does not.  Levels more than
  50 % apart (:data:`~fpk_vibro.fem.estimate.UNCONVERGED`), growing differences
  (ρ ≥ 1) or levels that cannot be made coarser give an infinite estimate (no
  bound);
- Krylov truncation: the change of S since the model one round smaller;
- an unstable part of the reduced model (:class:`~fpk_vibro.fem.spectrum_krylov.ReducedModel`),
  where there is one: its |H|/π;
- the truncated strip (mass beyond it < TAIL_MASS): S times
  SAFETY · TAIL_MASS (1 + Q²/Var q), Q the largest |q − m| on the strip.

``"correlation"`` sums the same parts for R over the lags (relative to R(0)), and
the linear interpolation between lags, (h ω)²/8 (``ReducedModel.lag_span``);
``"variance"`` those of Var q.

Measured effectivity: docs/measurements.md, §FE spectra.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import scipy.sparse.linalg as spla
import skfem

from ..model import VibroImpactSystem
from . import forms
from .estimate import SAFETY, UNCONVERGED
from .generator import assemble_tensor
from .mesh import TAIL_MASS, structured_mesh
from .solve import solve_stationary
from .spectrum_krylov import LAG_STEP, reduce

__all__ = ["Level", "shifts", "solve_level", "lags", "coarser", "estimate", "SHIFTS",
           "DAMPING", "COARSER", "RHO_RANGE", "MAX_LAGS", "ASSUMES"]

#: Shifts spread over [0, 3 ω̄], and their real part relative to their frequency.
SHIFTS = 3
DAMPING = 0.3
#: Most shifts added, one per octave, for requested ω beyond 3 ω̄.
MAX_OCTAVES = 12
#: The coarser levels of the estimate: nx, ny times COARSER and COARSER².
COARSER = 0.75
#: The contraction per level is taken from the measured one within these bounds:
#: the estimate's factor SAFETY ρ/(1 − ρ) lies in [0.5, 6].  The lower bound keeps a
#: coarsest level that was still pre-asymptotic from making the contraction look
#: fast (paper system, r = 1, Q4 at nx = 9, 12, 16, 21: errors 3.8e-4, 2.3e-5, 5.5e-6,
#: 8e-7, so ρ measured 0.05 where the next step gives 0.24; with 0.1 as the bound
#: the estimate was 0.84 of the error).
RHO_RANGE = (0.2, 0.75)
#: Most lags of R(τ).
MAX_LAGS = 16385
ASSUMES = ("the levels (nx, ny times 3/4, twice) converge geometrically at the measured "
           "rate (Richardson), times {safety:g}; plus the change of the reduced model over "
           "its last round, its unstable part if any, and the truncated strip's mass")


class Level:
    """One FE level: mesh, (L, M) by tensor assembly, p_s, and the centred q."""

    def __init__(self, system: VibroImpactSystem, dom, degree: int, nx: int, ny: int,
                 grading: float) -> None:
        t0 = time.perf_counter()
        self.degree, self.nx, self.ny, self.grading = degree, nx, ny, grading
        _, xs, ys = structured_mesh(dom, nx, ny, wall_grading=grading)
        op = assemble_tensor(system, xs, ys, degree, dom)
        self.L, self.M, self.unit = op.L.tocsc(), op.M.tocsc(), op.unit
        Mx, My = op.mass_factors
        self.shape = (op.xbasis.N, op.ybasis.N)
        ranks = tuple(np.argsort(np.argsort(b.doflocs[0])) for b in (op.xbasis, op.ybasis))
        self.p, _ = solve_stationary(self.L, self.unit, grid=ranks)
        ones = (np.ones(self.shape[0]), np.ones(self.shape[1]))
        # 1-D mass matrices weighted by 1, q, q² (x-factors for x, y-factors for y)
        self.factors = {
            "x": (Mx, [skfem.asm(forms.weighted_mass_1d, op.xbasis, coef=c)
                       for c in ((0.0, 1.0), (0.0, 0.0, 1.0))], My, 0),
            "y": (My, [skfem.asm(forms.weighted_mass_1d, op.ybasis, coef=c)
                       for c in ((0.0, 1.0), (0.0, 0.0, 1.0))], Mx, 1)}
        self.ones = ones
        self.edges = {"x": (dom.x0, dom.x1), "y": (-dom.y_max, dom.y_max)}
        self.seconds = time.perf_counter() - t0

    @property
    def ndofs(self) -> int:
        return int(self.p.size)

    def _row(self, q: str, k: int) -> np.ndarray:
        """w with w·p = ∫ q^k p (k = 0, 1, 2)."""
        M1, weighted, Mo, axis = self.factors[q]
        a = (M1 if k == 0 else weighted[k - 1]) @ self.ones[axis]
        b = Mo @ self.ones[1 - axis]
        return np.kron(a, b) if axis == 0 else np.kron(b, a)

    def moments(self, q: str) -> tuple[float, float]:
        """(E[q], Var q) of p_s."""
        m = float(self._row(q, 1) @ self.p)
        return m, float(self._row(q, 2) @ self.p) - m * m

    def centred(self, q: str) -> tuple[float, np.ndarray, np.ndarray]:
        """(m, u0, g) of the module docstring."""
        M1, weighted, _, axis = self.factors[q]
        m = float(self._row(q, 1) @ self.p)
        P = self.p.reshape(self.shape)
        lu = spla.splu(M1.tocsc())
        U = lu.solve(weighted[0] @ P) if axis == 0 else lu.solve(weighted[0] @ P.T).T
        u0 = U.ravel() - m * self.p
        u0 -= (self.unit @ u0) * self.p
        return m, u0, self._row(q, 1) - m * self.unit


def shifts(level: Level, omega: np.ndarray) -> tuple[list[complex], np.ndarray]:
    """(shifts, check grid) of the module docstring; the check grid covers [0, 3 ω̄]
    and, geometrically, the requested band beyond it."""
    _, vx = level.moments("x")
    _, vy = level.moments("y")
    top = 3.0 * math.sqrt(max(vy, 1e-300) / max(vx, 1e-300))
    freqs = list(top * (np.arange(SHIFTS) + 0.5) / SHIFTS)
    while freqs[-1] < omega[-1] and len(freqs) < SHIFTS + MAX_OCTAVES:
        freqs.append(2.0 * freqs[-1])
    check = np.linspace(0.0, top, 129)
    if omega[-1] > top:
        check = np.concatenate([check, np.geomspace(top, float(omega[-1]), 129)[1:]])
    return [f * (DAMPING + 1j) for f in freqs], check


def solve_level(level: Level, q: str, omega, shifts, check, tol: float) -> dict[str, Any]:
    """The reduced model of ``level`` for ``q`` and S on ``omega``."""
    m, u0, g = level.centred(q)
    model, previous, info = reduce(level.L, level.M, u0, g, level.p, level.unit, shifts,
                                   omega, check, tol=tol)
    return {"level": level, "mean": m, "model": model, "previous": previous, "info": info,
            "S": model.density(omega)}


def lags(model) -> np.ndarray:
    """Lags from 0 to about ten decay times (``ReducedModel.lag_span``), uniform, or,
    where that would pass MAX_LAGS (light damping, a slow mode such as hopping between
    wells), uniform over the first 3/4 of MAX_LAGS and geometric on to the end."""
    tmax, step = model.lag_span()
    n = int(math.ceil(tmax / step)) + 1
    if n <= MAX_LAGS:
        return np.linspace(0.0, tmax, max(65, n))
    head = np.arange(3 * MAX_LAGS // 4) * step
    return np.concatenate([head, np.geomspace(head[-1], tmax, MAX_LAGS // 4 + 1)[1:]])


def coarser(degree: int, nx: int, ny: int) -> list[tuple[int, int, int]]:
    """The estimate's two coarser levels: nx, ny times COARSER, twice, each at least
    one cell (two in y) fewer than the level above (at least 2 cells: then the same
    level again, which the estimate refuses to read)."""
    out, (mx, my) = [], (nx, ny)
    for _ in range(2):
        mx = max(2, min(mx - 1, int(math.floor(mx * COARSER + 0.5))))
        my = max(2, min(my - 2, 2 * int(math.floor(my * COARSER / 2 + 0.5))))
        out.append((degree, mx, my))
    return out


def estimate(fine: dict, coarse: list[dict], lags: np.ndarray, q: str) -> dict[str, Any]:
    """The estimate of the module docstring for ``fine`` from its two coarser levels."""
    S, R0 = fine["S"], fine["model"].variance
    lev = fine["level"]
    Q = max(abs(e - fine["mean"]) for e in lev.edges[q])
    trunc = SAFETY * TAIL_MASS * (1.0 + Q * Q / max(R0, 1e-300))
    R = fine["model"].correlation(lags)
    prev = fine["previous"]
    krylov_S = np.abs(S - prev.density(fine["omega"])) if prev is not None else np.zeros_like(S)
    krylov_R = float(np.max(np.abs(R - prev.correlation(lags)))) if prev is not None else 0.0
    c1, c2 = coarse
    d2 = np.abs(S - c1["S"])
    d1 = np.abs(c1["S"] - c2["S"])
    top = float(np.max(np.abs(S)))
    grids = [(d["level"].nx, d["level"].ny) for d in (fine, c1, c2)]
    distinct = all(a[0] > b[0] and a[1] > b[1] for a, b in zip(grids, grids[1:]))
    rho = float(np.max(d2) / np.max(d1)) if distinct and np.max(d1) > 0 else math.inf
    # differences at the noise of the reduced models (1e-9 at least) say only that the
    # levels agree: the widest factor then, on that noise
    noise = 10.0 * max(float(np.max(krylov_S)), 1e-9 * top)
    if distinct and max(np.max(d1), np.max(d2)) <= noise:
        rho = RHO_RANGE[1]
    if not (rho < 1.0 and max(np.max(d1), np.max(d2)) <= UNCONVERGED * top):
        factor = math.inf          # (no bound: pre-asymptotic, or too few cells)
    else:
        r = min(max(rho, RHO_RANGE[0]), RHO_RANGE[1])
        factor = SAFETY * r / (1.0 - r)
    # (d2 crosses zero where the levels' errors do not: S times its relative size
    # keeps the estimate from vanishing there)
    shape = np.maximum(d2, float(np.max(d2)) * np.abs(S) / top) if top > 0 else d2
    disc = factor * shape if math.isfinite(factor) else np.full_like(S, math.inf)
    model = fine["model"]
    unstable = model.dropped_transfer(fine["omega"])
    dens = disc + krylov_S + trunc * np.abs(S) + unstable
    v2, v1 = fine["model"].variance, c1["model"].variance
    R1 = c1["model"].correlation(lags)

    def scaled(d: float) -> float:
        return factor * d if math.isfinite(factor) else math.inf

    return {"density": dens, "relative": float(np.max(dens) / top) if top > 0 else math.inf,
            "variance": scaled(abs(v2 - v1) / abs(v2)) + trunc,
            "correlation": (scaled(float(np.max(np.abs(R - R1)))) + krylov_R) / abs(R0)
            + trunc + model.dropped + LAG_STEP ** 2 / 8.0,
            "discretisation": float(np.max(disc) / top) if top > 0 else math.inf,
            "krylov": float(np.max(krylov_S) / top) if top > 0 else 0.0,
            "truncation": trunc, "rate": rho, "unstable": model.dropped,
            "levels": "; ".join(f"degree {d['level'].degree}, nx {d['level'].nx}, ny "
                                f"{d['level'].ny}" for d in (fine, c1, c2)),
            "assumes": ASSUMES.format(safety=SAFETY)}
