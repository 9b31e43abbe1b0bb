"""The vibro-impact Duffing oscillator shared by every method.

Theory: docs/theory.md, §Model and §Walls.

    x'' + c x' + a x + b x³ = ξ1(t) + x ξ2(t),   x_L < x < x_R
    y⁺ = −r_L y⁻ at x = x_L,   y⁺ = −r_R y⁻ at x = x_R

Either wall may be absent (x_L = −∞ or x_R = +∞); the symmetric shorthand
``delta``, ``r``, ``barriers`` builds walls at ±Δ with one restitution.

with E[ξi(t) ξi(t + τ)] = 2 Di δ(τ).  In Itô form (no Wong–Zakai correction)

    dx = y dt,   dy = −(c y + a x + b x³) dt + sqrt(2 D1 + 2 D2 x²) dW.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._checks import InputError, check_float, invalid
from .option_schema import REQUIRED, Option
from .forcing import Harmonic
from .noise import OrnsteinUhlenbeck
from .restitution import Restitution
from .wall import R_ALLOWED, WALL_FIELDS, Wall

__all__ = ["VibroImpactSystem", "Wall", "Restitution", "BARRIER_KINDS", "FIELDS", "WALL_FIELDS",
           "check_system"]

BARRIER_KINDS = ("both", "right", "left", "none")

#: The model's fields, declared once: validation here, the scene's [system] and
#: [barriers] tables and the key table (docs/guide/keys.md) come from this.
FIELDS: dict[str, Option] = {
    "a": Option(REQUIRED, "linear stiffness", "float", lo=float("-inf"), unit="1/s²",
                scene="system.a"),
    "b": Option(REQUIRED, "cubic stiffness", "float", lo=float("-inf"), unit="1/(m² s²)",
                scene="system.b"),
    "c": Option(REQUIRED, "damping, the paper's ε²c", "float", lo=0.0, unit="1/s",
                scene="system.c"),
    "D1": Option(REQUIRED, "external noise intensity, the paper's ε²D11", "float", lo=0.0,
                 lo_open=True, unit="m²/s³", scene="system.D1",
                 why="without external noise the origin is a noise-free fixed point and "
                     "there is no stationary density"),
    "D2": Option(0.0, "parametric noise intensity, the paper's ε²D22", "float", lo=0.0,
                 unit="1/s³", scene="system.D2"),
    "delta": Option(None, "barrier position Δ; required unless sides = \"none\"", "float",
                    lo=0.0, lo_open=True, unit="m", scene="barriers.delta"),
    "r": Option(1.0, "restitution, y⁺ = −r(|y⁻|) y⁻: a coefficient or a law of the impact "
                "speed", "custom", check=lambda n, v, w: Restitution.of(v, w, n),
                allowed=R_ALLOWED, scene="barriers.r"),
    "barriers": Option("both", "barriers at ±Δ, at +Δ only, at −Δ only, or none",
                       "choice", choices=BARRIER_KINDS, scene="barriers.sides"),
    "left": Option(None, "the left wall {position, r} (instead of the shorthand)", "custom",
                   check=lambda n, v, w: Wall.of(v, n, w), allowed="a table {position, r}",
                   scene="barriers.left", auto="from delta, r, sides"),
    "right": Option(None, "the right wall {position, r} (instead of the shorthand)",
                    "custom", check=lambda n, v, w: Wall.of(v, n, w),
                    allowed="a table {position, r}", scene="barriers.right",
                    auto="from delta, r, sides"),
    "forcing": Option(None, "harmonic forcing F cos(Ωt + φ0) (none by default)", "custom",
                      check=lambda n, v, w: Harmonic.of(v, w, n),
                      allowed="a table {amplitude, frequency, phase}", scene="forcing"),
    "external": Option(None, "coloured external noise: an Ornstein–Uhlenbeck force of "
                       "correlation time τ and intensity D1 (white by default)", "custom",
                       check=lambda n, v, w: OrnsteinUhlenbeck.of(v, w, n),
                       allowed="a table {tau}", scene="external"),
}
#: The fields that make the symmetric shorthand, and their defaults.
SHORTHAND = {"delta": None, "r": 1.0, "barriers": "both"}


def _fail(field: str, allowed: str, value: Any, why: str = "") -> InputError:
    return invalid("VibroImpactSystem", field, allowed, value, why)


@dataclass(frozen=True, kw_only=True)
class VibroImpactSystem:
    """Duffing oscillator between rigid barriers under external and parametric noise.

    Parameters
    ----------
    a, b : float
        Linear and cubic stiffness, G(x) = a x²/2 + b x⁴/4 (paper Eq. 4).  With
        barriers on both sides any real values are allowed (softening b < 0,
        double well a < 0 < b); a side without barrier needs a confining
        potential (b > 0, or b = 0 and a > 0).
    c : float
        Damping, c ≥ 0.  The paper's ε²c.
    D1 : float
        External noise intensity, D1 > 0: E[ξ1(t) ξ1(t+τ)] = 2 D1 δ(τ).  The
        paper's ε²D11.
    D2 : float
        Parametric noise intensity, D2 ≥ 0 (noise x ξ2(t)).  The paper's ε²D22.
    delta : float or None
        Symmetric shorthand: barrier position Δ > 0 (walls at x = ±Δ, or at +Δ or
        −Δ only).  Ignored (may be None) when ``barriers="none"``.
    r : float
        Symmetric shorthand: restitution coefficient, 0 ≤ r ≤ 1 (paper Eq. 1b):
        y⁺ = −r y⁻.
    barriers : {"both", "right", "left", "none"}
        Symmetric shorthand: walls at ±Δ (the paper's case), at +Δ only, at −Δ only,
        or none.
    left, right : Wall or None
        The walls themselves, each with its own position and restitution (any
        positions with left < right; either may be None: no wall on that side).  Given
        instead of the shorthand; after construction both attributes are always set
        (a :class:`Wall` or None), and ``delta``, ``r``, ``barriers`` describe the walls
        where they can (``delta`` None unless the walls are at ±Δ or there is one wall
        at a positive +Δ / negative −Δ; ``r`` None when the walls differ).

    forcing : Harmonic or None
        Deterministic forcing F cos(Ωt + φ0) (:mod:`fpk_vibro.forcing`); the response
        is then periodic in time (``fem.periodic``, ``montecarlo.periodic``).
    external : OrnsteinUhlenbeck or None
        Coloured external noise (:mod:`fpk_vibro.noise`): ξ1 replaced by an
        Ornstein–Uhlenbeck force of correlation time τ and the same D1 (its spectral
        density at zero is that of ξ1).  None: white noise.  Solved by ``fem`` and
        ``montecarlo`` (stationary, transient).

    Raises
    ------
    ValueError
        For any invalid field, naming the field, the allowed range and the value.

    Examples
    --------
    >>> from fpk_vibro import VibroImpactSystem, Wall
    >>> s = VibroImpactSystem(a=1, b=0.2, c=0.025, D1=0.01,
    ...                       left=Wall(-0.4, r=0.7), right=Wall(0.8, r=0.95))
    >>> s.x_bounds, s.barriers, s.delta, s.r
    ((-0.4, 0.8), 'both', None, None)
    >>> VibroImpactSystem.paper(r=0.9).left
    Wall(position=-0.6, r=0.9)
    """

    a: float
    b: float
    c: float
    D1: float
    D2: float = 0.0
    delta: float | None = None
    r: float | None = 1.0
    barriers: str = "both"
    left: Wall | None = None
    right: Wall | None = None
    forcing: Harmonic | None = None
    external: OrnsteinUhlenbeck | None = None

    def __post_init__(self) -> None:
        where = "VibroImpactSystem"
        object.__setattr__(self, "forcing", FIELDS["forcing"].validate(
            "forcing", self.forcing, where))
        object.__setattr__(self, "external", FIELDS["external"].validate(
            "external", self.external, where))
        if self.forcing is not None and self.external is not None:
            raise _fail("external", "None (white noise) with harmonic forcing",
                        self.external, "no solver treats forcing and coloured noise "
                        "together yet")
        for name in ("a", "b", "c", "D1", "D2"):
            object.__setattr__(self, name, FIELDS[name].validate(name, getattr(self, name), where))
        left, right = Wall.of(self.left, "left"), Wall.of(self.right, "right")
        if left is not None or right is not None:
            self._derive_shorthand(left, right)
        else:
            self._build_walls()
        left, right = self.left, self.right
        if left is not None and right is not None and not left.position < right.position:
            raise _fail("left", f"a wall left of the right wall (x < {right.position})",
                        left.position, "the strip between the walls would be empty")
        free = [side for side, w in (("left", left), ("right", right)) if w is None]
        if free and not (self.b > 0 or (self.b == 0 and self.a > 0)):
            field = "b" if self.b != 0 else "a"
            raise _fail(field, "b > 0, or b = 0 with a > 0, on a side without a wall",
                        getattr(self, field),
                        f"there is no {' or '.join(free)} wall, so the potential must "
                        f"confine x there (a={self.a}, b={self.b})")
        if self.c == 0 and all(w is None or w.elastic for w in (left, right)):
            raise _fail("c", "> 0 when there is no other energy loss (r = 1 or no barrier)",
                        self.c, "without any dissipation there is no stationary density")

    def _build_walls(self) -> None:
        """left/right from the shorthand delta, r, barriers (validated here)."""
        where = "VibroImpactSystem"
        barriers = FIELDS["barriers"].validate("barriers", self.barriers, where)
        object.__setattr__(self, "barriers", barriers)
        object.__setattr__(self, "r", FIELDS["r"].validate("r", self.r, where))
        if barriers == "none":
            if self.delta is not None:                    # ignored: None or finite
                object.__setattr__(self, "delta", check_float("delta", self.delta, where=where))
            return
        if self.delta is None:
            raise _fail("delta", "a finite number > 0 when there is a barrier", self.delta)
        d = FIELDS["delta"].validate("delta", self.delta, where)
        object.__setattr__(self, "delta", d)
        if barriers in ("both", "left"):
            object.__setattr__(self, "left", Wall(-d, self.r))
        if barriers in ("both", "right"):
            object.__setattr__(self, "right", Wall(d, self.r))

    def _derive_shorthand(self, left: Wall | None, right: Wall | None) -> None:
        """delta, r, barriers from given walls; a shorthand given too must agree."""
        if left is not None and right is not None:
            barriers = "both"
            delta = (right.position if left.position == -right.position and right.position > 0
                     else None)
        elif right is not None:
            barriers, delta = "right", (right.position if right.position > 0 else None)
        else:
            barriers, delta = "left", (-left.position if left.position < 0 else None)
        rs = {w.r for w in (left, right) if w is not None}
        derived = {"delta": delta, "r": rs.pop() if len(rs) == 1 else None,
                   "barriers": barriers}
        for name, value in derived.items():
            given = getattr(self, name)
            if name == "r" and isinstance(given, (dict, Restitution)):   # a stored law
                given = FIELDS["r"].validate("r", given, "VibroImpactSystem")
            if given != SHORTHAND[name] and given != value:
                raise _fail(name, f"{value!r} (what the walls give) or left out", given,
                            "give the walls (left, right) or the symmetric shorthand "
                            "(delta, r, barriers), not both")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "left", left)
        object.__setattr__(self, "right", right)

    # -- construction -------------------------------------------------------------
    @classmethod
    def paper(cls, r: float = 0.98, **overrides: Any) -> "VibroImpactSystem":
        """The parameters of Yang et al. (2016), Figs 3–5.

        a = 1, b = 0.2, c = 0.025, D1 = D2 = 0.01, Δ = 0.6, bilateral barriers;
        any field can be overridden by keyword (e.g. ``delta=1.0`` for Figs 6–7).
        """
        fields = dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01, delta=0.6, r=r, barriers="both")
        if "left" in overrides or "right" in overrides:      # walls instead of ±Δ
            for name in SHORTHAND:
                fields.pop(name)
        unknown = set(overrides) - set(fields) - {"left", "right", "forcing", "external"}
        if unknown:
            raise ValueError(f"VibroImpactSystem.paper: unknown field(s) {sorted(unknown)}; "
                             f"allowed: {sorted(fields)}")
        fields.update(overrides)
        return cls(**fields)

    def replace(self, **changes: Any) -> "VibroImpactSystem":
        """A copy with some fields changed (validated again).

        Changing the shorthand (``delta``, ``r``, ``barriers``) rebuilds the walls from
        it; changing a wall keeps the other one.  Wall attributes may be changed by
        dotted name: ``replace(**{"left.r": 0.5})``.
        """
        walls = {"left": self.left, "right": self.right}
        for table, kind in (("forcing", Harmonic), ("external", OrnsteinUhlenbeck)):
            dotted = [k for k in changes if k.startswith(table + ".")]
            if not dotted:
                continue
            if getattr(self, table) is None and table not in changes:
                raise invalid("VibroImpactSystem.replace", dotted[0], f"a change of the "
                              f"system's {table}", changes[dotted[0]], f"it has no {table}")
            base = kind.of(changes.pop(table, None) or getattr(self, table))
            entries = base.to_dict()
            for key in dotted:
                entries[key.split(".", 1)[1]] = changes.pop(key)
            changes[table] = kind.of(entries, "VibroImpactSystem.replace")
        for key in [k for k in changes if "." in k]:
            side, attr = key.split(".", 1)
            if side not in walls or attr not in WALL_FIELDS:
                raise invalid("VibroImpactSystem.replace", key,
                              "a field or left.position, left.r, right.position, right.r",
                              changes[key])
            if walls[side] is None:
                raise invalid("VibroImpactSystem.replace", key, "a change of an existing "
                              "wall", changes[key], f"this system has no {side} wall")
            try:
                walls[side] = dataclasses.replace(walls[side], **{attr: changes.pop(key)})
            except InputError as exc:
                raise InputError(f"VibroImpactSystem: {key} {exc.rule}",
                                 where="VibroImpactSystem", name=key) from None
            changes[side] = walls[side]
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if set(changes) & set(SHORTHAND) and not set(changes) & {"left", "right"}:
            fields.update(left=None, right=None)
        elif set(changes) & {"left", "right"}:
            fields.update(SHORTHAND)
        fields.update(changes)
        return type(self)(**fields)

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain values (walls as {position, r} tables or None; a law as
        its scene table, :meth:`fpk_vibro.restitution.Restitution.to_dict`)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if isinstance(out["r"], Restitution):
            out["r"] = out["r"].to_dict()
        for side in ("left", "right"):
            if out[side] is not None:
                out[side] = out[side].to_dict()
        for table in ("forcing", "external"):
            if out[table] is not None:
                out[table] = out[table].to_dict()
            else:
                del out[table]              # (files of white, unforced systems as before)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "VibroImpactSystem":
        """Inverse of :meth:`to_dict`; a dict without walls uses the shorthand (a
        shorthand stored beside walls must agree with them)."""
        return cls(**data)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    # -- geometry and energy ------------------------------------------------------
    @property
    def has_barrier(self) -> bool:
        return self.left is not None or self.right is not None

    @property
    def walls(self) -> tuple[tuple[str, Wall], ...]:
        """(("left", Wall), ("right", Wall)) for the walls that exist."""
        return tuple((side, w) for side, w in (("left", self.left), ("right", self.right))
                     if w is not None)

    @property
    def symmetric(self) -> bool:
        """True when the walls are at ±Δ with one restitution, or there are none."""
        return (self.left is None and self.right is None) or (
            self.left is not None and self.right is not None
            and self.left.position == -self.right.position and self.left.r == self.right.r)

    @property
    def x_bounds(self) -> tuple[float, float]:
        """(left, right) limits of the strip; ±inf where there is no wall."""
        return (-math.inf if self.left is None else self.left.position,
                math.inf if self.right is None else self.right.position)

    def in_strip(self, x: np.ndarray) -> np.ndarray:
        """Boolean mask of points with left ≤ x ≤ right."""
        lo, hi = self.x_bounds
        x = np.asarray(x, dtype=float)
        return (x >= lo) & (x <= hi)

    def potential(self, x: np.ndarray) -> np.ndarray:
        """G(x) = a x²/2 + b x⁴/4 (paper Eq. 4)."""
        x2 = np.square(np.asarray(x, dtype=float))
        return x2 * (0.5 * self.a + 0.25 * self.b * x2)

    def restoring_force(self, x: np.ndarray) -> np.ndarray:
        """G'(x) = a x + b x³: the spring force, pulling toward x = 0 where positive."""
        x = np.asarray(x, dtype=float)
        return x * (self.a + self.b * np.square(x))

    def drift(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ẋ, ẏ) without noise: (y, −c y − G'(x)) (docs/theory.md, §Model)."""
        y = np.asarray(y, dtype=float)
        return y, -self.c * y - self.restoring_force(x)

    def energy(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """H = y²/2 + G(x) (paper Eq. 3)."""
        return 0.5 * np.square(np.asarray(y, dtype=float)) + self.potential(x)

    @property
    def barrier_energy(self) -> float:
        """The lowest wall energy min G(x_w): energies above it impact (paper Eq. 5:
        G(Δ)).  inf without walls."""
        if not self.has_barrier:
            return math.inf
        return min(float(self.potential(w.position)) for _, w in self.walls)

    def amplitude(self, H: np.ndarray) -> np.ndarray:
        """Amplitude A with G(A) = H, A² = 4H / (sqrt(a² + 4bH) + a) (docs/theory.md,
        §Energy and orbits).

        The cancellation-free form.  NaN where no real amplitude exists
        (softening b < 0 above the potential's maximum, or a ≤ 0 near H = 0).
        """
        H = np.asarray(H, dtype=float)
        disc = self.a * self.a + 4.0 * self.b * H
        with np.errstate(invalid="ignore", divide="ignore"):
            root = np.sqrt(disc)
            den = root + self.a
            A2 = np.where(disc >= 0, 4.0 * H / den, np.nan)
            A2 = np.where(H == 0, 0.0, A2)
            A2 = np.where(A2 >= 0, A2, np.nan)
        return np.sqrt(A2)

    def noise_intensity(self, x: np.ndarray) -> np.ndarray:
        """D(x) = D1 + D2 x²: the diffusion coefficient of the FPK (docs/theory.md,
        §FPK on the strip)."""
        return self.D1 + self.D2 * np.square(np.asarray(x, dtype=float))

    @property
    def effects(self) -> list[str]:
        """The physical effects active in this system (terms that are non-zero)."""
        out = []
        if self.a != 0 or self.b != 0:
            out.append("restoring")
        if self.c != 0:
            out.append("damping")
        out.append("external_noise" if self.external is None else "coloured_noise")
        if self.D2 != 0:
            out.append("parametric_noise")
        out += [f"impact_{side}" for side, _ in self.walls[::-1]]
        if self.forcing is not None:
            out.append("harmonic_forcing")
        return out


#: Where a forced system is solved (the solvers that take ``forcing``).
FORCED_SOLVERS = "fem.periodic, montecarlo.periodic and the transients of fem and montecarlo"
#: Where a system with coloured external noise is solved.
COLOURED_SOLVERS = ("fem.stationary, fem.transient, montecarlo.stationary or "
                    "montecarlo.transient")


def check_system(where: str, system: Any, *, forcing: bool = False,
                 coloured: bool = False) -> VibroImpactSystem:
    """``system`` if it is a :class:`VibroImpactSystem`, else a one-line error; a system
    with harmonic forcing too, unless the caller handles ``forcing`` (a forced system
    has no stationary density and no time-invariant first passage), and one with
    coloured external noise unless the caller handles ``coloured`` (its density lives
    in (x, y, ζ))."""
    if not isinstance(system, VibroImpactSystem):
        raise invalid(where, "system", "a VibroImpactSystem", system)
    if system.forcing is not None and not forcing:
        raise InputError(f"{where}: does not handle harmonic forcing (the response is "
                         f"periodic, not stationary); use {FORCED_SOLVERS}", where=where,
                         name="forcing")
    if system.external is not None and not coloured:
        raise InputError(f"{where}: does not handle coloured external noise (external="
                         f"OrnsteinUhlenbeck(tau={system.external.tau:g}): the state is "
                         f"(x, y, ζ)); use {COLOURED_SOLVERS}", where=where,
                         name="external")
    return system
