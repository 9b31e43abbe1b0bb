"""The one FE front door: a discretisation built once, used by every FE solver.

:func:`build` turns the system and validated :class:`~fpk_vibro.fem.Options` into a
:class:`Discretisation`: the mesh, the generator L and mass matrix M
(``M dp/dt = L p``; docs/theory.md, §Assembly and solve), the map from the solver's
vector to the mesh DOFs, and which discretisation it is:

- ``"galerkin"``: the conservative Galerkin generator (Kronecker-product assembly
  on the structured quadrilateral mesh, general skfem assembly otherwise);
- ``"positive"``: the positive tensor-grid generator of
  :mod:`fpk_vibro.fem.positivity` with lumped masses (``positivity`` True,
  "quick", "van-albada", "first-order");
- ``"afc"``: the Galerkin generator, made positive by algebraic upwinding and flux
  correction at solve time (:mod:`fpk_vibro.fem.afc`; ``positivity`` "upwind",
  "afc"; stationary only).

``positivity="auto"`` (the stationary default) builds the Galerkin discretisation;
:meth:`Discretisation.stationary` removes any negative nodal value of its density by
the local, mass-keeping redistribution of :mod:`fpk_vibro.fem.nonnegative`, whose
L1 and moment changes are recorded (``info["correction"]``) and added to the error
estimate.  ``sol.info["discretisation"]`` names what ran and
``sol.info["discretisation_reason"]`` why.  In a transient "auto" is Galerkin.

:meth:`Discretisation.stationary` solves for the stationary density and
:func:`fpk_vibro.fem.transient.transient` marches ``M dp/dt = L p`` on the same
object, so the choice of mesh, assembly and positivity is made here only.
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np
import scipy.sparse as sp
import skfem

from ..model import VibroImpactSystem
from .generator import (
    assemble,
    assemble_tensor,
    element_for,
    mesh_domain,
    quadrature_order,
    tensor_index,
)
from .mesh import structured_mesh
from .options import TENSOR_ONLY
from .solution import FEMSolution
from .solve import solve_stationary
from .strip_mesh import load_strip_mesh

__all__ = ["Discretisation", "build", "default_mesh", "discretise"]


class Discretisation:
    """Mesh, generator L, mass M and the map from the solver's vector to mesh DOFs.

    Attributes
    ----------
    kind : {"galerkin", "positive", "afc"}
    positivity : bool or str
        The option it was built with (False for Galerkin).
    L, M : scipy.sparse.csr_matrix
        Generator and mass matrix (for "positive": the positive generator A and the
        lumped masses diag(m)); M of the tensor assembly is made on first use (a
        stationary solve does not need it).
    unit : ndarray
        ∫ φ_i: the mass of the density is ``unit @ p``.
    order : ndarray or None
        Solver vector → mesh DOFs (None: the identity).
    tensor : (xnodes, ynodes) or None
        The grid of a structured quadrilateral mesh.
    points : ndarray, shape (2, n)
        Coordinates of the solver's unknowns.
    """

    def __init__(self, system: VibroImpactSystem, mesh: skfem.Mesh, degree: int,
                 L: sp.csr_matrix, M: sp.csr_matrix, unit: np.ndarray, order: np.ndarray | None,
                 tensor: tuple[np.ndarray, np.ndarray] | None, points: np.ndarray,
                 positivity: bool | str = False, walls: Any = None, *,
                 ranks: tuple | None = None, y_max: float | None = None,
                 assembly: str = "general", seconds: float = 0.0) -> None:
        self.system, self.mesh, self.degree = system, mesh, degree
        self.L, self._M, self.unit = L, M, unit
        self.order, self.tensor, self.points = order, tensor, points
        self.positivity, self.walls = positivity, walls
        self.ranks, self.y_max, self.assembly, self.seconds = ranks, y_max, assembly, seconds
        #: the options of a positivity="auto" build (None otherwise): stationary()
        #: corrects the Galerkin density to p >= 0
        self.auto: Any = None
        #: the options :func:`build` made it from (None when built otherwise)
        self.options: Any = None
        #: notes on walls beyond the density's support (fem.mesh.Domain.beyond)
        self.beyond: tuple[str, ...] = ()

    @property
    def M(self) -> sp.csr_matrix:
        if callable(self._M):          # (the tensor assembly's, made on first use)
            self._M = self._M()
        return self._M

    @property
    def kind(self) -> str:
        if not self.positivity:
            return "galerkin"
        return "positive" if self.positivity in TENSOR_ONLY else "afc"

    def limited_generator(self, p: np.ndarray) -> sp.csr_matrix:
        """A(g(p)): the positive generator with the high-order flux factors of p
        (:mod:`fpk_vibro.fem.positivity`; only for ``positivity`` other than
        "first-order")."""
        from .positivity import limiter_factors, positive_generator
        xs, ys = self.tensor
        scheme = "van-albada" if self.positivity == "van-albada" else "quick"
        gx, gy = limiter_factors(p.reshape(xs.size, ys.size), xs, ys, self.system, scheme)
        return positive_generator(self.system, xs, ys, self.walls, gx, gy)[0]

    def solution(self, p: np.ndarray, **info: Any) -> FEMSolution:
        """The :class:`FEMSolution` of the solver vector ``p``."""
        dofs = p if self.order is None else p[self.order]
        return FEMSolution(self.system, self.mesh, self.degree, dofs, residual=0.0,
                           info=info, tensor=self.tensor, mass=float(self.unit @ p))

    def stationary(self, solver: str = "auto") -> FEMSolution:
        """The stationary density: the normalised null vector of the generator."""
        extra: dict[str, Any] = {}
        if self.kind == "positive":
            from .positivity import stationary_positive
            xs, ys = self.tensor
            p, sinfo, extra = stationary_positive(
                self.system, xs, ys, self.walls, limit=self.positivity != "first-order",
                scheme="van-albada" if self.positivity == "van-albada" else "quick")
        elif self.kind == "afc":
            from .afc import stationary_afc
            p, sinfo, extra = stationary_afc(self.L, self.M, self.unit, solver=solver,
                                             grid=self.ranks,
                                             limit=self.positivity != "upwind")
        else:
            p, sinfo = solve_stationary(self.L, self.unit, solver=solver, grid=self.ranks)
        info = {"assembly_seconds": self.seconds, "solve_seconds": sinfo.seconds,
                "solver": sinfo.solver, "iterations": sinfo.iterations,
                "ordering": sinfo.extra.get("ordering", ""), "ndofs": int(p.size),
                "assembly": self.assembly, "discretisation": self.kind,
                "discretisation_reason": f"requested (positivity={self.positivity!r})",
                "positivity": self.positivity, "y_max": self.y_max, **extra}
        if self.beyond:
            info["walls_beyond_support"] = "; ".join(self.beyond)
        if sinfo.extra.get("fallback"):
            info["fallback"] = sinfo.extra["fallback"]
        sol = self.solution(p, **info)
        sol.residual = sinfo.residual
        if self.auto is not None:
            return self._auto(sol, solver)
        return sol

    def _auto(self, sol: FEMSolution, solver: str) -> FEMSolution:
        """positivity="auto": the Galerkin ``sol`` made non-negative by the local,
        mass-keeping correction of :mod:`fpk_vibro.fem.nonnegative` (module
        docstring); what it changed is in ``info["correction"]`` and in the error
        estimate."""
        from .nonnegative import correct
        ratio = float(sol.dofs.min() / sol.dofs.max())
        sol.info["positivity"] = "auto"
        out = correct(sol)
        if out is sol:
            out.info["discretisation_reason"] = "auto: Galerkin, non-negative as solved"
        else:
            c = out.info["correction"]
            out.info["discretisation_reason"] = (
                f"auto: Galerkin (min p = {ratio:.1e}·max p), made non-negative by local "
                f"mass redistribution: ∫|Δp| = {c['L1']:.1e}, largest moment change "
                f"{max(v for k, v in c.items() if k.startswith(('E_', 'P_'))):.1e}")
        return out


def default_mesh(system: VibroImpactSystem, opts: Any):
    """(domain, mesh, x-nodes, y-nodes) of the structured mesh of ``opts``.

    ``nx`` defaults to :data:`DEFAULT_NX`; ``ny`` to the even number giving cells
    with h_y ≈ 1.5 h_x, at most 4 nx (a narrow strip, e.g. Δ = 0.05, would
    otherwise get ~10⁶ cells in y for nothing).
    """
    dom, nx, ny = opts.grid(system)
    m, xs, ys = structured_mesh(dom, nx, ny, kind=opts.element, grading=float(opts.grading),
                                wall_grading=float(opts.wall_grading or 1.0))
    return dom, m, xs, ys


def build(system: VibroImpactSystem, opts: Any) -> Discretisation:
    """The :class:`Discretisation` of validated options ``opts`` (module docstring),
    which it keeps as ``options`` (a transient's estimate builds a richer one)."""
    disc = _build(system, opts)
    disc.options = opts
    return disc


def _build(system: VibroImpactSystem, opts: Any) -> Discretisation:
    if opts.positivity == "auto":        # Galerkin; stationary() may switch
        disc = build(system, opts.replace(positivity=False))
        disc.auto = opts
        return disc
    disc, dom = _assemble(system, opts)
    disc.beyond = dom.beyond
    return disc


def _assemble(system: VibroImpactSystem, opts: Any) -> tuple[Discretisation, Any]:
    t0 = time.perf_counter()
    positivity, degree = opts.positivity, opts.degree
    if opts.mesh is None:
        dom, m, xs, ys = default_mesh(system, opts)
        if positivity in TENSOR_ONLY:
            from .positivity import positive_generator
            A, unit = positive_generator(system, xs, ys, dom.walls)
            pts = np.stack(np.meshgrid(xs, ys, indexing="ij")).reshape(2, -1)
            return Discretisation(system, m, 1, A.tocsr(), sp.diags(unit).tocsr(), unit,
                                  None, (xs, ys), pts, positivity, dom.walls,
                                  y_max=dom.y_max, assembly="tensor",
                                  seconds=time.perf_counter() - t0), dom
        if opts.element == "quad" and opts.assembly != "general":
            op = assemble_tensor(system, xs, ys, degree, dom)
            order = None
            if degree == 2:      # a one-point basis is enough to read the DOF locations
                order = tensor_index(op.xbasis, op.ybasis,
                                     skfem.CellBasis(m, element_for(m, degree), intorder=1))
            pts = np.stack(np.meshgrid(op.xbasis.doflocs[0], op.ybasis.doflocs[0],
                                       indexing="ij")).reshape(2, -1)
            ranks = tuple(np.argsort(np.argsort(b.doflocs[0])) for b in (op.xbasis, op.ybasis))
            return Discretisation(system, m, degree, op.L, lambda: op.M, op.unit, order,
                                  (xs, ys), pts, positivity, dom.walls, ranks=ranks,
                                  y_max=dom.y_max, assembly="tensor",
                                  seconds=time.perf_counter() - t0), dom
    else:
        m = load_strip_mesh(system, opts.mesh, "fem")
        dom = mesh_domain(system, m)
    basis = skfem.CellBasis(m, element_for(m, degree), intorder=quadrature_order(degree))
    L, M = assemble(system, basis)
    return Discretisation(system, m, degree, L, M, np.asarray(M.sum(axis=0)).ravel(), None,
                          None, basis.doflocs, positivity, dom.walls, y_max=dom.y_max,
                          seconds=time.perf_counter() - t0), dom


def discretise(system: VibroImpactSystem, *, mesh=None, nx: int | None = None,
               ny: int | None = None, y_max: float | None = None, degree: int | None = None,
               element: str = "quad", grading: float = 0.0,
               wall_grading: float | None = None,
               positivity: bool | str = False) -> Discretisation:
    """Build the mesh and assemble (L, M) exactly as :func:`fpk_vibro.fem.stationary`
    does, for a transient (:func:`fpk_vibro.fem.transient`, also importable from
    :mod:`fpk_vibro.fem.transient`); with ``positivity`` the positive generator and
    the lumped masses instead.  Options as in :class:`fpk_vibro.fem.Options`."""
    from .options import Options
    return build(system, Options.prepare(system, "transient", locals())[0])
