"""Integrals of an FE density p_h: moments, resolution diagnostics, energy levels.

:func:`element_quadrature` takes the even moments of p_h and of p₊ = max(p_h, 0) in
one pass of the element quadrature; :func:`diagnose` turns them into the resolution
flags of :meth:`~fpk_vibro.fem.FEMSolution.resolution`.

P_impact = P(H > G(Δ)) is the integral of p_h over the part of the mesh above the
level.  Cells wholly on one side (by bounds of H on the cell's bounding box) take the
element rule; a cell the curve may cross is integrated over x outside and y inside,
where the curve is explicit, |y| = sqrt(2 (E − G(x))): the x-range is split at the
vertices, where the curve meets an edge (roots of a quartic, all cells at once) and
where G(x) = E, and a change of variable absorbs the square-root behaviour at a wall.
No loop runs over elements.  ``sol`` is a :class:`~fpk_vibro.fem.FEMSolution`.
"""
from __future__ import annotations

import numpy as np
import skfem

from ..model import VibroImpactSystem

__all__ = ["element_quadrature", "diagnose", "split", "cut_integrals", "eval_in_cells",
           "real_roots", "potential_range"]

#: Gauss points per x-piece and per y-interval of a cell cut by the level.
CUT_NX, CUT_NY = 10, 6


def real_roots(c: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Real roots of many polynomials at once (companion-matrix eigenvalues).

    Parameters
    ----------
    c : ndarray, shape (n, d + 1)
        Coefficients, highest degree first; ``c[:, 0]`` nonzero.
    tol : float
        Roots with ``|Im| ≤ tol (1 + |z|)`` count as real (a double root, e.g. a
        tangency, splits into a nearly real pair; a spurious real root is harmless
        to the caller, which only uses roots as break points).

    Returns
    -------
    ndarray, shape (n, d)
        Real parts of the real roots, NaN elsewhere.
    """
    n, d = c.shape[0], c.shape[1] - 1
    if d < 1 or n == 0:
        return np.full((n, max(d, 0)), np.nan)
    comp = np.zeros((n, d, d))
    comp[:, 0, :] = -c[:, 1:] / c[:, :1]
    comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
    z = np.linalg.eigvals(comp)
    return np.where(np.abs(z.imag) <= tol * (1.0 + np.abs(z)), z.real, np.nan)


def potential_range(system: VibroImpactSystem, lo: np.ndarray, hi: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) of G over each interval [lo, hi]: the ends and the critical
    points 0, ±√(−a/b) that fall inside."""
    cand = [lo, hi, np.clip(0.0, lo, hi)]
    if system.b != 0 and -system.a / system.b > 0:
        xc = np.sqrt(-system.a / system.b)
        cand += [np.clip(xc, lo, hi), np.clip(-xc, lo, hi)]
    G = system.potential(np.stack(cand))
    return G.min(axis=0), G.max(axis=0)



def split(sol, level: float, element_mass: np.ndarray) -> np.ndarray:
    """[[above, below] of p_h, [above, below] of p₊]; ``element_mass`` (2, nel):
    ∫ p_h and ∫ p₊ per element."""
    s, m = sol.system, sol.mesh
    V = m.p[:, m.t]
    xlo, xhi = V[0].min(axis=0), V[0].max(axis=0)
    ylo, yhi = V[1].min(axis=0), V[1].max(axis=0)
    Gmin, Gmax = potential_range(s, xlo, xhi)
    y2min = 0.5 * np.where((ylo <= 0) & (yhi >= 0), 0.0, np.minimum(ylo ** 2, yhi ** 2))
    y2max = 0.5 * np.maximum(ylo ** 2, yhi ** 2)
    above = Gmin + y2min >= level
    below = Gmax + y2max <= level
    whole = np.stack([element_mass[:, above].sum(axis=1),
                      element_mass[:, below].sum(axis=1)], axis=1)
    return whole + cut_integrals(sol, np.flatnonzero(~above & ~below), level)

def eval_in_cells(sol, cells: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """p_h at points ``x[i, :]``, ``y[i, :]`` known to lie in cell ``cells[i]``."""
    b = sol.basis
    target = np.stack([x, y])
    if isinstance(b.mapping, skfem.MappingAffine):
        ref = b.mapping.invF(target, tind=cells)
    else:
        # Newton for the bilinear map (skfem's invF clips to the reference
        # square, so a point a rounding error outside its cell never converges)
        ref = np.full(target.shape, 0.5)
        # skfem caches every Jacobian it computes, keyed by the points: without
        # dropping them here the cache grew by ~11 MB a chunk (3 GiB at nx = 1e5)
        cache = getattr(b.mapping, "_cache", {})
        kept = set(cache)
        try:
            for _ in range(50):
                step = np.einsum("ijkl,jkl->ikl", b.mapping.invDF(ref, tind=cells),
                                 target - b.mapping.F(ref, tind=cells))
                ref += step
                # quadratic convergence: a step below 1e-9 leaves ~1e-18; a tighter
                # test never passes on thin cells (round-off ~1e-16 × aspect ratio)
                if np.max(np.abs(step), initial=0.0) < 1e-9:
                    break
            else:
                raise RuntimeError("inverse bilinear map did not converge")
        finally:
            for key in set(getattr(b.mapping, "_cache", {})) - kept:
                b.mapping._cache.pop(key, None)
    out = np.zeros(x.shape)
    for k in range(b.Nbfun):         # over local basis functions, not elements
        # values on the reference cell (lbasis): gbasis would also build the inverse
        # Jacobians, ~1 GiB per 30 000 thin cells (nx = 30000, ny = 2)
        out += (np.asarray(b.elem.lbasis(ref, k)[0])
                * sol.dofs[b.element_dofs[k, cells]][:, None])
    return out

def cut_pieces(system: VibroImpactSystem, level: float, breaks: np.ndarray,
               lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The x-pieces of cells [lo, hi] between their breaks (``breaks``, one row per
    cell, NaN where none) and the roots of G(x) = level (on y = 0): the cell of each
    piece and its ends ``xa``, ``xb``."""
    s = system
    gcoef = ([0.25 * s.b, 0.0, 0.5 * s.a, 0.0, -level] if s.b != 0
             else [0.5 * s.a, 0.0, -level] if s.a != 0 else [1.0, 0.0, 1.0])
    groots = real_roots(np.array([gcoef]))[0]          # G(x) = level: on y = 0
    br = np.concatenate([breaks, np.broadcast_to(groots, (lo.size, groots.size))], axis=1)
    br = np.where(np.isfinite(br), br, lo[:, None])
    br = np.sort(np.clip(br, lo[:, None], hi[:, None]), axis=1)
    keep = br[:, 1:] - br[:, :-1] > 1e-13 * (hi - lo)[:, None]
    return np.nonzero(keep)[0], br[:, :-1][keep], br[:, 1:][keep]


def cut_nodes(xa: np.ndarray, xb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gauss nodes and weights in x on the pieces [xa, xb], graded toward both ends
    (x = 1.5 t − 0.5 t³: the √ behaviour of the energy curve at a turning point)."""
    t, wt = np.polynomial.legendre.leggauss(CUT_NX)
    mid, half = 0.5 * (xa + xb), 0.5 * (xb - xa)
    return (mid[:, None] + half[:, None] * (1.5 * t - 0.5 * t ** 3),
            half[:, None] * (1.5 * wt * (1.0 - t * t)))


def cut_integrals(sol, cells: np.ndarray, level: float, chunk: int = 1_000) -> np.ndarray:
    """[[above, below] of p_h, [above, below] of p₊] summed over ``cells``
    (module docstring: x outside with break points, y inside)."""
    total = np.zeros((2, 2))
    if cells.size == 0:
        return total
    s = sol.system
    V = sol.mesh.p[:, sol.mesh.t[:, cells]]          # (2, nv, nc)
    x0, y0 = V[0], V[1]
    x1, y1 = np.roll(x0, -1, axis=0), np.roll(y0, -1, axis=0)   # edge j: v_j → v_j+1
    xlo, xhi = x0.min(axis=0), x0.max(axis=0)
    vert = np.abs(x1 - x0) <= 1e-14 * (xhi - xlo)
    slope = np.where(vert, 0.0, (y1 - y0) / np.where(vert, 1.0, x1 - x0))
    icpt = y0 - slope * x0
    # the level set meets the edge line y = slope x + icpt where
    # b/4 x⁴ + (a + slope²)/2 x² + slope icpt x + icpt²/2 − level = 0
    sl, ic = slope.ravel(), icpt.ravel()
    if s.b != 0:
        coef = np.stack([np.full_like(sl, 0.25 * s.b), np.zeros_like(sl),
                         0.5 * (s.a + sl * sl), sl * ic, 0.5 * ic * ic - level], axis=1)
    else:
        lead = 0.5 * (s.a + sl * sl)
        ok = lead != 0
        coef = np.stack([np.where(ok, lead, 1.0), np.where(ok, sl * ic, 0.0),
                         np.where(ok, 0.5 * ic * ic - level, 1.0)], axis=1)
    roots = real_roots(coef).reshape(vert.shape + (-1,))
    roots = np.where(vert[..., None], np.nan, roots).transpose(1, 0, 2).reshape(x0.shape[1], -1)
    ci, xa, xb = cut_pieces(s, level, np.concatenate([x0.T, roots], axis=1), xlo, xhi)
    u, wu = np.polynomial.legendre.leggauss(CUT_NY)
    for k in range(0, ci.size, chunk):             # bounded memory, not per element
        c = ci[k:k + chunk]
        xq, wx = cut_nodes(xa[k:k + chunk], xb[k:k + chunk])
        # the vertical chord [ylo, yhi] of the (convex) cell at each xq
        ex0, ey0, ex1, ey1 = (a[:, c, None] for a in (x0, y0, x1, y1))
        ev = vert[:, c, None]
        lam = (xq[None] - ex0) / np.where(ev, 1.0, ex1 - ex0)
        ye = ey0 + lam * (ey1 - ey0)
        hit = ~ev & (lam >= -1e-12) & (lam <= 1.0 + 1e-12)
        ylo = np.where(hit, ye, np.inf).min(axis=0)
        yhi = np.where(hit, ye, -np.inf).max(axis=0)
        Y = np.sqrt(np.maximum(2.0 * (level - s.potential(xq)), 0.0))
        lo = np.stack([ylo, np.maximum(ylo, Y), np.maximum(ylo, -Y)])    # above, above, below
        hi = np.stack([np.minimum(yhi, -Y), yhi, np.minimum(yhi, Y)])
        lo = np.minimum(lo, yhi)                 # empty pieces: a point in the cell
        L = np.maximum(hi - lo, 0.0)
        yq = lo[..., None] + 0.5 * L[..., None] * (1.0 + u)              # (3, n, NX, NY)
        w = 0.5 * L[..., None] * wu * wx[None, :, :, None]
        xs = np.broadcast_to(xq[None, :, :, None], yq.shape)
        p = eval_in_cells(sol, cells[c], xs.transpose(1, 0, 2, 3).reshape(c.size, -1),
                                yq.transpose(1, 0, 2, 3).reshape(c.size, -1))
        w = w.transpose(1, 0, 2, 3).reshape(c.size, 3, -1)
        for row, f in enumerate((p, np.maximum(p, 0.0))):
            fw = f.reshape(c.size, 3, -1) * w
            total[row] += [fw[:, :2].sum(), fw[:, 2].sum()]
    return total


def element_quadrature(sol) -> dict:
    """One pass of the element quadrature over p_h: even moments of p_h and of
    p₊, the negative mass, and ∫ p_h, ∫ p₊ per element."""
    b = sol.basis
    v = np.asarray(b.interpolate(sol.dofs))
    x, y = np.asarray(b.global_coordinates())
    wp = np.maximum(v, 0.0) * b.dx
    wn = np.minimum(v, 0.0) * b.dx
    weights = {"E_x2": x * x, "E_x4": x ** 4, "E_y2": y * y, "E_y4": y ** 4}
    mp, mn = float(wp.sum()), float(wn.sum())
    return {"positive": {k: float(np.sum(wp * w)) / mp for k, w in weights.items()},
            "signed": {k: float(np.sum((wp + wn) * w)) / (mp + mn)
                       for k, w in weights.items()},
            "negative_mass": abs(mn) / (mp + mn),
            "element_mass": np.stack([(wp + wn).sum(axis=1), wp.sum(axis=1)])}


def diagnose(q: dict, tol: float) -> dict:
    """The resolution flags of the quadrature ``q`` (see ``FEMSolution.resolution``)."""
    neg = float(q["negative_mass"])
    shift = max(abs(q["positive"][k] - q["signed"][k]) / q["positive"][k]
                if q["positive"][k] > 0 else 0.0 for k in q["positive"])
    reasons = []
    if neg > tol:
        reasons.append(f"negative mass {neg:.3g} of the density > {tol:g}")
    if shift > tol:
        reasons.append(f"even moments of max(p_h, 0) and p_h differ by {shift:.3g} "
                       f"(relative) > {tol:g}")
    diag = {"negative_mass": neg, "moment_shift": float(shift),
            "under_resolved": bool(reasons), "under_resolved_reason": "; ".join(reasons),
            "moments_of": "p_h" if min(q["signed"].values()) >= 0 else "max(p_h, 0)"}
    if reasons:
        diag["under_resolved_reason"] += (" (the mesh does not resolve the density: "
                                          "refine nx/ny, or use positivity=True)")
    return diag
