"""`FEMSolution`: the stationary finite-element density as a :class:`fpk_vibro.Solution`.

How the derived quantities are computed from the FE function p_h(x, y):

- ``pdf_joint``: p_h evaluated by ``Basis.probes`` (zero outside the strip).
- ``pdf_x``, ``pdf_y``: on a tensor-product quadrilateral mesh exactly,
  p(x) = Σ_i ψ_i(x) Σ_j P_ij ∫χ_j dy (and likewise in y); on other meshes by a
  composite Gauss rule across the strip split at the mesh's node coordinates.
- ``pdf_energy`` (coarea formula): since ∂H/∂y = y,

      p(H) = ∫ Σ_± p(x, ±√(2H − 2G(x))) / √(2H − 2G(x)) dx   over {G(x) < H} ∩ strip,

  and with x = A sin θ (A the amplitude, DESIGN §2) the integrand is smooth:
  dx / √(2H − 2G) = dθ / √(a + b A² (1 + sin²θ)/2); θ runs over the part of
  [−π/2, π/2] inside the strip; Gauss–Legendre in θ.  Needs a monotone G on each
  side (a > 0); otherwise NotImplementedError.
- ``moments``: of the non-negative part p₊ = max(p_h, 0) (see :meth:`FEMSolution.moments`
  for why), by the element quadrature (order 2k + 3: exact for the polynomial
  weights x⁴, y⁴ times Q_k / P_k wherever p_h ≥ 0 on the cell).
  ``P_impact = ∫_{H > G(Δ)} p₊ / ∫ p₊`` over the mesh itself — no energy grid, so
  no scale of Δ or of the noise can be missed.  Cells are sorted by bounds of H on
  their bounding box: wholly above or below G(Δ) take the element rule; a cell the
  level set may cut is integrated over x outside, y inside, where the level set is
  explicit, |y| = Y(x) = √(2(G(Δ) − G(x))).  The x-range is split where the curve
  crosses a cell edge (real roots of the quartic G(x) + ℓ(x)²/2 = G(Δ), ℓ the edge
  line), at the vertices and where G(x) = G(Δ), so each piece is smooth; the
  √-behaviour of Y at G(x) = G(Δ) (the curve's vertical tangent on y = 0) is
  absorbed by the map x = m + h(3t − t³)/2 (dx ∝ 1 − t²); Gauss–Legendre in t and,
  on each y-interval, in y.  Measured: 1e-13 of the exact area/integral for
  polynomial densities (tests/test_fem_moments.py).  Any a, b (double wells too).
- Resolution diagnostics (``info["negative_mass"]``, ``info["moment_shift"]``,
  ``info["under_resolved"]``, ``info["under_resolved_reason"]``): see
  :meth:`FEMSolution.resolution`.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import skfem
from skfem import Functional

from ..model import VibroImpactSystem
from ..solution import Rule, Solution, Stored

__all__ = ["FEMSolution"]

_NTHETA = 96
#: Gauss points per x-piece and per y-interval of a cell cut by H = G(Δ).
_CUT_NX, _CUT_NY = 10, 6
#: Resolution tolerance (see :meth:`FEMSolution.resolution`).
RESOLUTION_TOL = 1e-3


def _real_roots(c: np.ndarray, tol: float = 1e-6) -> np.ndarray:
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


def _potential_range(system: VibroImpactSystem, lo: np.ndarray, hi: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) of G over each interval [lo, hi]: the ends and the critical
    points 0, ±√(−a/b) that fall inside."""
    cand = [lo, hi, np.clip(0.0, lo, hi)]
    if system.b != 0 and -system.a / system.b > 0:
        xc = np.sqrt(-system.a / system.b)
        cand += [np.clip(xc, lo, hi), np.clip(-xc, lo, hi)]
    G = system.potential(np.stack(cand))
    return G.min(axis=0), G.max(axis=0)


def _rows(P) -> tuple[np.ndarray, np.ndarray]:
    """Column indices and values of a probe matrix with equally many entries per row."""
    P = P.tocsr()
    n = P.shape[0]
    w = P.indptr[1] - P.indptr[0] if n else 0
    if n and not np.all(np.diff(P.indptr) == w):      # merged duplicates: pad
        coo = P.tocoo()
        cnt = np.diff(P.indptr)
        w = int(cnt.max())
        slot = np.arange(P.nnz) - np.repeat(P.indptr[:-1], cnt)
        cols = np.zeros((n, w), dtype=np.int64)
        vals = np.zeros((n, w))
        cols[coo.row, slot] = P.indices
        vals[coo.row, slot] = P.data
        return cols, vals
    return P.indices.reshape(n, w), P.data.reshape(n, w)


class FEMSolution(Solution):
    """Stationary FE density on a mesh of the strip (DESIGN §3).

    Attributes
    ----------
    mesh : skfem.Mesh
    basis : skfem.CellBasis
    dofs : ndarray
        Nodal values of p_h (basis DOF order), normalised to ∫ p_h = 1.
    mass : float
        ∫ p_h (1 to round-off).
    min_density : float
        Smallest nodal value (for Q1/P1 the minimum of p_h).
    residual : float
        Relative residual (backward error) of the normalised linear system.
    info : dict
        Solver, timings, DOF counts, options; the resolution diagnostics of
        :meth:`resolution` (``under_resolved``, ...) are added on first access.
    """

    kind = "fem"

    def __init__(self, system: VibroImpactSystem, mesh: skfem.Mesh, degree: int,
                 dofs: np.ndarray, *, residual: float = float("nan"),
                 info: dict | None = None, tensor: tuple[np.ndarray, np.ndarray] | None = None,
                 mass: float | None = None):
        self.system = system
        self.mesh = mesh
        self.degree = int(degree)
        self.dofs = np.asarray(dofs, dtype=float)
        self.residual = float(residual)
        self.info = dict(info or {})
        self._tensor = tensor
        self._mass = None if mass is None else float(mass)
        self.min_density = float(self.dofs.min())
        self._x0, self._x1 = float(mesh.p[0].min()), float(mesh.p[0].max())
        self.y_max = float(mesh.p[1].max())
        self._tensor_cache = None
        self._basis = None

    @property
    def basis(self) -> skfem.CellBasis:
        """The Lagrange basis of p_h (built on first use; quadrature 2k + 3)."""
        if self._basis is None:
            from .generator import element_for, quadrature_order
            self._basis = skfem.CellBasis(self.mesh, element_for(self.mesh, self.degree),
                                          intorder=quadrature_order(self.degree))
        return self._basis

    @property
    def mass(self) -> float:
        """∫ p_h over the strip (1 to round-off after normalisation)."""
        if self._mass is None:
            self._mass = float(skfem.asm(Functional(lambda w: w.f), self.basis,
                                         f=self.basis.interpolate(self.dofs)))
        return self._mass

    # -- evaluation helpers --------------------------------------------------------
    @property
    def max_density(self) -> float:
        return float(self.dofs.max())

    def _eval(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        shape = x.shape
        x, y = x.ravel(), y.ravel()
        out = np.zeros(x.size)
        inside = (x >= self._x0) & (x <= self._x1) & (np.abs(y) <= self.y_max)
        idx = np.flatnonzero(inside)
        if self._tensor is not None:
            # p = Σ_ij P_ij ψ_i(x) χ_j(y): 1-D probes (linear-time cell search)
            xb, yb, P = self._tensor_factors()
            for k in range(0, idx.size, 500_000):
                part = idx[k:k + 500_000]
                ix, vx = _rows(xb.probes(x[part][None, :]))
                iy, vy = _rows(yb.probes(y[part][None, :]))
                out[part] = np.einsum("na,nb,nab->n", vx, vy,
                                      P[ix[:, :, None], iy[:, None, :]])
        else:
            # skfem's 2-D element finder costs O(batch²) memory: small batches
            for k in range(0, idx.size, 400):
                part = idx[k:k + 400]
                out[part] = self.basis.probes(np.vstack([x[part], y[part]])) @ self.dofs
        return out.reshape(shape)

    def _tensor_factors(self):
        """(ψ-basis, χ-basis, P as an nx×ny array) on a tensor quad mesh."""
        if self._tensor_cache is None:
            from .generator import assemble_tensor_bases, tensor_index
            xb, yb = assemble_tensor_bases(self._tensor[0], self._tensor[1], self.degree)
            k = tensor_index(xb, yb, self.basis)
            P = np.zeros(xb.N * yb.N)
            P[k] = self.dofs
            self._tensor_cache = (xb, yb, P.reshape(xb.N, yb.N))
        return self._tensor_cache

    @staticmethod
    def _line_integral(b1: skfem.CellBasis) -> np.ndarray:
        return skfem.asm(skfem.LinearForm(lambda v, w: v), b1)

    # -- Solution interface ----------------------------------------------------------
    def pdf_joint(self, x, y):
        """p_h(x, y); zero outside the strip."""
        return self._eval(x, y)

    def pdf_x(self, x):
        """p(x) = ∫ p_h(x, y) dy (exact on tensor quad meshes; module docstring)."""
        x = np.asarray(x, float)
        if self._tensor is not None:
            xb, yb, P = self._tensor_factors()
            xf = x.ravel()
            inside = (xf >= self._x0) & (xf <= self._x1)
            out = np.zeros(xf.size)
            if inside.any():
                out[inside] = xb.probes(xf[inside][None, :]) @ (P @ self._line_integral(yb))
            return out.reshape(x.shape)
        nodes, w = self._composite(np.unique(self.mesh.p[1]))
        vals = self._eval(x[..., None], nodes)
        return vals @ w

    def pdf_y(self, y):
        """p(y) = ∫ p_h(x, y) dx (exact on tensor quad meshes; module docstring)."""
        y = np.asarray(y, float)
        if self._tensor is not None:
            xb, yb, P = self._tensor_factors()
            yf = y.ravel()
            inside = np.abs(yf) <= self.y_max
            out = np.zeros(yf.size)
            if inside.any():
                out[inside] = yb.probes(yf[inside][None, :]) @ (P.T @ self._line_integral(xb))
            return out.reshape(y.shape)
        nodes, w = self._composite(np.unique(self.mesh.p[0]))
        vals = self._eval(nodes, y[..., None])
        return vals @ w

    def _composite(self, breaks: np.ndarray, npts: int = 4):
        qb = skfem.CellBasis(skfem.MeshLine(breaks), skfem.ElementLineP0(),
                             intorder=2 * npts - 1)
        return np.asarray(qb.global_coordinates())[0].ravel(), qb.dx.ravel()

    @staticmethod
    def has_energy_density(system) -> bool:
        """True where :meth:`pdf_energy` applies: G increasing on each side of 0
        (a > 0, or a = 0 < b), so each energy level is one orbit."""
        return system.a > 0 or (system.a == 0 and system.b > 0)

    def pdf_energy(self, H):
        """Density of H from p_h by the coarea formula (module docstring)."""
        s = self.system
        if not self.has_energy_density(s):
            raise NotImplementedError("pdf_energy of a FEMSolution needs a > 0, or a = 0 "
                                      "< b (G monotone on each side)")
        H = np.asarray(H, float)
        Hf = H.ravel()
        out = np.zeros(Hf.size)
        pos = Hf > 0
        A = s.amplitude(Hf[pos])
        ok = np.isfinite(A) & (A > 0)
        idx = np.flatnonzero(pos)[ok]
        A = A[ok]
        if idx.size:
            t, wt = np.polynomial.legendre.leggauss(_NTHETA)
            lo = np.arcsin(np.clip(self._x0 / A, -1, 1))
            hi = np.arcsin(np.clip(self._x1 / A, -1, 1))
            th = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * t[None, :]
            jac = 0.5 * (hi - lo)[:, None] * wt[None, :]
            xq = A[:, None] * np.sin(th)
            yq = np.sqrt(np.maximum(2.0 * (Hf[idx][:, None] - s.potential(xq)), 0.0))
            den = np.sqrt(s.a + 0.5 * s.b * A[:, None] ** 2 * (1.0 + np.sin(th) ** 2))
            vals = self._eval(xq, yq) + self._eval(xq, -yq)
            out[idx] = np.sum(vals * jac / den, axis=1)
        return out.reshape(H.shape)

    # -- moments and resolution ----------------------------------------------------------
    @property
    def info(self) -> dict:
        """Solver, timings, DOF counts, options, and the resolution diagnostics of
        :meth:`resolution` (evaluated on first access: one pass of the element
        quadrature, which builds :attr:`basis`)."""
        if self._resolution is None:
            self._record(self._quadrature())
        return self._info

    @info.setter
    def info(self, value: dict) -> None:
        self._info = value
        self._resolution = None

    def _quadrature(self) -> dict[str, Any]:
        """One pass of the element quadrature over p_h: moments of p₊ and of p_h,
        the negative mass, and ∫ p₊ per element."""
        b = self.basis
        v = b.interpolate(self.dofs).value
        x, y = b.global_coordinates().value
        wp = np.maximum(v, 0.0) * b.dx
        wn = np.minimum(v, 0.0) * b.dx
        weights = {"E_x2": x * x, "E_x4": x ** 4, "E_y2": y * y, "E_y4": y ** 4}
        mp, mn = float(wp.sum()), float(wn.sum())
        return {"positive": {k: float(np.sum(wp * w)) / mp for k, w in weights.items()},
                "signed": {k: float(np.sum((wp + wn) * w)) / (mp + mn)
                           for k, w in weights.items()},
                "negative_mass": -mn / (mp + mn), "element_mass": wp.sum(axis=1)}

    def _record(self, q: dict[str, Any]) -> None:
        neg = float(q["negative_mass"])
        shift = max(abs(q["positive"][k] - q["signed"][k]) / q["positive"][k]
                    if q["positive"][k] > 0 else 0.0 for k in q["positive"])
        reasons = []
        if neg > RESOLUTION_TOL:
            reasons.append(f"negative mass {neg:.3g} of the density > {RESOLUTION_TOL:g}")
        if shift > RESOLUTION_TOL:
            reasons.append(f"even moments of max(p_h, 0) and p_h differ by {shift:.3g} "
                           f"(relative) > {RESOLUTION_TOL:g}")
        diag = {"negative_mass": neg, "moment_shift": float(shift),
                "under_resolved": bool(reasons),
                "under_resolved_reason": "; ".join(reasons)}
        if reasons:
            diag["under_resolved_reason"] += (" (the mesh does not resolve the density: "
                                              "refine nx/ny, or use positivity=True)")
        self._info.update(diag)
        self._resolution = diag

    def resolution(self) -> dict[str, Any]:
        """Whether the mesh resolves the density, from the density itself.

        Returns
        -------
        dict
            ``negative_mass`` = ∫ max(−p_h, 0) / ∫ p_h; ``moment_shift`` = the largest
            relative difference between an even moment (x², x⁴, y², y⁴) of
            p₊ = max(p_h, 0) and of p_h; ``under_resolved`` (bool) and
            ``under_resolved_reason`` (str, empty when resolved).  Also recorded in
            :attr:`info`.

        Notes
        -----
        The exact density is ≥ 0 and has the mass of p_h, so
        ‖p_h − p‖₁ ≥ 2 ∫ max(−p_h, 0): the negative mass is a computable lower bound
        of the FE error, and ``moment_shift`` is what the clipping of
        :meth:`moments` changed.  Either above :data:`RESOLUTION_TOL` (1e-3) flags
        the mesh: the agreement checks of this package (FE vs Monte Carlo with
        ``target_rse`` 1e-3 to 2e-3, two-level FE errors < 1 %) are meaningless for
        a density whose L1 error is certainly beyond 2e-3.  Measured: 1e-12 (paper
        case, default mesh), 3.7e-2 (nx = 4, ny = 2), 3e-3 to 2e-2 (Galerkin on the
        hard cases r ≤ 0.3 at nx = 48), 0 with ``positivity=True``.
        """
        if self._resolution is None:
            self._record(self._quadrature())
        return dict(self._resolution)

    def moments(self) -> dict[str, float]:
        """E[H], E[x²], E[y²], E[x⁴], E[y⁴] and, with barriers, P_impact.

        All from the non-negative part p₊ = max(p_h, 0), normalised by ∫ p₊
        (element quadrature; ``P_impact`` by the level-set quadrature of the module
        docstring).  Even moments are therefore ≥ 0 and ``P_impact`` ∈ [0, 1] on
        every mesh; :meth:`resolution` (in :attr:`info`) flags meshes where the
        clipping mattered.

        Returns
        -------
        dict
            Keys of :data:`fpk_vibro.solution.MOMENT_KEYS` (no ``P_impact`` without
            barriers).

        Notes
        -----
        Why a non-negative reconstruction rather than refusing coarse meshes at
        solve time: whether a mesh resolves the density depends on the density,
        not on nx, ny (the same nx resolves D1 = 0.01 and not D1 = 1e-6), so it is
        known only after the solve; Galerkin undershoots near (±Δ, 0) on the hard
        cases r → 0 at every practical mesh while its moments still converge at
        order 2; and transient snapshots are FEMSolutions too.  Clipping is safe
        because p ≥ 0: |p₊ − p| ≤ |p_h − p| pointwise, so it never increases the
        error anywhere and keeps the convergence order.  Where p_h ≥ 0 (resolved
        meshes) nothing changes: the difference is bounded by max|weight| times
        the negative mass (1e-12 on the paper case).  The element rule is exact
        for p₊ only on cells where p_h keeps its sign; on the others the error is
        of the size of the (flagged) negative mass.
        """
        s = self.system
        q = self._quadrature()
        if self._resolution is None:
            self._record(q)
        out = dict(q["positive"])
        out = {"E_H": 0.5 * out["E_y2"] + 0.5 * s.a * out["E_x2"] + 0.25 * s.b * out["E_x4"],
               "E_x2": out["E_x2"], "E_y2": out["E_y2"], "E_x4": out["E_x4"],
               "E_y4": out["E_y4"]}
        if s.has_barrier:
            above, below = self.energy_split(s.barrier_energy, q["element_mass"])
            out["P_impact"] = above / (above + below)
        return out

    def energy_split(self, level: float, element_mass: np.ndarray | None = None
                     ) -> tuple[float, float]:
        """(∫ p₊ over {H > level}, ∫ p₊ over {H ≤ level}) on the mesh.

        Parameters
        ----------
        level : float
            The energy level (``P_impact`` uses G(Δ)).
        element_mass : ndarray, optional
            ∫ p₊ per element (computed if not given).

        Returns
        -------
        above, below : float
            Unnormalised; ``above / (above + below)`` is P(H > level).

        Notes
        -----
        Cells wholly on one side (by bounds of H on the cell's bounding box) take
        the element rule; the others the cut-cell rule of the module docstring.
        """
        if element_mass is None:
            element_mass = self._quadrature()["element_mass"]
        s, m = self.system, self.mesh
        V = m.p[:, m.t]
        xlo, xhi = V[0].min(axis=0), V[0].max(axis=0)
        ylo, yhi = V[1].min(axis=0), V[1].max(axis=0)
        Gmin, Gmax = _potential_range(s, xlo, xhi)
        y2min = 0.5 * np.where((ylo <= 0) & (yhi >= 0), 0.0, np.minimum(ylo ** 2, yhi ** 2))
        y2max = 0.5 * np.maximum(ylo ** 2, yhi ** 2)
        above = Gmin + y2min >= level
        below = Gmax + y2max <= level
        cut_above, cut_below = self._cut_integrals(np.flatnonzero(~above & ~below), level)
        return (float(element_mass[above].sum() + cut_above),
                float(element_mass[below].sum() + cut_below))

    def _eval_in_cells(self, cells: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """p_h at points ``x[i, :]``, ``y[i, :]`` known to lie in cell ``cells[i]``."""
        b = self.basis
        ref = b.mapping.invF(np.stack([x, y]), tind=cells)
        out = np.zeros(x.shape)
        for k in range(b.Nbfun):         # over local basis functions, not elements
            out += (b.elem.gbasis(b.mapping, ref, k, tind=cells)[0].value
                    * self.dofs[b.element_dofs[k, cells]][:, None])
        return out

    def _cut_integrals(self, cells: np.ndarray, level: float,
                       chunk: int = 20_000) -> tuple[float, float]:
        """(∫ p₊ over {H > level}, over {H ≤ level}) summed over ``cells`` (module
        docstring: x outside with break points, y inside)."""
        if cells.size == 0:
            return 0.0, 0.0
        s = self.system
        V = self.mesh.p[:, self.mesh.t[:, cells]]          # (2, nv, nc)
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
        roots = _real_roots(coef).reshape(vert.shape + (-1,))
        roots = np.where(vert[..., None], np.nan, roots).transpose(1, 0, 2).reshape(x0.shape[1], -1)
        gcoef = ([0.25 * s.b, 0.0, 0.5 * s.a, 0.0, -level] if s.b != 0
                 else [0.5 * s.a, 0.0, -level] if s.a != 0 else [1.0, 0.0, 1.0])
        groots = _real_roots(np.array([gcoef]))[0]          # G(x) = level: on y = 0
        br = np.concatenate([x0.T, roots, np.broadcast_to(groots, (x0.shape[1], groots.size))],
                            axis=1)
        br = np.where(np.isfinite(br), br, xlo[:, None])
        br = np.sort(np.clip(br, xlo[:, None], xhi[:, None]), axis=1)
        keep = br[:, 1:] - br[:, :-1] > 1e-13 * (xhi - xlo)[:, None]
        ci = np.nonzero(keep)[0]
        xa, xb = br[:, :-1][keep], br[:, 1:][keep]
        t, wt = np.polynomial.legendre.leggauss(_CUT_NX)
        u, wu = np.polynomial.legendre.leggauss(_CUT_NY)
        total = np.zeros(2)
        for k in range(0, ci.size, chunk):             # bounded memory, not per element
            c = ci[k:k + chunk]
            mid, half = 0.5 * (xa[k:k + chunk] + xb[k:k + chunk]), 0.5 * (xb[k:k + chunk] - xa[k:k + chunk])
            xq = mid[:, None] + half[:, None] * (1.5 * t - 0.5 * t ** 3)
            wx = half[:, None] * (1.5 * wt * (1.0 - t * t))
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
            L = np.maximum(hi - lo, 0.0)
            yq = lo[..., None] + 0.5 * L[..., None] * (1.0 + u)              # (3, n, NX, NY)
            w = 0.5 * L[..., None] * wu * wx[None, :, :, None]
            xs = np.broadcast_to(xq[None, :, :, None], yq.shape)
            p = self._eval_in_cells(cells[c], xs.transpose(1, 0, 2, 3).reshape(c.size, -1),
                                    yq.transpose(1, 0, 2, 3).reshape(c.size, -1))
            pw = np.maximum(p, 0.0).reshape(c.size, 3, -1) * w.transpose(1, 0, 2, 3).reshape(c.size, 3, -1)
            total += [pw[:, :2].sum(), pw[:, 2].sum()]
        return float(total[0]), float(total[1])

    # -- output ------------------------------------------------------------------------
    def save_vtu(self, path: str | Path) -> Path:
        """Write the mesh with the nodal density ``p`` (vertex values) through meshio.

        Any extension meshio writes works (``.vtu`` for ParaView, ``.xdmf``, ...).
        """
        import meshio
        from .._checks import invalid
        if not isinstance(path, (str, Path)) or not str(path).strip():
            raise invalid("FEMSolution.save_vtu", "path", "a file path", path)
        path = Path(path)
        if path.suffix.lower() not in meshio.extension_to_filetypes:
            raise invalid("FEMSolution.save_vtu", "path", "a file name with an extension "
                          "meshio writes (.vtu, .xdmf, .vtk, ...)", str(path))
        vertex_vals = self.dofs[self.basis.nodal_dofs[0]]
        from ..io import atomic_files
        try:
            atomic_files(path, lambda p: self.mesh.save(str(p), point_data={"p": vertex_vals}))
        except (meshio.ReadError, meshio.WriteError, KeyError) as exc:
            raise invalid("FEMSolution.save_vtu", "path", "a file name with an extension "
                          "meshio writes", str(path), str(exc)) from None
        return path

    # -- persistence -----------------------------------------------------------------------
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        meta = {"degree": self.degree, "cell": "quad" if isinstance(self.mesh, skfem.MeshQuad1) else "tri",
                "residual": self.residual, "tensor": self._tensor is not None,
                "mass": self.mass,
                "info": {k: v for k, v in self.info.items()
                         if isinstance(v, (int, float, str, bool)) or v is None}}
        arrays = {"mesh_p": self.mesh.p, "mesh_t": self.mesh.t.astype(np.int64), "dofs": self.dofs}
        if self._tensor is not None:
            arrays["xnodes"], arrays["ynodes"] = self._tensor
        return meta, arrays

    _meta_schema = {"degree": Rule.integer(1, 2), "cell": Rule.choice("quad", "tri"),
                    "residual": Rule.number(0.0, nan=True), "tensor": Rule.FLAG,
                    "mass": Rule.number(0.0, lo_open=True, none=True).optional(),
                    "info": Rule.mapping(Rule.SCALAR).optional()}

    @classmethod
    def _array_schema(cls, meta):
        """Vertices (2, n), cells (corners, m) indexing them, DOF values; tensor nodes."""
        corners = 4 if meta["cell"] == "quad" else 3
        out = {"mesh_p": Stored((2, "vertices"), min_size=2 * corners),
               "mesh_t": Stored((corners, "cells"), dtype="int", min_size=corners,
                                below="vertices"),
               "dofs": Stored(("dofs",))}
        if meta["tensor"]:
            out["xnodes"] = Stored(("nx",), min_size=2, increasing=True)
            out["ynodes"] = Stored(("ny",), min_size=2, increasing=True)
        return out

    @classmethod
    def _check_state(cls, system, meta, arrays):
        """DOF count of the degree on this mesh (Q2: + edges + cells, P2: + edges)."""
        t, n = arrays["mesh_t"], arrays["mesh_p"].shape[1]
        want = n
        if meta["degree"] == 2:
            pairs = np.sort(np.stack([t, np.roll(t, -1, axis=0)], axis=-1).reshape(-1, 2), axis=1)
            want += len(np.unique(pairs, axis=0)) + (t.shape[1] if meta["cell"] == "quad" else 0)
        if arrays["dofs"].shape != (want,):
            raise ValueError(f"array 'dofs' has shape {arrays['dofs'].shape}, expected ({want},) "
                             f"for degree {meta['degree']} on this mesh")
        if meta["tensor"] and arrays["xnodes"].size * arrays["ynodes"].size != n:
            raise ValueError(f"arrays 'xnodes' ({arrays['xnodes'].size}) and 'ynodes' "
                             f"({arrays['ynodes'].size}) do not span the {n} mesh vertices")

    @classmethod
    def _from_state(cls, system, meta, arrays):
        kind = skfem.MeshQuad1 if meta["cell"] == "quad" else skfem.MeshTri1
        mesh = kind(np.asarray(arrays["mesh_p"], float), np.asarray(arrays["mesh_t"]),
                    sort_t=False)
        tensor = (arrays["xnodes"], arrays["ynodes"]) if meta["tensor"] else None
        return cls(system, mesh, meta["degree"], arrays["dofs"], residual=meta["residual"],
                   info=meta.get("info", {}), tensor=tensor, mass=meta.get("mass"))

    def __repr__(self) -> str:
        return (f"FEMSolution(system={self.system!r}, degree={self.degree}, "
                f"dofs={self.dofs.size}, mass={self.mass:.15g}, residual={self.residual:.2e})")
