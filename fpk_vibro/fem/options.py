"""The options of the finite-element method, declared once (see :mod:`fpk_vibro.options`).

:meth:`Options.validate_for` holds every rule that joins options to each other or to
the system (a mesh file is read and checked here), and :meth:`Options.estimate` the
cost model (constants measured on this machine kind, ``docs/costs.md``).  Both run
in :func:`~fpk_vibro.fem.stationary`, :func:`~fpk_vibro.fem.transient` and in
``fpk-vibro check``, so a scene that passes the check passes them in the run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .._checks import InputError, invalid, retired
from ..budget import Cost
from ..model import VibroImpactSystem
from ..options import Options as _Options
from ..options import PerMode, option
from .ladder import DEFAULT_RTOL, WALL_GRADING, ladder_cost, uses_ladder  # noqa: F401
from .mesh import thermal_velocity
from .solve import SOLVERS
from .strip_mesh import load_strip_mesh
from .periodic_options import MAX_HARMONICS, REDUCED, periodic_cost, validate_periodic
from .wall_layers import MAX_CONTRAST, check_wall_layers, wall_layers  # noqa: F401

__all__ = [
    "DEFAULT_NX",
    "PASSAGE_NX",
    "DEFAULT_RTOL",
    "WALL_GRADING",
    "POSITIVITY",
    "SCHEMES",
    "SOLVERS",
    "Options",
    "load_strip_mesh",
]

S, T, FP, PE = ("stationary",), ("transient",), ("first_passage",), ("periodic",)
#: The mesh options shared by the densities and first passage.
ALL = ("stationary", "transient", "first_passage")
#: With fem.periodic (its keywords: rtol, nx, ny, degree, harmonics, y_max,
#: wall_grading).
ALLP, DENSP = ALL + PE, ("stationary", "transient", "periodic")
#: Cells across x of each part of the safe set in first passage by default: within
#: 0.2 % of converged on the measured cases (docs/fem_first_passage.md) in about a
#: second.
PASSAGE_NX = 32
#: positivity values: the tensor-grid generator's (stationary and transient), then
#: the algebraic ones (stationary, any mesh).  "auto" (the stationary default):
#: Galerkin made non-negative by a local mass-keeping correction whose changes
#: enter the error estimate (fem.nonnegative); in a transient "auto" is Galerkin.
POSITIVITY = (False, True, "auto", "quick", "van-albada", "first-order", "upwind", "afc")
TENSOR_ONLY = (True, "quick", "van-albada", "first-order")
#: Retired positivity values, accepted for one release (docs/measurements.md, §Which option when).
RETIRED = {"afc": ("its flux correction does not converge, even on the paper case",
                   "\"auto\" (non-negative on any mesh, 12-290 times closer when measured)")}
SCHEMES = ("bdf2", "theta", "euler")
#: Default number of cells across the strip in x, per degree (degrees 3 and 4:
#: the structured tensor mesh only; about the DOFs of Q2 at nx = 48).
DEFAULT_NX = {1: 128, 2: 48, 3: 32, 4: 24}


def _mesh(name: str, value: Any, where: str | None) -> Any:
    import skfem
    if isinstance(value, skfem.Mesh):
        return value
    if isinstance(value, (str, Path)) and str(value).strip():
        return value
    raise invalid(where, name, "a skfem.Mesh or a mesh file (any format meshio reads)", value)


def _positivity(name: str, value: Any, where: str | None) -> Any:
    for p in POSITIVITY:
        if type(value) is type(p) and value == p:
            if p in RETIRED:
                retired(where, name, p, *RETIRED[p])
            return p
    raise invalid(where, name, f"false, true or one of {list(POSITIVITY[2:])}", value)


#: What a transient reads of a Discretisation (checked by duck typing: the class
#: builds and solves, which no option check may import).
_DISCRETISATION_ATTRIBUTES = ("system", "mesh", "L", "M", "unit", "order", "points",
                              "positivity")


def _discretisation(name: str, value: Any, where: str | None) -> Any:
    if not all(hasattr(value, a) for a in _DISCRETISATION_ATTRIBUTES):
        raise invalid(where, name, "a Discretisation from fem.transient.discretise", value)
    return value


#: The coloured-noise (3-D) solve's default (nx, ny, nz, degree): the paper case with
#: walls at ±0.6, τ = 0.5 within 3e-4 (docs/measurements.md, §Coloured noise).
COLOURED_GRID = (16, 24, 12, 2)


@dataclass(frozen=True)
class Options(_Options):
    """Numerical options of :func:`~fpk_vibro.fem.stationary`,
    :func:`~fpk_vibro.fem.transient` and :func:`~fpk_vibro.fem.first_passage` (there
    nx, ny, degree mesh each part of the safe set, rtol drives its refinement)."""

    WHERE = "fem"
    #: fem.periodic solves for a forced system's periodic state and fem.transient
    #: marches one (its forcing explicit in IMEX-BDF2 steps).
    FORCED_MODES = ("transient", "periodic")
    #: fem.stationary and fem.transient solve a system with coloured noise in
    #: (x, y, ζ) (:mod:`fpk_vibro.fem.coloured`, :mod:`fpk_vibro.fem.coloured_transient`).
    COLOURED_MODES = ("stationary", "transient")

    mesh: Any = option(None, "a mesh of the strip (walls at its x-extremes, symmetric in y, "
                       "y = 0 a mesh line); in a scene a file relative to it", "custom",
                       check=_mesh, allowed="a mesh file", scene="file", reduced="drop",
                       auto="a structured mesh of nx × ny cells")
    nx: int | None = option(None, "cells across x", "int", lo=2, hi=10 ** 6,
                            reduced=24, modes=ALLP,
                            auto="128, 48, 32, 24 for degree 1, 2, 3, 4 (first "
                            "passage: 32; periodic: 12, doubled by rtol)")
    ny: int | None = option(None, "cells across y (even: y = 0 is a mesh line)", "int",
                            lo=2, hi=10 ** 6, even=True, reduced=32, modes=ALLP,
                            auto="h_y ≈ 1.5 h_x, at most 4 nx (first passage: 2 nx)")
    nz: int | None = option(None, "cells across ζ (coloured external noise only: the 3-D "
                            "solve, fpk_vibro.fem.coloured; below 8 its ζ-spectrum is not "
                            "resolved)", "int", lo=8, hi=4096, even=True,
                            reduced=8, modes=("stationary", "transient"), auto="12")
    y_max: float | None = option(None, "velocity truncation |y| < y_max", "float", lo=0.0,
                                 lo_open=True, unit="m/s", modes=DENSP,
                                 auto="the energy-tail rule of fpk_vibro.scales (mass "
                                      "beyond < 1e-8; periodic: plus Ω times the linear "
                                      "response amplitude)")
    degree: int | None = option(PerMode(1, None, 2), "Lagrange degree: 1 (Q1/P1), 2 (Q2/P2); "
                                "3 or 4 (Q3/Q4, the structured quad mesh with tensor "
                                "assembly; not in first passage)", "int", lo=1, hi=4,
                                modes=ALLP,
                                auto="2, or 1 with positivity (periodic: 3)")
    rtol: float | None = option(None, "accuracy goal: degree 2-4, nx, ny are chosen until "
                                "the estimated L1 error of p and relative errors of E[H], "
                                "E[x²], E[y²], P_impact are below it (sol.error_estimate();"
                                " in a transient at every output time, space and time); "
                                "not with mesh, nx, ny, degree or positivity "
                                "(first passage: nx, ny, n_steps doubled from the given "
                                "ones until its three-level estimate meets it)",
                                "float", lo=1e-10, hi=0.5, modes=ALLP,
                                auto="stationary: 1e-4 (best effort: flagged and one "
                                     "RuntimeWarning, not refused, when not reached) "
                                     "unless mesh, nx, ny or positivity is given, then no "
                                     "adaptation (the estimate is still available: "
                                     "sol.error_estimate()); transient, first passage: no "
                                     "adaptation; periodic: 1e-3 (best effort) unless "
                                     "nx, ny, degree or harmonics is given")
    n_steps: int = option(200, "BDF2 steps of the first-passage reliability march per 5 "
                          "mean times (at most 8 n_steps in all)", "int", lo=10,
                          hi=10 ** 6, modes=FP)
    solver: str = option("auto", "linear solver of the stationary system", "choice",
                         choices=SOLVERS, modes=S)
    element: str = option("quad", "structured quadrilaterals or triangles", "choice",
                          choices=("quad", "tri"))
    grading: float = option(0.0, "clustering of the y-nodes towards y = 0 (sinh map)",
                            "float", lo=0.0, hi=20.0)
    wall_grading: float | None = option(None, "clustering of the x-nodes toward each wall "
                                        "with r < 1: x_w − x ∝ s^power (1: uniform)",
                                        "float", lo=1.0, hi=4.0, modes=DENSP,
                                        auto="2 in the rtol solve, else 1 (uniform); "
                                             "periodic: 2 with a wall r < 1")
    harmonics: int | None = option(None, "K, the highest time harmonic of the periodic "
                                   "density kept", "int", lo=1, hi=MAX_HARMONICS, modes=PE,
                                   reduced=4, auto="raised from 4 by 4 until ‖p_K‖ < "
                                   "rtol/10 (relative to ‖p_0‖)")
    positivity: bool | str = option(PerMode("auto", False),
                                    "non-negative discretisation (degree 1): the positive "
                                    "tensor-grid generator, or algebraic upwinding "
                                    "(stationary, any mesh); \"auto\": Galerkin made "
                                    "non-negative by a local mass-keeping correction whose "
                                    "changes enter the error estimate (in a transient "
                                    "\"auto\" is Galerkin)",
                                    "custom", check=_positivity,
                                    allowed="false, true, \"auto\", \"quick\", "
                                            "\"van-albada\", \"first-order\" or "
                                            "\"upwind\" (\"afc\": retired)")
    assembly: str = option("auto", "Kronecker-product or general skfem assembly", "choice",
                           choices=("auto", "tensor", "general"), modes=S)
    dt: float | None = option(None, "time step (the largest, with adaptive steps)", "float",
                              lo=0.0, lo_open=True, unit="s", modes=T,
                              auto="a twentieth of the period T0 (fpk_vibro.scales)")
    scheme: str | None = option(None, "time scheme", "choice", choices=SCHEMES, modes=T,
                                auto="bdf2; euler with positivity")
    theta: float = option(0.5, "θ of the θ-scheme (1/2 Crank–Nicolson, 1 implicit Euler)",
                          "float", lo=0.5, hi=1.0, modes=T)
    tol: float | None = option(None, "local L1 error per adaptive BDF2 step", "float",
                               lo=1e-14, hi=1.0, modes=T,
                               auto="3e-4 when dt is not given (adaptive), else fixed steps")
    progress: bool | None = option(None, "a progress line on stderr (stationary: the 3-D "
                                   "coloured-noise solve)", "bool", modes=("stationary", "transient"),
                                   scene="cli --quiet", auto="when stderr is a terminal")
    discretisation: Any = option(None, "an assembled mesh and operator to reuse", "custom",
                                 check=_discretisation, allowed="a Discretisation", modes=T,
                                 scene="fem.mesh, fem.nx, fem.ny (built from them)",
                                 auto="built from the mesh options")

    @classmethod
    def reduce(cls, mode: str, given: dict[str, Any]) -> dict[str, Any]:
        """As the base, but a given ``rtol`` keeps choosing nx and ny; a reduced
        periodic run has smaller caps
        (:data:`~fpk_vibro.fem.periodic_options.REDUCED`: each harmonic is a
        stationary-sized solve), not an rtol."""
        out = super().reduce(mode, given)
        if given.get("rtol") is not None and mode != "periodic":
            # rtol picks the grid: a cap on a size not given would clash with it
            for name in ("nx", "ny"):
                if given.get(name) is None:
                    out.pop(name, None)
        if mode == "periodic":
            out.pop("rtol", None)
            out.update({k: min(out.get(k) or cap, cap) for k, cap in REDUCED.items()})
        return out

    # -- rules joining options ----------------------------------------------------
    def validate_for(self, system: VibroImpactSystem, mode: str, *, probe: bool = False) -> None:
        """Every rule joining the options to each other and to ``system``."""
        where = f"fem.{mode}"
        pos, mesh = self.positivity, self.mesh
        if pos == "auto":       # Galerkin, possibly switched: no rule of its own
            pos = False

        def bad(name: str, msg: str) -> InputError:
            return InputError(f"{where}: {name} {msg}", where=where, name=name)

        if mode == "periodic":           # rules of fem.periodic's own keywords
            validate_periodic(self, system, where)
            return
        if mode == "first_passage":      # a mesh of the safe set, built by the solver
            if self.degree > 2:
                raise invalid(where, "degree", "an integer in [1, 2] (the isoparametric "
                              "mesh of the safe set)", self.degree)
            return

        if mode == "stationary" and self.rtol is not None:
            if self.degree != 1:
                raise bad("degree", "must not be given with rtol (rtol chooses degree 2-4)")
            for name in ("mesh", "nx", "ny"):
                if getattr(self, name) is not None:
                    raise bad(name, "must not be given with rtol (rtol chooses the mesh; "
                              "give one or the other)")
            if self.positivity not in ("auto", False):
                raise bad("positivity", "must not be given with rtol (the adaptive solve "
                          "is Galerkin, degrees 2-4)")
            if self.element != "quad" or self.assembly == "general":
                raise bad("rtol", "needs the structured quadrilateral mesh with tensor "
                          "assembly (element 'quad', assembly 'auto' or 'tensor')")
        if pos and self.degree != 1:
            raise bad("positivity", "needs degree = 1 (Q1/P1 basis functions are "
                      "non-negative; Q2/P2 are not)")
        if mode == "transient" and self.rtol is not None:
            for name in ("mesh", "nx", "ny", "dt", "tol", "discretisation"):
                if getattr(self, name) is not None:
                    raise bad(name, "must not be given with rtol (rtol chooses the mesh "
                              "and the steps; give one or the other)")
            if self._degree_given or pos:
                raise bad("degree" if self._degree_given else "positivity",
                          "must not be given with rtol (the adaptive transient is "
                          "Galerkin, degrees 2-4)")
        if mode == "transient":
            if pos not in (False,) + TENSOR_ONLY:
                raise bad("positivity", f"must be false, true, 'quick', 'van-albada' or "
                          f"'first-order' in a transient; got {pos!r}")
            scheme = self.scheme or ("euler" if pos else "bdf2")
            if pos and not (scheme == "euler" or (scheme == "theta" and self.theta == 1)):
                raise bad("scheme", f"must be 'euler' (or 'theta' with theta = 1) with "
                          f"positivity: BDF2 and θ < 1 do not keep p >= 0; got scheme = "
                          f"{scheme!r}, theta = {self.theta}")
            if self.tol is not None and pos:
                raise bad("tol", "(adaptive BDF2 steps) cannot be combined with positivity "
                          "(implicit Euler, fixed steps)")
            if self.tol is not None and scheme != "bdf2":
                raise bad("tol", f"(adaptive steps) needs scheme = 'bdf2'; got {scheme!r}")
            disc = self.discretisation
            if disc is not None:
                if disc.system != system:
                    raise bad("discretisation", "was built for another system")
                if pos and not {pos, disc.positivity} <= {True, "quick"} \
                        and pos != disc.positivity:
                    raise bad("positivity", f"= {pos!r} differs from the discretisation's "
                              f"({disc.positivity!r}); build it with discretise(..., "
                              "positivity=...)")
                return
        if self.degree > 2 and (mesh is not None or self.element != "quad"
                                or self.assembly == "general"):
            raise bad("degree", f"= {self.degree} needs the structured quadrilateral mesh "
                      "with tensor assembly (no mesh, element = 'quad', assembly 'auto' or "
                      "'tensor'); degree 1 or 2 serve meshes and triangles")
        if mesh is not None:
            for name in ("nx", "ny", "y_max", "wall_grading"):
                if getattr(self, name) is not None:
                    raise bad(name, "must not be given with a mesh (the mesh fixes it)")
            if self.grading != 0.0:
                raise bad("grading", "must not be given with a mesh (the mesh fixes it)")
            if self.assembly == "tensor":
                raise bad("assembly", "= 'tensor' needs the built-in structured mesh "
                          "(no mesh)")
            if pos in TENSOR_ONLY:
                raise bad("positivity", f"= {pos!r} needs the built-in structured "
                          "quadrilateral mesh; use 'auto' or 'upwind' with a mesh")
            m = load_strip_mesh(system, mesh, where)
            reach = float(abs(m.p[1]).max())
            if reach < thermal_velocity(system):
                raise bad("mesh", f"must reach |y| >= the thermal velocity sqrt(D1/λ) = "
                          f"{thermal_velocity(system):.3g} (as y_max must: below it most "
                          f"of the density lies outside the strip); got a mesh with "
                          f"|y| <= {reach:.3g}")
            return
        if self.assembly == "tensor" and self.element != "quad":
            raise bad("assembly", "= 'tensor' needs element = 'quad'")
        if pos in TENSOR_ONLY and (self.element != "quad" or self.assembly == "general"):
            raise bad("positivity", f"= {pos!r} needs element = 'quad' and tensor assembly "
                      "(a tensor grid); use 'auto' or 'upwind' otherwise")
        if self.y_max is None and system.c == 0:
            raise bad("y_max", "must be given when c = 0 (no damping bound on the energy "
                      "tail; all dissipation comes from impacts)")
        if self.y_max is not None:
            v = thermal_velocity(system)
            if self.y_max < v:
                raise bad("y_max", f"must be at least the thermal velocity sqrt(D1/λ) = "
                          f"{v:.3g} (below it most of the density lies outside the strip); "
                          f"got {self.y_max!r}")
        dom, nx, ny = self.grid(system, where)
        if mode == "stationary" and self.y_max is not None and system.c > 0:
            from .mesh import default_y_max
            try:
                tail = default_y_max(system)
            except ValueError:
                tail = math.inf
            h_y = 2.0 * dom.y_max / ny
            if h_y > 2.0 * tail:      # all the density's y-extent inside one cell
                raise bad("y_max", f"must give cells below 2 × {tail:.3g} tall (the default "
                          f"y_max, beyond which the mass is < 1e-8); got 2 y_max/ny = "
                          f"{h_y:.3g} (y_max = {dom.y_max:.3g}, ny = {ny}): measured E[H] "
                          "3.3e8 times the true one at y_max = 1e6")
        if system.c > 0 and system.has_barrier:
            # (rtol and the default choose nx themselves, from the same layers: start_nx)
            layers = self.rtol is None and not uses_ladder(self, mode)
            check_wall_layers(self, system, dom, nx, bad, layers=layers)

    def validate_initial(self, system: VibroImpactSystem, init: Any) -> None:
        """The mean of a Gaussian start must lie inside the truncated strip."""
        if not getattr(init, "is_gaussian", False):
            return
        if self.discretisation is not None or self.mesh is not None:
            p = (self.discretisation.points if self.discretisation is not None
                 else load_strip_mesh(system, self.mesh).p)
            x0, x1, y_max = float(p[0].min()), float(p[0].max()), float(abs(p[1]).max())
        else:          # (a side without a wall, or a wall beyond the support: cut)
            dom = self.grid(system)[0]
            x0, x1, y_max = dom.x0, dom.x1, dom.y_max
        for k, bad in ((1, abs(init.mean[1]) > y_max), (0, not x0 <= init.mean[0] <= x1)):
            if bad:
                strip = f"|y| <= y_max = {y_max:.4g}" if k else f"{x0:.4g} <= x <= {x1:.4g}"
                raise InputError(f"fem.transient: initial mean[{k}] must lie in the truncated "
                                 f"strip {strip}; got {init.mean[k]!r}",
                                 where="fem.transient", name="initial")

    def __post_init__(self) -> None:
        object.__setattr__(self, "_degree_given", self.degree is not None)
        if self.degree is None:            # frozen: resolved once, here
            object.__setattr__(self, "degree", 1 if self.positivity not in (False, "auto") else 2)

    def grid(self, system: VibroImpactSystem, where: str = "fem"):
        """(domain, nx, ny) of the structured mesh these options give on ``system``."""
        from .mesh import domain
        try:
            dom = domain(system, self.y_max)
        except ValueError as exc:
            raise InputError(f"{where}: y_max must be given: {exc}", where=where,
                             name="y_max") from None
        nx = DEFAULT_NX[self.degree] if self.nx is None else self.nx
        ny = self.ny
        if ny is None:
            ratio = (2.0 * dom.y_max) / (dom.x1 - dom.x0) / 1.5
            ny = max(2, 2 * int(round(0.5 * nx * min(ratio, 4.0))))
        return dom, nx, ny

    # -- cost ---------------------------------------------------------------------
    def ndofs(self, system: VibroImpactSystem) -> int:
        if self.discretisation is not None:
            return int(self.discretisation.unit.size)
        if self.mesh is not None:
            mesh = load_strip_mesh(system, self.mesh, "fem")
            cells, verts = mesh.t.shape[1], mesh.p.shape[1]
            return verts if self.degree == 1 else verts + 2 * cells + cells
        _, nx, ny = self.grid(system)
        k = self.degree
        return (k * nx + 1) * (k * ny + 1)

    def _coloured_cost(self, system: VibroImpactSystem, mode: str, times: Any) -> Cost:
        """The 3-D solve (:mod:`fpk_vibro.fem.coloured`): the 2-D factors (one per
        low ζ-mode, shared by the high ones, ~60 at most; ~190 entries of 22 bytes per
        2-D unknown), the Krylov basis, L (~65 entries per row), and seconds from the
        paper case (4·10⁴ unknowns 1.5 s, 1.3·10⁵ 10 s: N^1.6; a transient step ~10
        GMRES iterations)."""
        nx, ny, nz = (d if v is None else v
                      for v, d in zip((self.nx, self.ny, self.nz), COLOURED_GRID[:3]))
        k = 2 if self.degree in (None, 1) else self.degree
        n2 = float((k * nx + 1) * (k * ny + 1))
        nzd = float(k * nz + 1)
        n = n2 * nzd
        memory = 130e6 + min(2 * nzd, 60) * n2 * 190 * 22 + n * 110 * 8 + n * 65 * 12
        seconds = 6.5e-8 * n ** 1.6
        if mode == "transient":
            t_end = float(max(times)) if times is not None and len(times) else 0.0
            from ..scales import period
            steps = t_end / (self.dt if self.dt is not None else period(system) / 20.0)
            seconds += steps * 2.5e-6 * n
        return Cost(memory, n, "unknowns", seconds, "nz")

    def estimate(self, system: VibroImpactSystem, mode: str, times: Any = None) -> Cost:
        """Memory, DOFs × steps and seconds (constants: docs/costs.md); first
        passage: :func:`passage_cost` of one part."""
        if mode == "periodic":
            return periodic_cost(self, system)
        if system.external is not None:
            return self._coloured_cost(system, mode, times)
        if mode == "first_passage":
            nx = PASSAGE_NX if self.nx is None else self.nx
            return passage_cost(system, nx, 2 * nx if self.ny is None else self.ny,
                                self.degree, self.n_steps)
        if uses_ladder(self, mode):        # the rtol ladder, not one solve
            return ladder_cost(system, self)
        n = float(self.ndofs(system))
        fill = 2200.0 if self.degree == 1 else 3000.0
        lu = n * fill * max(1.0, math.log2(max(n, 2.0)) / 17.0)
        factor_s = (3.4e-7 if self.degree == 1 else 6.5e-7) * n ** 1.3
        if self.mesh is not None or self.element == "tri" or self.assembly == "general":
            factor_s *= 3.0
        key = "mesh" if self.mesh is not None else "nx"
        if mode == "stationary":
            iterations = {"quick": 20, True: 20, "van-albada": 20, "afc": 10}.get(
                self.positivity, 1)
            seconds = 0.2 + iterations * factor_s
            # 130 MB: the interpreter with skfem/scipy and the moments' quadrature
            # (peak RSS 150 MiB at 6 k DOFs, 2 × 2000 cells; 776 MiB at 1e5 × 2)
            return Cost(130e6 + lu, n, "DOFs", seconds, key)
        from ..scales import period
        t_end = float(max(times)) if times is not None and len(times) else 0.0
        dt = self.dt if self.dt is not None else period(system) / 20.0
        pos = False if self.positivity == "auto" else self.positivity   # Galerkin
        adaptive = self.tol is not None or (self.dt is None and not pos
                                            and (self.scheme in (None, "bdf2")))
        steps = t_end / dt + (len(times) if times is not None else 0)
        if adaptive:
            steps = 1500.0 + 20.0 * t_end / dt
        per_step = 3e-7 * n * (4.0 if pos not in (False, "first-order") else 1.0)
        if pos not in (False, "first-order"):
            per_step += factor_s        # a new factorisation each step
        copies = 25.0 if adaptive else 3.0
        key = "times" if t_end / dt > 1e7 else key
        return Cost(80e6 + copies * lu, n * steps, "DOF-steps",
                    0.2 + 10 * factor_s + steps * per_step, key)


def passage_cost(system: VibroImpactSystem, nx: int, ny: int, degree: int, n_steps: int,
                 parts: int = 1) -> Cost:
    """Memory and time of a first passage: the stationary cost model (general
    assembly) for one factorisation per part, two factors alive at once in the
    reliability march (five in all) and at most 8 n_steps steps of two triangular
    solves."""
    one = Options(nx=nx, ny=ny, degree=degree, positivity=False,
                  assembly="general").estimate(system, "stationary")
    n = float((degree * nx + 1) * (degree * ny + 1))
    lu, factor_s = one.memory - 80e6, one.seconds - 0.2
    steps = 8.0 * n_steps
    return Cost(80e6 + 2.0 * lu, parts * n * steps, "DOF-steps",
                0.2 + parts * (5.0 * factor_s + steps * 2.0 * 3e-7 * n), "nx")
