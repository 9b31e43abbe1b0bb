"""Domain and meshes of the strip (DESIGN §3).

The FPK of DESIGN §3 is posed on the strip ``xL < x < xR``, ``|y| < Y``.  Each end
``x = xL`` / ``x = xR`` is a *wall* with a restitution coefficient: the barriers at
``±Δ`` carry the system's ``r``; where the system has no barrier (unilateral or no
barrier) the strip is truncated at ``|x| = X`` with negligible mass beyond and an
elastic wall (r = 1) is put there, which conserves mass (DESIGN §3, last line).

Default truncation rule (documented, used when ``y_max`` is not given)
---------------------------------------------------------------------
For r = 1, D2 = 0 the density is exactly Gibbs, p ∝ exp(−H/T) with T = D1/c, so
y is N(0, T) independently of x and P(|y| > Y) = erfc(Y / sqrt(2T)).  The default
is ``Y = sqrt(2 T) · erfcinv(1e-8)`` with the *largest* local temperature on the
strip, ``T = max_x (D1 + D2 x²) / c``.  Restitution r < 1 only removes energy, so
the rule is conservative there.  The same bound on x (``G(X) = T · ln(1e9)``)
gives the truncation of a side without barrier.  ``c = 0`` (all dissipation from
impacts) has no such bound: ``y_max`` must then be given.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import skfem
from scipy.special import erfcinv

from ..model import VibroImpactSystem

__all__ = ["Wall", "Domain", "domain", "default_y_max", "axis_nodes",
           "structured_mesh", "load_mesh", "TAIL_MASS"]

#: Mass allowed beyond the truncation |y| = Y (and |x| = X without barrier).
TAIL_MASS = 1e-8


@dataclass(frozen=True)
class Wall:
    """A wall x = ``x`` with restitution ``r``; ``side`` is +1 (right) or −1 (left).

    Its outflow half is ``side · y > 0`` (DESIGN §3, B±).
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
    walls: tuple[Wall, Wall]


def _temperature(system: VibroImpactSystem, xmax: float) -> float:
    return (system.D1 + system.D2 * xmax * xmax) / system.c


def _x_truncation(system: VibroImpactSystem) -> float:
    """|X| with G(X) = T ln(1e9), T at X (fixed point); see module docstring."""
    X = 1.0
    for _ in range(200):
        H = _temperature(system, X) * math.log(1.0 / (0.1 * TAIL_MASS))
        Xn = float(system.amplitude(H))
        if not math.isfinite(Xn):
            break
        if abs(Xn - X) <= 1e-10 * Xn:
            return Xn
        X = Xn
    raise ValueError(f"D2={system.D2}: the parametric noise is too strong for the "
                     "default truncation of the unbounded side (no fixed point of the "
                     "Gibbs tail bound); give a mesh covering the support instead")


def default_y_max(system: VibroImpactSystem, x_extent: float | None = None) -> float:
    """Default |y| truncation: ``sqrt(2 T) erfcinv(TAIL_MASS)`` (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
    x_extent : float, optional
        max |x| over the strip (default: from the domain rule).

    Raises
    ------
    ValueError
        If ``c == 0`` (no Gibbs bound): ``y_max`` must be given.
    """
    if system.c == 0:
        raise ValueError("y_max must be given when c = 0 (no Gibbs tail bound; "
                         "all dissipation comes from impacts)")
    if x_extent is None:
        lo, hi = _x_limits(system)
        x_extent = max(abs(lo), abs(hi))
    T = _temperature(system, x_extent)
    return float(math.sqrt(2.0 * T) * erfcinv(TAIL_MASS))


def _x_limits(system: VibroImpactSystem) -> tuple[float, float]:
    lo, hi = system.x_bounds
    if math.isinf(lo) or math.isinf(hi):
        X = _x_truncation(system)
        lo = -X if math.isinf(lo) else lo
        hi = X if math.isinf(hi) else hi
    return lo, hi


def averaged_energy_cut(system: VibroImpactSystem) -> float | None:
    """Energy H_t with P(H > H_t) < TAIL_MASS under the averaged stationary density.

    None where averaging does not apply (G not increasing on (0, Δ)).  Averaging
    over-estimates the energy for r < 1 (it spreads impact losses over the orbit),
    so the cut is conservative; unlike the Gibbs bound it stays tight with
    parametric noise on a side without barrier.
    """
    from ..averaging import stationary
    try:
        sol = stationary(system)
    except ValueError:
        return None
    H = np.linspace(0.0, sol.H_end, 20001)
    p = sol.pdf_energy(H)
    tail = np.concatenate([np.cumsum(0.5 * (p[1:] + p[:-1])[::-1] * np.diff(H))[::-1], [0.0]])
    return float(H[np.argmax(tail < TAIL_MASS)])


def domain(system: VibroImpactSystem, y_max: float | None = None) -> Domain:
    """The truncated strip and its two walls for ``system`` (module docstring).

    Default truncation: the averaged tail (:func:`averaged_energy_cut`) where
    averaging applies — y_max = sqrt(2 H_t), and G(X) = H_t on a side without
    barrier — else the Gibbs-tail rule.
    """
    H_t = averaged_energy_cut(system) if (y_max is None or not system.barriers == "both") else None
    if H_t is not None:
        lo, hi = system.x_bounds
        X = float(system.amplitude(H_t))
        lo, hi = max(lo, -X), min(hi, X)
        if y_max is None:
            y_max = math.sqrt(2.0 * H_t)
        rl = system.r if system.barriers == "both" else 1.0
        rr = system.r if system.has_barrier else 1.0
        return Domain(lo, hi, float(y_max), (Wall(lo, rl, -1), Wall(hi, rr, +1)))
    lo, hi = _x_limits(system)
    if y_max is None:
        y_max = default_y_max(system, max(abs(lo), abs(hi)))
    rl = system.r if system.barriers == "both" else 1.0
    rr = system.r if system.has_barrier else 1.0
    return Domain(lo, hi, float(y_max), (Wall(lo, rl, -1), Wall(hi, rr, +1)))


def axis_nodes(lo: float, hi: float, n: int, grading: float = 0.0,
               centre: float | None = None) -> np.ndarray:
    """``n + 1`` nodes on [lo, hi]; with ``grading > 0`` clustered at ``centre``.

    The map is ξ ↦ centre + s·sinh(g ξ)/sinh(g) on each side of ``centre``
    (uniform for g = 0).  ``centre`` (if given) is always a node, so y = 0 stays a
    mesh line (DESIGN §3); ``n`` must then be even.
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


def structured_mesh(dom: Domain, nx: int, ny: int, *, kind: str = "quad",
                    grading: float = 0.0) -> tuple[skfem.Mesh, np.ndarray, np.ndarray]:
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

    Returns
    -------
    mesh, xnodes, ynodes
    """
    xs = axis_nodes(dom.x0, dom.x1, nx)
    ys = axis_nodes(-dom.y_max, dom.y_max, ny, grading, centre=0.0)
    m = skfem.MeshQuad.init_tensor(xs, ys)
    if kind == "tri":
        m = m.to_meshtri()
    return m, xs, ys


def load_mesh(path: str | Path) -> skfem.Mesh:
    """Read a strip mesh (any format meshio reads) with :meth:`skfem.Mesh.load`."""
    return skfem.Mesh.load(str(path))
