"""Domain and meshes of the strip (docs/theory.md, §FPK on the strip).

The FPK is posed on the strip ``xL < x < xR``, ``|y| < Y``.  Each end
``x = xL`` / ``x = xR`` is a *wall* with a restitution coefficient: a wall of the
system (``system.left`` / ``system.right``) carries its own ``r``; on a side without
a wall the strip is truncated at ``|x| = X`` with negligible mass beyond and an
elastic wall (r = 1) is put there, which conserves mass (docs/theory.md, §Walls).

Default truncation (used when ``y_max`` is not given): the energy H_t above which
the tail bound of :mod:`fpk_vibro.scales` holds less than ``TAIL_MASS`` (1e-8):
``y_max = sqrt(2 (H_t − min G))`` and, on a side without barrier, the strip ends
where G = H_t.  For r = 1, D2 = 0 this is the exact Gibbs tail; r < 1 only removes
energy, so it is conservative there; a law r(u) is bounded by its largest r.  ``c = 0`` (all dissipation from impacts)
has no such bound: ``y_max`` must then be given.

A wall beyond that cut (|x_w| past the reach of H_t, where the density holds less
than ``TAIL_MASS``; with ``c = 0`` the reach of min G + y_max²/2, as on a side
without a wall) is treated as no wall is: the strip ends at the cut with an
elastic end (r = 1; the paths that would reach the wall are reflected there, which
keeps mass and removes no energy, as the potential turns them back before it), and
``Domain.beyond`` says so (``sol.info["walls_beyond_support"]``).  Its impacts are
negligible (fewer than the tail mass); meshing up to it put nearly every cell where
the density is zero (walls at −0.6 and 50: E[H] 1.9e5 instead of 0.209).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import skfem
from .. import scales
from ..model import VibroImpactSystem
from ..restitution import Restitution
from ..scales import TAIL_MASS
from .rebound import is_elastic, preimage, rebound

__all__ = ["StripEnd", "Domain", "domain", "default_y_max", "axis_nodes", "wall_nodes",
           "structured_mesh", "load_mesh", "wall_restitutions", "beyond_support",
           "ends_at_wall", "thermal_velocity", "TAIL_MASS"]


@dataclass(frozen=True)
class StripEnd:
    """An end x = ``x`` of the strip with restitution ``r``; ``side`` is +1 (right)
    or −1 (left): a wall of the system (:class:`fpk_vibro.model.Wall`, its ``r``: a
    number or a law r(u) of the impact speed) or the elastic end (r = 1) of a
    truncated side.

    Its outflow half is ``side · y > 0`` (docs/theory.md, §Impact coupling); an
    outgoing speed u re-enters at speed :meth:`rebound` φ(u) = u r(u).
    """
    x: float
    r: "float | Restitution"
    side: int

    @property
    def elastic(self) -> bool:
        """True when r ≡ 1 (no impact loses energy)."""
        return is_elastic(self.r)

    def rebound(self, u: np.ndarray) -> np.ndarray:
        """φ(u) = u r(u), the speed after an impact at speed ``u`` ≥ 0."""
        return rebound(self.r, u)

    def preimage(self, w: np.ndarray, u_max: float) -> np.ndarray:
        """The impact speeds u ≤ ``u_max`` with φ(u) = ``w``
        (:func:`fpk_vibro.fem.rebound.preimage`)."""
        return preimage(self.r, w, u_max)


@dataclass(frozen=True)
class Domain:
    """The strip ``x0 < x < x1``, ``|y| < y_max`` with a wall at each x end;
    ``beyond``: a note per wall of the system beyond the density's support (module
    docstring), whose end is the elastic cut instead."""
    x0: float
    x1: float
    y_max: float
    walls: tuple[StripEnd, StripEnd]
    beyond: tuple[str, ...] = ()


def default_y_max(system: VibroImpactSystem) -> float:
    """The default |y| truncation (module docstring).

    Raises
    ------
    ValueError
        If ``c == 0`` (no tail bound): ``y_max`` must be given.
    """
    return domain(system).y_max


def domain(system: VibroImpactSystem, y_max: float | None = None) -> Domain:
    """The truncated strip and its two walls for ``system`` (module docstring): the
    same x-extent whether ``y_max`` is given or not."""
    return _domain(system, None if y_max is None else float(y_max))


@functools.lru_cache(maxsize=64)
def _domain(system: VibroImpactSystem, y_max: float | None) -> Domain:
    lo, hi = system.x_bounds
    (rl, rr), beyond = wall_restitutions(system), []
    try:
        H_t: float | None = scales.tail_energy(_least_loss(system), TAIL_MASS)
    except ValueError:          # c = 0, or a tail that does not decay: y_max's energy
        if y_max is None:
            raise
        H_t = scales.potential_min(system) + 0.5 * y_max * y_max
    if H_t is not None:
        X = float(scales.reach(system, H_t))
        if lo < -X:
            lo, rl = -X, 1.0
            beyond += _beyond_note(system.left, "left", lo, X)
        if hi > X:
            hi, rr = X, 1.0
            beyond += _beyond_note(system.right, "right", hi, X)
        if y_max is None:
            y_max = math.sqrt(2.0 * (H_t - scales.potential_min(system)))
    return Domain(lo, hi, float(y_max), (StripEnd(lo, rl, -1), StripEnd(hi, rr, +1)),
                  tuple(beyond))


def _least_loss(system: VibroImpactSystem) -> VibroImpactSystem:
    """``system`` with each wall's law r(u) replaced by its largest r: the least loss
    per impact, so a tail bound of it bounds the law's tail too (the strip can only
    be wider)."""
    laws = {f"{side}.r": w.r_bounds()[1] for side, w in system.walls if w.law is not None}
    return system.replace(**laws) if laws else system


def _beyond_note(wall, side: str, cut: float, X: float) -> list[str]:
    """The note on a wall beyond the cut (none for a side without a wall)."""
    if wall is None:
        return []
    return [f"the {side} wall x = {wall.position:g} lies beyond the density's support "
            f"(all but {TAIL_MASS:g} of the mass within |x| <= {X:.4g}): the strip ends at "
            f"x = {cut:.4g} with an elastic end, as without that wall; its impacts are "
            "negligible"]


def beyond_support(system: VibroImpactSystem, side: str) -> float | None:
    """Where the strip is cut on ``side`` when its wall lies beyond the density's
    support (module docstring); None when the wall bounds the strip itself (or the
    system has no tail bound, c = 0)."""
    try:
        dom = domain(system)
    except ValueError:
        return None
    wall = getattr(system, side)
    cut = dom.x0 if side == "left" else dom.x1
    return cut if wall is not None and cut != wall.position else None


def ends_at_wall(system: VibroImpactSystem, side: str, edge: float, tol: float) -> bool:
    """Whether a strip whose ``side`` end is ``edge`` ends where ``system`` says: at
    its wall there (within ``tol``), or between the cut and a wall beyond the
    density's support (:func:`beyond_support`); a side without a wall: anywhere."""
    wall = getattr(system, side)
    if wall is None or abs(edge - wall.position) <= tol:
        return True
    cut, sign = beyond_support(system, side), (-1.0 if side == "left" else 1.0)
    return cut is not None and sign * (edge - cut) >= -tol and sign * (wall.position - edge) > 0


def thermal_velocity(system: VibroImpactSystem) -> float:
    """The least |y| extent of a truncated strip (``y_max`` or a mesh): sqrt(D1/λ)
    (:func:`fpk_vibro.scales.energy_scale`), at most the default ``y_max``, whose
    tail rule knows the impacts' loss (c = 1e-4 with walls of r = 0.5 at ±0.6 has
    sqrt(D1/c) = 10 but E[y²] = 0.26 and the default y_max 1.52, which was refused
    when given)."""
    v = math.sqrt(scales.energy_scale(system))
    try:
        return min(v, default_y_max(system))
    except ValueError:         # c = 0: no tail rule
        return v


def wall_restitutions(system: VibroImpactSystem) -> tuple:
    """(r_L, r_R) of the strip's ends: each wall's own r (a number, or its law r(u);
    a law constant in u as that number, so that it is the number bit for bit), 1 on a
    truncated side."""
    def one(w):
        if w is None:
            return 1.0
        law = getattr(w, "law", None)
        if law is None:
            return w.r
        return float(law.constant) if law.constant is not None else law
    return tuple(one(w) for w in (system.left, system.right))


def axis_nodes(lo: float, hi: float, n: int, grading: float = 0.0,
               centre: float | None = None) -> np.ndarray:
    """``n + 1`` nodes on [lo, hi]; with ``grading > 0`` clustered at ``centre``.

    The map is ξ ↦ centre + s·sinh(g ξ)/sinh(g) on each side of ``centre``
    (uniform for g = 0).  ``centre`` (if given) is always a node, so y = 0 stays a
    mesh line (docs/theory.md, §Assembly and solve); ``n`` must then be even.
    """
    if centre is None:
        xi = np.linspace(-1.0, 1.0, n + 1)
        s = np.sinh(grading * xi) / math.sinh(grading) if grading > 0 else xi
        return 0.5 * (lo + hi) + 0.5 * (hi - lo) * s
    half = n // 2
    xi = np.linspace(0.0, 1.0, half + 1)
    s = np.sinh(grading * xi) / math.sinh(grading) if grading > 0 else xi
    left = centre - (centre - lo) * s[::-1]
    right = centre + (hi - centre) * s
    out = np.concatenate([left, right[1:]])
    out[0], out[-1], out[half] = lo, hi, centre
    return out


def wall_nodes(dom: Domain, n: int, power: float = 1.0) -> np.ndarray:
    """``n + 1`` x-nodes on [x0, x1], clustered toward each inelastic wall (r < 1, or a law
    r(u) not ≡ 1).

    Near such a wall the node spacing grows like the distance to it raised to
    1 − 1/``power`` (x_w − x ∝ s^power in the uniform parameter s; ``power`` = 1 is
    uniform, as is every end with r = 1).  Why: the density is singular at the
    corners (x_w, 0) of an inelastic wall (docs/fem_hard_cases.md, §Corner
    exponent); a graded mesh keeps the corner error from setting the convergence
    rate of the whole strip (measured in docs/measurements.md, §FE error estimate
    and rtol).
    """
    s = np.linspace(0.0, 1.0, n + 1)
    left, right = (not w.elastic and power != 1.0 for w in dom.walls)
    if left and right:
        xi = 2.0 * s - 1.0
        u = 0.5 + 0.5 * np.sign(xi) * (1.0 - (1.0 - np.abs(xi)) ** power)
    elif right:
        u = 1.0 - (1.0 - s) ** power
    elif left:
        u = s ** power
    else:
        u = s
    out = dom.x0 + (dom.x1 - dom.x0) * u
    out[0], out[-1] = dom.x0, dom.x1
    return out


def structured_mesh(dom: Domain, nx: int, ny: int, *, kind: str = "quad",
                    grading: float = 0.0, wall_grading: float = 1.0
                    ) -> tuple[skfem.Mesh, np.ndarray, np.ndarray]:
    """Tensor-product mesh of the strip: ``nx × ny`` cells, y = 0 a mesh line.

    Parameters
    ----------
    dom : Domain
    nx, ny : int
        Cells in x and y (``ny`` even).
    kind : {"quad", "tri"}
        Quadrilaterals, or each quadrilateral split into two triangles.
    grading : float
        ≥ 0; clusters the y-nodes towards y = 0 (see :func:`axis_nodes`).
    wall_grading : float
        ≥ 1; clusters the x-nodes toward each wall with r < 1 (see :func:`wall_nodes`).

    Returns
    -------
    mesh, xnodes, ynodes
    """
    xs = wall_nodes(dom, nx, wall_grading)
    ys = axis_nodes(-dom.y_max, dom.y_max, ny, grading, centre=0.0)
    m = skfem.MeshQuad.init_tensor(xs, ys)
    if kind == "tri":
        m = m.to_meshtri()
    return m, xs, ys


def load_mesh(path: str | Path) -> skfem.Mesh:
    """Read a strip mesh (any format meshio reads) with :meth:`skfem.Mesh.load`."""
    return skfem.Mesh.load(str(path))
