"""Quadrature over the orbits of the unperturbed vibro-impact oscillator, for any walls.

Orbit structure
---------------
The strip is x_L < x < x_R (x_L = −∞ or x_R = +∞ where there is no wall).  An
orbit of energy H is the set {x in the strip: G(x) < H}, run through with speed
|y| = sqrt(2H − 2G(x)) and reflected at the walls.  Averaging needs this set to be
one interval for every H; here it is required that G increase with |x| on the strip
(x G'(x) = x²(a + b x²) > 0 for x ≠ 0 in the strip), which covers

- the single well (a ≥ 0, b ≥ 0, not both 0) with any walls;
- the softening spring (a > 0 > b) with both walls inside ±sqrt(−a/b);
- strips that do not contain the minimum x = 0 of G ("preload": e.g. a right wall
  at x_R < 0 and no left wall, or both walls on one side), also of a double well
  (a < 0 < b) as long as the strip stays outside its hump, a + b x² > 0.

Then G(A) = H has one root A(H) > 0 on the increasing branch (the outer root for
a < 0) and the orbit is

    (x_lo, x_hi) = (max(−A, x_L), min(A, x_R)),

empty for H below the strip's floor min G.  If the strip contains 0 the floor is
G(0) = 0 and every orbit contains 0; otherwise the floor is G at the wall nearest
to 0 and every orbit runs from a turning point (or the far wall) to that wall.
Where G has a local maximum inside the strip (a double well with x = 0 inside, a
softening spring with a wall beyond its hilltop) energies just below the maximum
have two separate orbits, and averaging does not apply (:func:`require_single_well`).

Because G and the noise intensity D1 + D2 x² are even in x and every averaged
integrand depends on x only through them and |y|, an orbit integral over
[x_lo, x_hi] is I(x_hi) − I(x_lo) with I(u) = ∫₀ᵘ, odd in u: an asymmetric orbit is
two "half" orbits I(x_hi) + I(−x_lo), and a preloaded one is a difference of two
half orbits on the same side.  Both are computed without cancellation through one
substitution x = A sin θ, which maps any θ ∈ [θ_lo, θ_hi] ⊂ [−π/2, π/2] onto
[x_lo, x_hi], θ = ±π/2 at a turning point and θ = arcsin(x_w/A) at a wall.  With

    2H − 2G(x) = (A² − x²)(a + b(A² + x²)/2)

the integral ∫ g dx/|y| becomes ∫ g / w(θ) dθ, w = sqrt(a + b A²(1 + sin²θ)/2),
smooth on [θ_lo, θ_hi], which Gauss–Legendre integrates to machine precision with
a few dozen nodes.  For a softening spring (b < 0) above the potential's maximum no
amplitude exists; the orbit then spans the strip with |y| bounded away from zero
and plain Gauss–Legendre in x is used.
"""
from __future__ import annotations

import math

import numpy as np

from .model import VibroImpactSystem

__all__ = ["OrbitNodes", "orbit_nodes", "single_well", "require_single_well", "energy_loss",
           "energy_floor", "wall_energies", "energy_loss_first_order", "why_not_single_well",
           "wall_loss"]


class OrbitNodes:
    """Nodes and weights of one traversal for each energy: ``Σ w g(x, v)`` ≈ ∫ g dx/|y|.

    Attributes ``x``, ``v`` (= |y|) and ``w`` have shape ``H.shape + (n,)``.
    """

    __slots__ = ("x", "v", "w")

    def __init__(self, x: np.ndarray, v: np.ndarray, w: np.ndarray) -> None:
        self.x, self.v, self.w = x, v, w

    def integrate(self, values: np.ndarray) -> np.ndarray:
        """∫ g dx/|y| for g given at the nodes (shape ``H.shape + (n,)``)."""
        return np.sum(self.w * values, axis=-1)

    @property
    def period(self) -> np.ndarray:
        """T(H) = 2 ∫ dx/|y| (paper Eq. 6, 14): both velocity branches."""
        return 2.0 * np.sum(self.w, axis=-1)


def _strip_x2(system: VibroImpactSystem) -> tuple[float, float]:
    """(inf, sup) of x² over the strip; inf = 0 when the strip contains 0."""
    lo, hi = system.x_bounds
    if lo <= 0.0 <= hi:
        return 0.0, max(lo * lo, hi * hi)
    near, far = sorted((abs(lo), abs(hi)))
    return near * near, far * far


def why_not_single_well(system: VibroImpactSystem) -> str | None:
    """Why averaging does not apply to ``system`` (one line), or None when it does.

    It applies when G increases with |x| on the strip (module docstring): then each
    energy level's orbit is one interval, given by the root A(H) of G(A) = H.
    """
    a, b = system.a, system.b
    lo, hi = system.x_bounds
    if a == 0 and b == 0:
        return "G ≡ 0 (a free particle between the walls) has no amplitude to parametrise"
    maxima = [0.0] if (a < 0 or (a == 0 and b < 0)) else []
    if a > 0 > b:
        maxima += [-math.sqrt(-a / b), math.sqrt(-a / b)]
    inside = [x for x in maxima if lo < x < hi]
    if inside:
        where = ", ".join(f"{x:.6g}" for x in inside)
        return (f"G has a local maximum at x = {where} inside the strip, so energies just "
                f"below it have two separate orbits (one on each side)")
    q_in, q_out = _strip_x2(system)
    inner_ok = a >= 0 if q_in == 0 else a + b * q_in > 0
    outer_ok = (b > 0 or (b == 0 and a > 0)) if math.isinf(q_out) else a + b * q_out > 0
    if not (inner_ok and outer_ok):
        return ("G decreases with |x| on part of the strip (a well away from x = 0, or a "
                "strip beyond the hilltop of a softening spring), so its orbits do not end "
                "on the increasing branch G(A) = H that averaging parametrises")
    return None


def single_well(system: VibroImpactSystem) -> bool:
    """True when G increases with |x| on the strip: one orbit per energy level."""
    return why_not_single_well(system) is None


def require_single_well(system: VibroImpactSystem, method: str = "averaging") -> None:
    """Raise ``ValueError`` (one line, naming the reason) unless G increases with |x|
    on the strip, i.e. each energy level has one orbit (module docstring)."""
    why = why_not_single_well(system)
    if why is not None:
        lo, hi = system.x_bounds
        raise ValueError(
            f"{method} needs the potential G(x) = a x²/2 + b x⁴/4 increasing in |x| on the "
            f"strip ({lo:g}, {hi:g}) (one orbit per energy level); a={system.a}, "
            f"b={system.b}: {why}. Use fpk_vibro.fem or fpk_vibro.montecarlo for this system.")


def energy_floor(system: VibroImpactSystem) -> float:
    """The lowest energy on the strip: 0 when the strip contains x = 0, else G at the
    wall nearest to 0 (the orbits of a preloaded strip start there)."""
    lo, hi = system.x_bounds
    if lo <= 0.0 <= hi:
        return 0.0
    return float(system.potential(hi if hi < 0 else lo))


def wall_energies(system: VibroImpactSystem) -> np.ndarray:
    """The distinct wall energies G(x_w), increasing: where the orbits start to hit a
    wall (the kinks of p(H)).  Empty without walls."""
    return np.unique([float(system.potential(w.position)) for _, w in system.walls])


def wall_loss(system: VibroImpactSystem, wall, H: np.ndarray) -> np.ndarray:
    """Energy one impact on ``wall`` takes from the orbit of energy ``H``:
    (1 − r(u)²)(H − G(x_w)) at u = sqrt(2 (H − G(x_w))), the wall's law
    (:meth:`fpk_vibro.wall.Wall.loss`); 0 where the orbit does not reach the wall.
    For a constant r (a number, or a law constant in u) this is (1 − r²)(H − G(x_w))
    as computed before laws existed (r is then exact, so the result is too)."""
    K = np.maximum(np.asarray(H, dtype=float) - float(system.potential(wall.position)), 0.0)
    r = wall.r_at(np.sqrt(2.0 * K))
    return (1.0 - r * r) * K


def _first_order(system: VibroImpactSystem, H: np.ndarray) -> list[np.ndarray]:
    """(1 − r_w(u_w)²) max(H − G(x_w), 0) for each wall: the loss at a first impact."""
    return [wall_loss(system, w, H) for _, w in system.walls]


def energy_loss_first_order(system: VibroImpactSystem, H: np.ndarray) -> np.ndarray:
    """Σ_w (1 − r_w(u_w)²)(H − G(x_w)) over the walls with G(x_w) < H.

    The loss per quasi-period to first order in 1 − r: each impact takes the share
    1 − r_w(u_w)² of the kinetic energy H − G(x_w) at the wall (u_w its speed).
    :func:`energy_loss` compounds the impacts instead; the two agree to first order
    in 1 − r.
    """
    H = np.asarray(H, dtype=float)
    return sum(_first_order(system, H), np.zeros_like(H))


def energy_loss(system: VibroImpactSystem, H: np.ndarray) -> np.ndarray:
    """Energy lost to impacts in one quasi-period, δ(H) (paper Eq. 13), impacts compounded.

    One wall: (1 − r(u)²)(H − G(x_w)), u = sqrt(2 (H − G(x_w))) the impact speed
    (:func:`wall_loss`; r(u) the wall's law, a constant for a number).  Two walls,
    hit in the order 1 then 2: the first impact leaves H' = H − d₁(H), and the second
    takes d₂(H') (zero if H' < G₂):

        δ₁₂ = d₁(H) + d₂(H − d₁(H)),   d_w(H) = (1 − r_w(u_w)²)(H − G_w)⁺.

    A quasi-period starting at a random phase of the orbit meets the right wall
    first half of the time (the two velocity branches take equal times), so
    δ = (δ_RL + δ_LR)/2.  The orders differ by (1 − r_L²)(1 − r_R²)(G_R − G_L)
    when both walls are hit, a second-order term; so does the first-order sum of
    :func:`energy_loss_first_order`.  Walls at ±Δ with one number r give exactly the
    paper's (1 − r⁴)(H − G(Δ)) (computed by that formula, bit for bit; a law constant
    in u gives it to rounding), one wall (1 − r²)(H − G(x_w)); zero below the wall
    energies or without walls.
    """
    H = np.asarray(H, dtype=float)
    if not system.has_barrier:
        return np.zeros_like(H)
    numbers = all(w.law is None for _, w in system.walls)
    if numbers and (system.symmetric or len(system.walls) == 1):
        r2 = system.r ** 2
        factor = 1.0 - r2 * r2 if system.barriers == "both" else 1.0 - r2
        return factor * np.maximum(H - system.barrier_energy, 0.0)
    if len(system.walls) == 1:
        return wall_loss(system, system.walls[0][1], H)
    (_, w1), (_, w2) = system.walls
    d1, d2 = wall_loss(system, w1, H), wall_loss(system, w2, H)
    return 0.5 * (d1 + wall_loss(system, w2, H - d1) + d2 + wall_loss(system, w1, H - d2))


def _theta_limit(bound: float, A: np.ndarray) -> np.ndarray:
    """arcsin(bound/A) clipped to [−π/2, π/2]; its limit sign(bound) π/2 at A = 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.where(A > 0, bound / A, np.sign(bound))
    return np.arcsin(np.clip(q, -1.0, 1.0))


def orbit_nodes(system: VibroImpactSystem, H: np.ndarray, n: int = 48) -> OrbitNodes:
    """Gauss–Legendre nodes along one traversal of the orbit of energy ``H``.

    Parameters
    ----------
    system : VibroImpactSystem
        Must satisfy :func:`require_single_well`.
    H : array_like
        Energies; below :func:`energy_floor` the orbit is empty (all weights 0).
    n : int
        Nodes per orbit.  With n = 48 the orbit integrals agree with adaptive
        ``scipy.integrate.quad`` to ~1e-13 relative (see tests).

    Returns
    -------
    OrbitNodes
        Nodes and weights on θ ∈ [θ_lo, θ_hi] (module docstring) for each energy.
    """
    H = np.asarray(H, dtype=float)
    t, gw = np.polynomial.legendre.leggauss(n)
    lo, hi = system.x_bounds
    A = system.amplitude(np.maximum(H, min(0.0, energy_floor(system))))[..., None]
    has_A = np.isfinite(A)
    A_safe = np.where(has_A, A, 0.0)
    th_hi = _theta_limit(hi, A_safe)             # π/2 where A ≤ x_R: a turning point
    th_lo = -_theta_limit(-lo, A_safe)
    th_hi = np.maximum(th_hi, th_lo)             # below the floor: an empty orbit
    mid, half = 0.5 * (th_hi + th_lo), 0.5 * (th_hi - th_lo)
    theta = mid + half * t
    s = np.sin(theta)
    w_theta = np.sqrt(system.a + 0.5 * system.b * A_safe ** 2 * (1.0 + s * s))
    x = A_safe * s
    v = A_safe * np.cos(theta) * w_theta
    w = half * gw / w_theta
    if not np.all(has_A):
        # softening spring above max G: no turning point inside the strip
        xg = 0.5 * (hi + lo) + 0.5 * (hi - lo) * t
        Hb = np.broadcast_to(H[..., None], x.shape)
        vg = np.sqrt(np.maximum(2.0 * Hb - 2.0 * system.potential(xg), 0.0))
        with np.errstate(divide="ignore"):
            wg = 0.5 * (hi - lo) * gw / vg
        mask = np.broadcast_to(~has_A, x.shape)
        x = np.where(mask, xg, x)
        v = np.where(mask, vg, v)
        w = np.where(mask, wg, w)
    return OrbitNodes(x, v, w)
