"""The stationary density of the 2-D FPK: :func:`stationary`, the face of the FE method."""
from __future__ import annotations

from ..model import VibroImpactSystem
from .discretisation import build
from .adaptive import adaptive
from .options import DEFAULT_RTOL, Options
from .solution import FEMSolution

__all__ = ["stationary"]


def stationary(system: VibroImpactSystem, *, mesh=None, nx: int | None = None,
               ny: int | None = None, y_max: float | None = None, degree: int = 1,
               solver: str = "auto", element: str = "quad", grading: float = 0.0,
               wall_grading: float | None = None, positivity: bool | str = "auto",
               assembly: str = "auto", rtol: float | None = None, nz: int | None = None,
               progress: bool | None = None) -> FEMSolution:
    """Stationary density of the 2-D FPK with impact coupling.

    Solves L p = 0, ∫ p = 1 where L is the conservative Galerkin generator
    (``assemble``: ∫ J·∇q − B₊ − B₋; docs/theory.md, §Impact coupling) on a mesh
    of the strip.  Given none of ``mesh``, ``nx``, ``ny``, ``positivity`` (and
    ``degree`` at its default), the mesh and degree are chosen for ``rtol`` = 1e-4
    (best effort) and the density is non-negative; ``sol.error_estimate()`` says
    how accurate it is.

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
        :func:`fpk_vibro.fem.mesh.domain`, :mod:`fpk_vibro.scales`).  In x the strip
        ends at the walls, or where the same tail leaves less than 1e-8 of the mass
        (a side without a wall, or a wall beyond the density's support: an elastic
        end there, as without that wall; ``info["walls_beyond_support"]``).
    degree : {1, 2, 3, 4}
        Default 1, used with a mesh, nx or ny (otherwise rtol chooses 2–4).  Q1/P1
        or Q2/P2 Lagrange elements; 3, 4: Q3/Q4 on the structured quad mesh
        with tensor assembly only (:mod:`fpk_vibro.fem.highorder`; default nx 32,
        24).  Measured L1 orders on the exact case: Q3 4, Q4 5 falling to 4
        (docs/measurements.md, §Degrees 3 and 4).
    solver : {"auto", "direct", "amg", "amg-sa"}
        See :mod:`fpk_vibro.fem.solve`.
    element : {"quad", "tri"}
        Structured quadrilaterals or triangles (ignored with ``mesh``).
    grading : float
        ≥ 0: cluster the y-nodes towards y = 0 (sinh map).
    wall_grading : float, optional
        ≥ 1: cluster the x-nodes toward each wall with r < 1
        (:func:`fpk_vibro.fem.mesh.wall_nodes`); default 2 in the rtol solve, else
        uniform.
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
        strongly diffusive).  ``"afc"`` (retired: a DeprecationWarning; it goes in
        the next release): upwinding plus Kuzmin's flux correction by defect
        correction, which does not converge (a RuntimeWarning says so); use
        ``"auto"``.  ``False``: plain Galerkin (order 2 on smooth
        cases, negative next to (±Δ, 0) on hard cases).  Default ``"auto"``:
        Galerkin, with any negative nodal value removed by a local mass-keeping
        redistribution (:mod:`fpk_vibro.fem.nonnegative`); the L1 and moment
        changes it made are in ``sol.info["correction"]`` and in the error
        estimate, and every evaluation (``pdf_joint``, ``pdf_x``, ``pdf_y``,
        ``pdf_energy``) is ≥ 0.  ``sol.info["discretisation"]`` names what ran and
        ``sol.info["discretisation_reason"]`` why.
    assembly : {"auto", "tensor", "general"}
        Kronecker-product assembly (structured quads) or general skfem assembly.
    rtol : float, optional
        Accuracy goal: Galerkin degree 2, 3, 4 and then nx doubled until the
        estimated relative errors of E[H], E[x²], E[y²], P_impact
        (``sol.error_estimate()``, which also gives the L1 error of the density)
        are below ``rtol`` (:mod:`fpk_vibro.fem.estimate`); not with mesh, nx,
        ny, degree or positivity.  Refused in one line naming ``rtol`` when the
        budget, 30 s in all or nx = 4096 would be passed first.  Default: 1e-4
        when none of mesh, nx, ny, degree, positivity is given, as a best effort
        (10 s at most; where it is not reached the last estimated level is
        returned with ``info["under_resolved"]``, ``info["rtol_not_reached"]`` and one
        RuntimeWarning naming its estimated error and what to give instead);
        otherwise no adaptation, and ``sol.error_estimate()`` is still available
        (one richer solve, on first call).

    nz : int, optional
        Coloured external noise only (``system.external``): cells in ζ.
    progress : bool, optional
        Coloured external noise only: progress bars of the 3-D solve.

    Returns
    -------
    FEMSolution
        With coloured external noise a
        :class:`~fpk_vibro.fem.coloured_solution.ColouredFEMSolution`: the density in
        (x, y, ζ) on tensor hexahedra (:mod:`fpk_vibro.fem.coloured`), read through its
        ζ-marginal; only ``nx``, ``ny``, ``nz``, ``degree`` (2 or 3; 1 means the
        default 2), ``y_max`` and ``rtol`` apply.

    Raises
    ------
    ValueError
        Naming the offending parameter, before any work; also when the estimated
        memory or run time is beyond the machine (:mod:`fpk_vibro.budget`).

    Warns
    -----
    RuntimeWarning
        Once, where the default (best-effort) solve misses rtol = 1e-4: its estimated
        error, and the options to give instead.

    Notes
    -----
    Every option is declared once in :class:`fpk_vibro.fem.Options`.
    """
    if getattr(system, "external", None) is not None:
        return _coloured(system, locals())
    chosen = (mesh is None and nx is None and ny is None and degree == 1
              and positivity == "auto" and element == "quad" and assembly != "general")
    best_effort = rtol is None and chosen
    # (best effort: rtol stays None in the options, as in a scene's, so the checks
    # and the cost are those of the default's ladder: fem.ladder)
    opts, _ = Options.prepare(system, "stationary", locals())
    if opts.rtol is not None or best_effort:
        sol = adaptive(system, opts, DEFAULT_RTOL if best_effort else opts.rtol,
                       best_effort=best_effort)
    else:
        sol = build(system, opts).stationary(opts.solver)
        sol._options = opts
    # the stationary power balance (noise in = damping + impacts): a check of p_h
    sol.info["power_balance_residual"] = sol.power_balance()["residual"]
    return sol


#: fem.stationary's keywords a coloured-noise solve takes (the others at their defaults).
_COLOURED_KEYS = ("nx", "ny", "nz", "degree", "y_max", "rtol", "progress")


def _coloured(system: VibroImpactSystem, given: dict) -> FEMSolution:
    from .._checks import InputError
    from .coloured import stationary_coloured
    defaults = stationary.__kwdefaults__
    for key, value in given.items():
        if key not in _COLOURED_KEYS and key != "system" and value is not defaults[key] \
                and value != defaults[key]:
            raise InputError(f"fem.stationary: {key} is not an option of the coloured-noise "
                             f"(3-D) solve; it takes {', '.join(_COLOURED_KEYS)}",
                             where="fem.stationary", name=key)
    kw = {k: given[k] for k in _COLOURED_KEYS}
    if kw["degree"] == 1:
        kw["degree"] = None
    Options.prepare(system, "stationary", {k: v for k, v in kw.items() if v is not None})
    sol = stationary_coloured(system, **kw)
    sol.info["power_balance_residual"] = sol.power_balance()["residual"]
    return sol
