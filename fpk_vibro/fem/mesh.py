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
energy, so it is conservative there.  ``c = 0`` (all dissipation from impacts)
has no such bound: ``y_max`` must then be given.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import skfem
from .. import scales
from ..model import VibroImpactSystem
from ..scales import TAIL_MASS

__all__ = ["StripEnd", "Domain", "domain", "default_y_max", "axis_nodes", "wall_nodes",
           "structured_mesh", "load_mesh", "wall_restitutions", "TAIL_MASS"]


@dataclass(frozen=True)
class StripEnd:
    """An end x = ``x`` of the strip with restitution ``r``; ``side`` is +1 (right)
    or −1 (left): a wall of the system (:class:`fpk_vibro.model.Wall`, its ``r``) or
    the elastic end (r = 1) of a truncated side.

    Its outflow half is ``side · y > 0`` (docs/theory.md, §Impact coupling).
    """
    x: float
    r: float
    side: int


@dataclass(frozen=True)
class Domain:
    """The strip ``x0 < x < x1``, ``|y| < y_max`` with a wall at each x end."""
    x0: float
    x1: float
    y_max: float
    walls: tuple[StripEnd, StripEnd]


def default_y_max(system: VibroImpactSystem) -> float:
    """The default |y| truncation (module docstring).

    Raises
    ------
    ValueError
        If ``c == 0`` (no tail bound): ``y_max`` must be given.
    """
    return domain(system).y_max


def domain(system: VibroImpactSystem, y_max: float | None = None) -> Domain:
    """The truncated strip and its two walls for ``system`` (module docstring)."""
    lo, hi = system.x_bounds
    if y_max is None or math.isinf(lo) or math.isinf(hi):
        try:
            H_t = scales.tail_energy(system, TAIL_MASS)
        except ValueError:
            if y_max is None:
                raise
            H_t = scales.potential_min(system) + 0.5 * y_max * y_max
        X = float(scales.reach(system, H_t))
        lo, hi = max(lo, -X), min(hi, X)
        if y_max is None:
            y_max = math.sqrt(2.0 * (H_t - scales.potential_min(system)))
    rl, rr = wall_restitutions(system)
    return Domain(lo, hi, float(y_max), (StripEnd(lo, rl, -1), StripEnd(hi, rr, +1)))


def wall_restitutions(system: VibroImpactSystem) -> tuple[float, float]:
    """(r_L, r_R) of the strip's ends: each wall's own r, 1 on a truncated side."""
    return tuple(1.0 if w is None else w.r for w in (system.left, system.right))


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
    """``n + 1`` x-nodes on [x0, x1], clustered toward each wall with r < 1.

    Near such a wall the node spacing grows like the distance to it raised to
    1 − 1/``power`` (x_w − x ∝ s^power in the uniform parameter s; ``power`` = 1 is
    uniform, as is every end with r = 1).  Why: the density is singular at the
    corners (x_w, 0) of an inelastic wall (docs/fem_hard_cases.md, §Corner
    exponent); a graded mesh keeps the corner error from setting the convergence
    rate of the whole strip (measured in docs/measurements.md, §FE error estimate
    and rtol).
    """
    s = np.linspace(0.0, 1.0, n + 1)
    left, right = (w.r < 1.0 and power != 1.0 for w in dom.walls)
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
