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
- ``moments``: E[H], E[x²], ... are skfem functionals of p_h (exact quadrature of
  polynomial weights), divided by the mass; ``P_impact = 1 − ∫₀^{G(Δ)} p(H) dH``
  (Gauss–Legendre in H on the energy density above); for a ≤ 0 (no amplitude
  map) the indicator of H > G(Δ) is integrated by the element quadrature instead.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import skfem
from skfem import Functional

from ..model import VibroImpactSystem
from ..solution import Solution

__all__ = ["FEMSolution"]

_NTHETA = 96
_NH = 64


@Functional
def _moment(w):
    x, y = w.x
    return w.f * (x ** w.kx) * (y ** w.ky)


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
        Solver, timings, DOF counts, options.
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

    def moments(self) -> dict[str, float]:
        """E[H], E[x²], E[y²], E[x⁴], E[y⁴], P_impact (module docstring)."""
        s = self.system
        f = self.basis.interpolate(self.dofs)

        def E(kx, ky):
            return float(skfem.asm(_moment, self.basis, f=f, kx=kx, ky=ky)) / self.mass

        Ex2, Ex4, Ey2, Ey4 = E(2, 0), E(4, 0), E(0, 2), E(0, 4)
        out = {"E_H": 0.5 * Ey2 + 0.5 * s.a * Ex2 + 0.25 * s.b * Ex4,
               "E_x2": Ex2, "E_y2": Ey2, "E_x4": Ex4, "E_y4": Ey4}
        if s.has_barrier and s.a <= 0:
            # no amplitude map: quadrature of the indicator (first-order accurate
            # across the level set H = G(Δ))
            Hb = s.barrier_energy
            ind = skfem.asm(Functional(lambda w: w.f * (s.energy(w.x[0], w.x[1]) > Hb)),
                            self.basis, f=f)
            out["P_impact"] = float(ind) / self.mass
        elif s.has_barrier:
            Hb = s.barrier_energy
            t, w = np.polynomial.legendre.leggauss(_NH)
            Hq = 0.5 * Hb * (t + 1.0)
            out["P_impact"] = float(1.0 - 0.5 * Hb * np.sum(w * self.pdf_energy(Hq)) / self.mass)
        return out

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
        try:
            self.mesh.save(str(path), point_data={"p": vertex_vals})
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
