"""Finite elements for the stationary 2-D FPK on the strip with impacts (DESIGN §3).

Public API
----------
:func:`stationary`      stationary density → :class:`FEMSolution`
:func:`assemble`        (L, M) on any skfem basis of the strip (for transient solvers)
:func:`assemble_tensor` the same by Kronecker products on a tensor-product mesh
:func:`domain`          the truncated strip and its walls (default ``y_max`` rule)

Modules: ``forms`` (weak forms of DESIGN §3), ``impact`` (B± coupling),
``generator`` (assembly of L, M), ``mesh``, ``solve``, ``positivity``,
``solution`` (:class:`FEMSolution`), ``benchmark``.

Measured (exact case r = 1, D2 = 0, paper a, b, c, D1, Δ; ny = 4 nx)
--------------------------------------------------------------------
- Q1 and P1: L1 and max-norm order 2.0 (L1 5.4e-4, 1.3e-4, 3.4e-5, 8.4e-6,
  2.2e-6 at nx = 32 … 500 for Q1).  Mass 1 to ~1e-15, min p ≥ 0 to 1e-9.
- Q2/P2: order 2 (L1 7.8e-5, 1.7e-5, 4.0e-6, 9.8e-7 at nx = 16 … 128), about 8×
  more accurate than Q1 per DOF; the largest error sits at (0, 0).  Cause: not
  the quadrature (2k + 9 instead of 2k + 3 gives the same error to 1e-3), not the
  pinned row (any replaced row gives the same vector: 1ᵀL = 0), not the impact
  coupling (Δ = 3, where the walls carry ~1e-9 of the density, shows the same
  order and location).  Refining only y at fixed nx leaves the error at (0, 0)
  unchanged, while halving h_x divides it by 4.00 and the L1 error converges at
  order ~3 in h_y: the order-2 component is the Galerkin discretisation of the
  pure transport y ∂p/∂x (no diffusion in x) — the textbook loss of one order of
  Galerkin for a first-order hyperbolic direction (Q1 keeps order 2 by the
  symmetry of uniform meshes).  Raising it needs a different x-discretisation
  (upwind/DG in x, order k + ½), not more quadrature.
- ``positivity=True`` (:mod:`fpk_vibro.fem.positivity`: positive generator with
  clipped QUICK transport fluxes): L1 order 2.25, 2.21, 2.11 (nx = 16 … 128,
  ny = 2 nx), p ≥ 0 and mass 1 to 1e-15 on the hard cases r ∈ {0, 0.1, 0.3},
  D1 = 0.002, where Galerkin reaches −8 % (r = 0.3) to −26 % (r = 0) of max p.
- Speed (``python -m fpk_vibro.fem.benchmark``): L1 7.1e-6 with Q2, nx = 48
  (37 345 DOFs) in 0.3 s; 10⁶ Q1 DOFs assembled + solved in 19–46 s (machine
  load); the straightforward path (general assembly + SuperLU/COLAMD) is 3–11×
  slower where it was run.  pyamg (AIR, smoothed aggregation) does not converge on
  the Galerkin matrix; it does on the positive generator's step matrix M − dt A
  (7–11 iterations at any size), where ``fem.solve.factorised`` picks it by size
  (docs/fem_solvers.md).
"""
from __future__ import annotations

from ..model import VibroImpactSystem
from .discretisation import Discretisation, build
from .generator import assemble, assemble_tensor
from .mesh import Domain, default_y_max, domain, load_mesh, structured_mesh
from .options import DEFAULT_NX, POSITIVITY, Options
from .solution import FEMSolution
from .solve import SOLVERS

__all__ = ["stationary", "transient", "Options", "Discretisation", "build", "FEMSolution",
           "assemble", "assemble_tensor", "domain", "DEFAULT_NX", "POSITIVITY",
           "default_y_max", "structured_mesh", "load_mesh", "Domain", "SOLVERS",
           "relaxation_time", "first_passage"]


def stationary(system: VibroImpactSystem, *, mesh=None, nx: int | None = None,
               ny: int | None = None, y_max: float | None = None, degree: int = 1,
               solver: str = "auto", element: str = "quad", grading: float = 0.0,
               positivity: bool | str = "auto", assembly: str = "auto") -> FEMSolution:
    """Stationary density of the 2-D FPK with impact coupling (DESIGN §3).

    Solves L p = 0, ∫ p = 1 where L is the conservative Galerkin generator
    (``assemble``: ∫ J·∇q − B₊ − B₋, DESIGN §3) on a mesh of the strip.

    Parameters
    ----------
    system : VibroImpactSystem
    mesh : skfem.Mesh or path, optional
        A mesh of the strip (walls at its x-extremes, symmetric in y, y = 0 a mesh
        line), e.g. from ``meshes/``.  Default: a structured mesh.
    nx, ny : int, optional
        Cells across x and y (``ny`` even).  Default ``nx`` = 128 (Q1) / 48 (Q2),
        ``ny`` the even number giving cells with h_y ≈ 1.5 h_x, at most 4 nx.
    y_max : float, optional
        Truncation |y| < y_max; default from the energy tail (mass beyond < 1e-8,
        :func:`fpk_vibro.fem.mesh.domain`, :mod:`fpk_vibro.scales`).
    degree : {1, 2}
        Q1/P1 or Q2/P2 Lagrange elements.
    solver : {"auto", "direct", "amg", "amg-sa"}
        See :mod:`fpk_vibro.fem.solve`.
    element : {"quad", "tri"}
        Structured quadrilaterals or triangles (ignored with ``mesh``).
    grading : float
        ≥ 0: cluster the y-nodes towards y = 0 (sinh map).
    positivity : bool or {"auto", "quick", "van-albada", "first-order", "upwind", "afc"}
        :mod:`fpk_vibro.fem.positivity` (the first three) and
        :mod:`fpk_vibro.fem.afc`, degree 1 only (nodal Q1 density).
        ``True``/``"quick"``: the positive tensor-grid generator (Scharfetter–
        Gummel for the dissipative y part, upwind fluxes for the Hamiltonian
        transport, conservative lumped walls) with QUICK face values whose flux
        factors are clipped to [0, 4], solved by Picard iteration (Anderson-
        accelerated); every returned density is the null vector of a generator,
        so p ≥ 0 and mass 1.  Measured L1 order ≈ 2.1–2.3 on the exact case
        (module notes).  ``"van-albada"``: the same with TVD van Albada face
        values (order ≈ 2.4 but a larger constant).  ``"first-order"``: the
        generator unlimited (provably ≥ 0, first order, one linear solve).  These
        need the structured quad mesh with tensor assembly.  ``"upwind"``:
        algebraic discrete upwinding of the Galerkin matrix (any mesh; ≥ 0 but
        strongly diffusive).  ``"afc"``: upwinding plus Kuzmin's flux correction
        by defect correction (does not converge on the hard cases; a
        RuntimeWarning says so).  ``False``: plain Galerkin (order 2 on smooth
        cases, negative next to (±Δ, 0) on hard cases).  Default ``"auto"``:
        Galerkin, replaced by ``"quick"`` on nx = 64 (or the given nx) × 2 nx
        cells when the Galerkin density has min p < −1e-6·max p (degree 1,
        structured quads; otherwise Galerkin is kept and the reason says so).
        ``sol.info["discretisation"]`` names what ran and
        ``sol.info["discretisation_reason"]`` why.
    assembly : {"auto", "tensor", "general"}
        Kronecker-product assembly (structured quads) or general skfem assembly.

    Returns
    -------
    FEMSolution

    Raises
    ------
    ValueError
        Naming the offending parameter, before any work; also when the estimated
        memory or run time is beyond the machine (:mod:`fpk_vibro.budget`).

    Notes
    -----
    Every option is declared once in :class:`fpk_vibro.fem.Options`.
    """
    opts, _ = Options.prepare(system, "stationary", locals())
    sol = build(system, opts).stationary(opts.solver)
    # the stationary power balance (noise in = damping + impacts): a check of p_h
    sol.info["power_balance_residual"] = sol.power_balance()["residual"]
    return sol


from .transient import relaxation_time, transient  # noqa: E402
from .first_passage import first_passage  # noqa: E402
