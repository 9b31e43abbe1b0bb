"""`FEMSolution`: the stationary finite-element density as a :class:`fpk_vibro.Solution`.

How the derived quantities are computed from the FE function p_h(x, y):

- ``pdf_joint``: p_h at points (zero outside the strip).  On the structured tensor
  mesh (the default) by :mod:`fpk_vibro.fem.tensor_eval`: the cell by
  ``np.searchsorted`` in the x- and y-nodes and the 1-D bases there, no 2-D basis
  and no inverse map, so every evaluation, the moments and the power balance
  below cost O(DOFs) (10⁶ DOFs: moments 0.3 s; docs/measurements.md, §Scale).
  On other meshes (mesh files, triangles, general assembly) by ``Basis.probes``.
- ``pdf_x``, ``pdf_y``, ``pdf_energy``: :mod:`fpk_vibro.fem.marginals`.
- ``moments``: E[x²], ..., E[y⁴] are functionals of p_h by the element quadrature
  (order 2k + 3: exact for the weights x⁴, y⁴ times Q_k / P_k; on the tensor mesh
  the same tensor Gauss rule by 1-D contractions), divided by ∫ p_h;
  where one of them would be negative (a mesh far too coarse), of
  p₊ = max(p_h, 0) instead (:meth:`FEMSolution.moments` says why).
  ``P_impact = ∫_{H > G(Δ)} p_h / ∫ p_h`` over the mesh itself, cells cut by the
  level set integrated where it is explicit (:mod:`fpk_vibro.fem.integrals`): no
  energy grid, so no scale of Δ or of the noise can be missed.  Any a, b.
- Resolution diagnostics (``info["negative_mass"]``, ``"moment_shift"``,
  ``"under_resolved"``, ``"under_resolved_reason"``, ``"moments_of"``):
  :meth:`FEMSolution.resolution`, :mod:`fpk_vibro.fem.under_resolved`.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import skfem
from skfem import Functional

from ..model import VibroImpactSystem
from ..solution import Solution
from . import integrals
from .marginals import energy_density, marginal_x, marginal_y
from .solution_files import (META_SCHEMA, array_schema, check_state, state, state_info,
                             state_mesh, write_mesh_file)
from .under_resolved import RESOLUTION_TOL, diagnosis, flag_estimate  # noqa: F401

__all__ = ["FEMSolution"]


class FEMSolution(Solution):
    """Stationary FE density on a mesh of the strip (docs/theory.md, §FPK on the strip).

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
    #: :meth:`error_estimate`'s estimator, :func:`fpk_vibro.fem.estimate.error_estimate`,
    #: set by that module (it solves a richer level: this module cannot import it)
    estimator: Any = None

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
        self._options: Any = None       # the options it was solved with (estimate)
        self._estimate: dict | None = None

    @property
    def basis(self) -> skfem.CellBasis:
        """The Lagrange basis of p_h (built on first use; quadrature 2k + 3).
        Degrees 3 and 4 have none (a tensor density: :mod:`fpk_vibro.fem.highorder`)."""
        if self.degree > 2:
            raise AttributeError(f"a degree-{self.degree} FEMSolution is a tensor density "
                                 "without a 2-D skfem basis (fpk_vibro.fem.highorder)")
        if self._basis is None:
            from .generator import element_for, quadrature_order
            self._basis = skfem.CellBasis(self.mesh, element_for(self.mesh, self.degree),
                                          intorder=quadrature_order(self.degree))
        return self._basis

    @property
    def mass(self) -> float:
        """∫ p_h over the strip (1 to round-off after normalisation)."""
        if self._mass is None and self.degree > 2:
            xb, yb, P = self._tensor_factors()
            self._mass = float(self._line_integral(xb) @ P @ self._line_integral(yb))
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
            # p = Σ_ij P_ij ψ_i(x) χ_j(y): cells by searchsorted, no inverse map
            out[idx] = self._field()(x[idx], y[idx])
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
            if self.degree > 2:          # the DOFs are the Kronecker coefficients
                self._tensor_cache = (xb, yb, self.dofs.reshape(xb.N, yb.N))
                return self._tensor_cache
            k = tensor_index(xb, yb, self._doflocs())
            P = np.zeros(xb.N * yb.N)
            P[k] = self.dofs
            self._tensor_cache = (xb, yb, P.reshape(xb.N, yb.N))
        return self._tensor_cache

    def _doflocs(self):
        """Something with the ``doflocs`` of :attr:`basis`, without building its
        quadrature (vertices for degree 1; else a one-point basis)."""
        from types import SimpleNamespace
        if self._basis is not None:
            return self._basis
        if self.degree == 1:
            return SimpleNamespace(doflocs=self.mesh.p)
        from .generator import element_for
        return skfem.CellBasis(self.mesh, element_for(self.mesh, self.degree), intorder=1)

    def _field(self):
        """The :class:`~fpk_vibro.fem.tensor_eval.TensorField` of p_h on a tensor
        mesh (None otherwise): point values, quadrature and level split without the
        2-D basis."""
        if self._tensor is None:
            return None
        if getattr(self, "_field_cache", None) is None:
            from .tensor_eval import TensorField
            self._field_cache = TensorField(*self._tensor_factors())
        return self._field_cache

    def _split(self, level: float, q: dict[str, Any]) -> np.ndarray:
        """[[above, below] of p_h, [above, below] of p₊] for the quadrature ``q``
        (a tensor quadrature's per-cell masses are a (2, x-cells, y-cells) grid)."""
        if np.ndim(q["element_mass"]) == 3:
            return self._field().split(self.system, level, q["element_mass"])
        return integrals.split(self, level, q["element_mass"])

    @staticmethod
    def _line_integral(b1: skfem.CellBasis) -> np.ndarray:
        return skfem.asm(skfem.LinearForm(lambda v, w: v), b1)

    # -- Solution interface ----------------------------------------------------------
    def _clip(self, values):
        """max(values, 0) for a corrected density (``info["nonnegative"]``,
        :mod:`fpk_vibro.fem.nonnegative`: its dips between the nodes are in the
        error estimate); a raw Galerkin density is returned as it is."""
        return np.maximum(values, 0.0) if self._info.get("nonnegative") else values

    def pdf_joint(self, x, y):
        """p_h(x, y); zero outside the strip."""
        return self._clip(self._eval(x, y))

    def pdf_x(self, x):
        """p(x) = ∫ p_h(x, y) dy (exact on tensor quad meshes;
        :mod:`fpk_vibro.fem.marginals`)."""
        return marginal_x(self, x)

    def pdf_y(self, y):
        """p(y) = ∫ p_h(x, y) dx (exact on tensor quad meshes;
        :mod:`fpk_vibro.fem.marginals`)."""
        return marginal_y(self, y)

    @staticmethod
    def has_energy_density(system) -> bool:
        """True: :meth:`pdf_energy` applies to every potential (issue 31); kept for callers."""
        return True

    def pdf_energy(self, H):
        """p(H) over the whole level set, any potential (:mod:`fpk_vibro.fem.marginals`);
        its L1 error ≤ the joint one, ``error_estimate()["L1"]``: ∫|p_H − p̂_H| ≤ ∫∫|p − p̂|."""
        return energy_density(self, H)

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
        if self._tensor is not None:         # the same Gauss rule by 1-D contractions
            return self._field().quadrature()
        return integrals.element_quadrature(self)

    def _record(self, q: dict[str, Any]) -> None:
        diag = diagnosis(q, self._info)
        self._info.update(diag)
        self._resolution = diag
        if self._estimate is not None:
            self._apply_estimate()

    def resolution(self) -> dict[str, Any]:
        """Whether the mesh resolves the density, from the density itself.

        Returns
        -------
        dict
            ``negative_mass`` = ∫ max(−p_h, 0) / ∫ p_h; ``moment_shift`` = the largest
            relative difference between an even moment (x², x⁴, y², y⁴) of
            p₊ = max(p_h, 0) and of p_h; ``under_resolved`` (bool) and
            ``under_resolved_reason`` (str, empty when resolved); ``moments_of``:
            ``"p_h"`` or ``"max(p_h, 0)"``, the density :meth:`moments` integrates.
            Also recorded in :attr:`info`.

        Notes
        -----
        The exact density is ≥ 0 and has the mass of p_h, so
        ‖p_h − p‖₁ ≥ 2 ∫ max(−p_h, 0): the negative mass is a computable lower bound
        of the FE error.  Either figure above :data:`RESOLUTION_TOL` (1e-3) flags the
        mesh; why this threshold, and the figures measured on the hard cases:
        ``docs/fem_moments.md``.
        """
        if self._resolution is None:
            self._record(self._quadrature())
        return dict(self._resolution)

    def error_estimate(self) -> dict[str, Any]:
        """The estimated errors of this density (:mod:`fpk_vibro.fem.estimate`).

        Returns
        -------
        dict
            ``L1`` (∫|p_h − p|), ``E_H``, ``E_x2``, ``E_y2`` and with barriers
            ``P_impact`` (relative), ``assumes`` (what the estimate rests on),
            ``richer`` (the level it was compared with), ``seconds``.  Computed on
            first call by one richer solve (degree + 1, or h/2 at degree 4; a
            transient's: one richer transient for all its times,
            :mod:`fpk_vibro.fem.transient_estimate`) unless ``fem.stationary(...,
            rtol=...)`` or ``fem.transient(..., rtol=...)`` made it; afterwards
            ``info["error_estimate"]`` holds the largest entry and
            ``info["under_resolved"]`` is also set when it exceeds the solve's
            ``rtol`` (or 1e-3, :data:`RESOLUTION_TOL`, without one).
        """
        if self._estimate is None:
            if self.snapshot_time() is not None and "estimator" not in vars(self):
                raise ValueError("error_estimate: this transient density has no estimate (one "
                                 "read from a file saved before fem.transient made it has none)")
            self._estimate = self.estimator(self)
        self._apply_estimate()
        return dict(self._estimate)

    def _apply_estimate(self) -> None:
        if self._estimate is not None:
            flag_estimate(self.info, self._resolution, self._estimate)

    def moments(self) -> dict[str, float]:
        """E[H], E[x²], E[y²], E[x⁴], E[y⁴] and, with barriers, P_impact.

        The Galerkin moments (functionals of p_h, element quadrature, divided by
        ∫ p_h; ``P_impact`` by the level-set quadrature of the module docstring,
        clamped to [0, 1]) — unless one of its even moments is negative: then every
        moment is taken of the non-negative reconstruction p₊ = max(p_h, 0),
        normalised by ∫ p₊.  Even moments are therefore ≥ 0 and ``P_impact`` ∈
        [0, 1] on every mesh; ``info["moments_of"]`` says which density was used,
        and such a mesh is always flagged ``info["under_resolved"]`` (a negative
        even moment means ``moment_shift`` > 1; :meth:`resolution`).

        Returns
        -------
        dict
            Keys of :data:`fpk_vibro.solution.MOMENT_KEYS` (no ``P_impact`` without
            barriers).

        Notes
        -----
        Coarse meshes are flagged, not refused: whether a mesh resolves the density
        depends on the density and is known only after the solve.  The Galerkin
        moments are kept where possible because the cancellation of undershoot
        against overshoot makes them more accurate than those of p₊ (measurements:
        ``docs/fem_moments.md``).
        """
        s = self.system
        q = self._quadrature()
        if self._resolution is None:
            self._record(q)
        galerkin = self._resolution["moments_of"] == "p_h"
        m = q["signed"] if galerkin else q["positive"]
        out = {"E_H": 0.5 * m["E_y2"] + 0.5 * s.a * m["E_x2"] + 0.25 * s.b * m["E_x4"],
               "E_x2": m["E_x2"], "E_y2": m["E_y2"], "E_x4": m["E_x4"], "E_y4": m["E_y4"]}
        if s.has_barrier:
            above, below = self._split(s.barrier_energy, q)[0 if galerkin else 1]
            out["P_impact"] = min(max(above / (above + below), 0.0), 1.0)
        return out

    def impacts(self) -> dict[str, dict[str, float]]:
        """Per wall: impact rate, mean and mean-square speed before impact and the
        energy the impacts remove per unit time, from the trace of p_h on the wall
        (:mod:`fpk_vibro.fem.impacts`)."""
        from .impacts import impact_statistics
        return impact_statistics(self)

    def impact_speed_pdf(self, wall: str, u):
        """Density of the speed just before impact on ``wall`` ("left"/"right")."""
        from .impacts import impact_speed_pdf
        return impact_speed_pdf(self, wall, u)

    def _inter_impact(self):
        if getattr(self, "_inter_impact_cache", None) is None:
            from .inter_impact import inter_impact
            self._inter_impact_cache = inter_impact(self)
        return self._inter_impact_cache

    def inter_impact_pdf(self, t):
        """Density of the time between successive impacts (any wall) at ``t`` ≥ 0: the
        first passage to the walls, walls absorbing, from the stationary post-impact
        flux (:mod:`fpk_vibro.fem.inter_impact`; solved on first use, then kept)."""
        return self._inter_impact().pdf(t)

    def mean_inter_impact_time(self) -> float:
        """Mean time between successive impacts from the walls-absorbing backward
        equation (:mod:`fpk_vibro.fem.inter_impact`); it equals 1/(total rate of
        :meth:`impacts`) (Kac), on the Galerkin density to round-off."""
        return self._inter_impact().mean

    def inter_impact_pairs(self) -> dict[str, dict[str, float]]:
        """Per wall pair ``"left->right"`` ...: the probability that an impact on the
        first wall is followed by one on the second, and the mean time between them."""
        return {k: dict(v) for k, v in self._inter_impact().pairs.items()}

    def energy_split(self, level: float, *, positive: bool = False) -> tuple[float, float]:
        """(∫ over {H > level}, ∫ over {H ≤ level}) of p_h on the mesh.

        Parameters
        ----------
        level : float
            The energy level (``P_impact`` uses G(Δ)).
        positive : bool
            Integrate p₊ = max(p_h, 0) instead of p_h.

        Returns
        -------
        above, below : float
            Unnormalised; ``above / (above + below)`` is P(H > level).

        Notes
        -----
        Cells wholly on one side (by bounds of H on the cell's bounding box) take
        the element rule; the others the cut-cell rule of the module docstring.
        """
        above, below = self._split(level, self._quadrature())[int(positive)]
        return float(above), float(below)

    # -- output ------------------------------------------------------------------------
    def save_vtu(self, path: str | Path) -> Path:
        """Write the mesh with the nodal density ``p`` (vertex values) through meshio:
        ``.vtu``, ``.xdmf``, ... (:func:`fpk_vibro.fem.solution_files.write_mesh_file`)."""
        return write_mesh_file(self, path)

    # -- persistence -----------------------------------------------------------------------
    _meta_schema = META_SCHEMA

    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return state(self)

    @classmethod
    def _array_schema(cls, meta):
        """Vertices (2, n), cells (corners, m) indexing them, DOF values; tensor nodes."""
        return array_schema(meta)

    @classmethod
    def _check_state(cls, system, meta, arrays):
        """DOF count of the degree on this mesh; the walls at its x-extremes."""
        check_state(meta, arrays, system)

    @classmethod
    def _from_state(cls, system, meta, arrays):
        tensor = (arrays["xnodes"], arrays["ynodes"]) if meta["tensor"] else None
        return cls(system, state_mesh(meta, arrays), meta["degree"], arrays["dofs"],
                   residual=meta["residual"], info=state_info(meta), tensor=tensor,
                   mass=meta.get("mass"))

    def __repr__(self) -> str:
        return (f"FEMSolution(system={self.system!r}, degree={self.degree}, "
                f"dofs={self.dofs.size}, mass={self.mass:.15g}, residual={self.residual:.2e})")
