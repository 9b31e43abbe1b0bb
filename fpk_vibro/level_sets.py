"""Quadrature over the energy level sets {H(x, y) = H} of the strip, for any potential.

The coarea formula (docs/theory.md, §Energy and orbits, "Level sets") writes an
integral over a level set of H = y²/2 + G(x) as one in x over the part of the strip
where G(x) < H, both signs of y:

    ∮_{H(x,y)=H} f / |∇H| dl = ∫_{x_L}^{x_R} [f(x, v) + f(x, −v)] / v · 1{G(x) < H} dx,
    v = sqrt(2H − 2G(x)).

Unlike :mod:`fpk_vibro.orbits` this needs no single well: the set {G < H} may be one
interval, two (a double well below its hump), or cut by the walls, and G may have a
hilltop inside it (a double well above its hump, a softening spring beyond its
hilltops, a = 0 > b).  It is built in ξ = |x| (G is even): the strip's part with
x ≥ 0 and its part with x ≤ 0, reflected, are the two ranges of ξ, and each range is
cut at the turning radii ρ (G(ρ) = H, the positive roots q = ρ² of
b q² + 2a q − 4H = 0) and at the critical radius ξ_c = sqrt(−a/b) of G.  On each
piece G is monotone, so 1/v is largest at the piece's high-G end e, which is

- a turning point (G(e) = H): v vanishes like sqrt(d), d = |ξ − e|; with d = s²
  the integrand dξ/v = 2 ds / sqrt(2Q), Q = (G(e) − G(ξ))/d, is smooth;
- a hilltop of G (G'(e) = 0) or a wall: v is bounded away from 0 (integrand smooth).

Near a hilltop's energy 1/v is nearly singular at e all the same (p(H) has a
logarithmic peak there: the level set passes through a saddle of H, |∇H| = 0):
above it v² ≈ 2(H − G_top) + |G''| d², below it Q ≈ Q₀ + Q₁ s² with Q₀ ∝ |G'(e)| → 0.
Both are resolved by a composite Gauss–Legendre rule in s graded geometrically
towards s = 0 (:data:`RULE`: 12 equal panels of 8 points, the first split 6 times by
1/4; 144 nodes a piece).  G(e) − G(ξ) is evaluated in the factored form
(e − ξ)(e + ξ)(a/2 + b(e² + ξ²)/4) (at ξ_c: −(b/4)(e − ξ)²(e + ξ)²), with e − ξ = ±d
exact, so there is no cancellation near e.

Accuracy (f ≡ 1, the period T(H) = ∮ dl/|∇H| = 2∫ dx/v, against adaptive
quadrature; tests/test_fem_energy_density.py): ~1e-10 relative away from a hilltop's
energy, ≤ 2e-8 within 1e-9 of it (1e-7 for the quartic hilltop of a = 0 > b).

Examples
--------
>>> import numpy as np
>>> from fpk_vibro import VibroImpactSystem
>>> s = VibroImpactSystem(a=-1.0, b=1.0, c=0.1, D1=0.05, delta=1.5)
>>> T = level_set_nodes(s, [-0.2, 0.2]).period     # two wells, then one orbit
>>> bool(np.allclose(T, [9.261350608298, 7.820915238923]))
True
"""
from __future__ import annotations

import math

import numpy as np

from .model import VibroImpactSystem

__all__ = ["LevelSetNodes", "level_set_nodes", "RULE"]


def _unit_rule(panels: int = 12, levels: int = 6, ratio: float = 0.25,
               points: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes and weights on [0, 1]: ``panels`` equal panels,
    the first one split geometrically (by ``ratio``, ``levels`` times) towards 0."""
    first = 1.0 / panels
    edges = np.concatenate([[0.0], first * ratio ** np.arange(levels, 0, -1),
                            np.arange(1, panels + 1) / panels])
    t, w = np.polynomial.legendre.leggauss(points)
    lo, hi = edges[:-1, None], edges[1:, None]
    return (0.5 * (lo + hi) + 0.5 * (hi - lo) * t).ravel(), (0.5 * (hi - lo) * w).ravel()


#: The unit rule in s ∈ [0, 1] used on every piece (module docstring): 144 nodes.
RULE = _unit_rule()

_WALL, _TURN, _CRIT = 0, 1, 2


class LevelSetNodes:
    """Nodes of the level sets of several energies, flat: Σ over the nodes of energy
    ``k`` (``index == k``) of ``w · g(x, v)`` ≈ ∫ g(x, v) dx / v over {G(x) < H_k} on
    the strip, v = sqrt(2H_k − 2G(x)) (one velocity branch: add the two signs of y)."""

    __slots__ = ("index", "x", "v", "w", "size")

    def __init__(self, index: np.ndarray, x: np.ndarray, v: np.ndarray, w: np.ndarray,
                 size: int) -> None:
        self.index, self.x, self.v, self.w, self.size = index, x, v, w, size

    def integrate(self, values: np.ndarray) -> np.ndarray:
        """Σ w g per energy for ``values`` g at the nodes (shape ``(size,)``)."""
        return np.bincount(self.index, weights=self.w * values, minlength=self.size)

    @property
    def period(self) -> np.ndarray:
        """T(H) = 2 ∫ dx/v over {G < H} (both branches; every orbit of the level set)."""
        return 2.0 * np.bincount(self.index, weights=self.w, minlength=self.size)


def _turning_radii(a: float, b: float, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The positive radii ρ with G(ρ) = H (NaN where fewer): ρ² the roots of
    b q² + 2a q − 4H = 0, in the cancellation-free form."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if b == 0:
            q1 = 2.0 * H / a if a != 0 else np.full_like(H, np.nan)
            q2 = np.full_like(H, np.nan)
        else:
            disc = a * a + 4.0 * b * H
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            t = -(a + np.copysign(sq, a))
            q1 = t / b
            q2 = np.where(t != 0, -4.0 * H / t, 0.0)
        return tuple(np.sqrt(np.where(q > 0, q, np.nan)) for q in (q1, q2))


def _ranges(bounds: tuple[float, float]) -> list[tuple[float, float, float]]:
    """(ξ_lo, ξ_hi, sign): the strip's parts with x ≥ 0 and x ≤ 0, in ξ = |x|."""
    lo, hi = bounds
    out = []
    if hi > 0:
        out.append((max(lo, 0.0), hi, 1.0))
    if lo < 0:
        out.append((max(-hi, 0.0), -lo, -1.0))
    return out


def level_set_nodes(system: VibroImpactSystem, H, bounds: tuple[float, float] | None = None
                    ) -> LevelSetNodes:
    """Quadrature nodes on the level sets {H(x, y) = H} of the strip (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
        Gives G (any a, b).
    H : array_like
        Energies (flattened; ``index`` refers to the flat order).
    bounds : (float, float), optional
        The strip (x_L, x_R), finite; default the system's walls.

    Returns
    -------
    LevelSetNodes
        ``w`` > 0 at points x of {G < H} ∩ strip with v = sqrt(2H − 2G(x)); no nodes
        for an energy at or below min G on the strip.
    """
    a, b = float(system.a), float(system.b)
    bounds = system.x_bounds if bounds is None else bounds
    if not all(math.isfinite(v) for v in bounds):
        raise ValueError(f"level_set_nodes needs a bounded strip; got {bounds}")
    H = np.asarray(H, dtype=float).ravel()
    r1, r2 = _turning_radii(a, b, H)
    xc = math.sqrt(-a / b) if b != 0 and -a / b > 0 else math.nan
    parts = []
    for lo, hi, sign in _ranges(bounds):
        parts += _range_nodes(a, b, H, lo, hi, sign, r1, r2, xc)
    if not parts:
        empty = np.zeros(0)
        return LevelSetNodes(np.zeros(0, dtype=np.intp), empty, empty, empty, H.size)
    return LevelSetNodes(*(np.concatenate(p) for p in zip(*parts)), H.size)


def _range_nodes(a, b, H, lo, hi, sign, r1, r2, xc) -> list[tuple[np.ndarray, ...]]:
    """(index, x, v, w) of each piece of one range ξ ∈ (lo, hi) (module docstring)."""
    n = H.size
    pts = np.column_stack([np.full(n, lo), np.full(n, hi), r1, r2, np.full(n, xc)])
    code = np.tile(np.array([_WALL, _WALL, _TURN, _TURN, _CRIT]), (n, 1))
    tol = 1e-12 * max(abs(lo), abs(hi))
    for r in (r1, r2):               # a turning point on a wall: the wall is one
        code[np.abs(r - hi) <= tol, 1] = _TURN
        code[np.abs(r - lo) <= tol, 0] = _TURN
    inner = pts[:, 2:]
    keep = (inner > lo + tol) & (inner < hi - tol)
    pts[:, 2:] = np.where(keep, inner, hi)
    code[:, 2:] = np.where(keep, code[:, 2:], _WALL)
    order = np.argsort(pts, axis=1, kind="stable")
    pts, code = np.take_along_axis(pts, order, 1), np.take_along_axis(code, order, 1)
    t, w = RULE
    out = []
    for k in range(pts.shape[1] - 1):
        u, v = pts[:, k], pts[:, k + 1]
        mid = 0.5 * (u + v)
        idx = np.flatnonzero((v > u) & (H > mid * mid * (0.5 * a + 0.25 * b * mid * mid)))
        if idx.size == 0:
            continue
        u, v, mid, Hk = u[idx], v[idx], mid[idx], H[idx]
        up = mid * (a + b * mid * mid) >= 0          # G increases: the high end is v
        e = np.where(up, v, u)[:, None]
        ce = np.where(up, code[idx, k + 1], code[idx, k])[:, None]
        sig = np.where(up, 1.0, -1.0)[:, None]
        turn = ce == _TURN
        L = (v - u)[:, None]
        S = np.where(turn, np.sqrt(L), L)
        s, ds = S * t, S * w
        d = np.where(turn, s * s, s)
        em = sig * d                                  # e − ξ
        ep = 2.0 * e - em                             # e + ξ
        beta = np.where(ce == _CRIT, -0.25 * b * em * ep,
                        0.5 * a + 0.25 * b * (e * e + (e - em) ** 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            Q = np.maximum(sig * ep * beta, 1e-300)   # (G(e) − G(ξ))/d at a turning point
            gap = np.maximum(Hk[:, None] - e * e * (0.5 * a + 0.25 * b * e * e)
                             + em * ep * beta, 1e-300)
            vel = np.where(turn, s * np.sqrt(2.0 * Q), np.sqrt(2.0 * gap))
            wt = np.where(turn, 2.0 * ds / np.sqrt(2.0 * Q), ds / vel)
        out.append((np.repeat(idx, t.size), (sign * (e - em)).ravel(), vel.ravel(),
                    wt.ravel()))
    return out
