"""Stationary density of the averaged energy process (paper Eqs. 22–27), any walls.

With T, J1, J2, K, m, σ² as in :mod:`fpk_vibro.averaging.coefficients`:

Stationary density (paper Eq. 24).  Because dJ2/dH = 2K (the integrand of J2
vanishes at turning points and the walls are fixed), 2m/σ² = J2'/J2 −
(2cJ1 + δ)/J2, so the paper's exp(∫ 2m/σ²)/σ² integrates in closed form to

    p(H) = T(H) exp(−Φ(H)) / Z,   Φ(H) = ∫ f(u) du from the floor,   f = (2c J1 + δ)/J2,

and the joint density p(x, y) = p(H)/T(H) = exp(−Φ(H))/Z (paper Eq. 25).  The
floor is H = 0 when the strip contains x = 0 (f → c/D1 there, no singular term
is left) and G at the nearest wall otherwise (preload: f ∝ (H − floor)^-½, still
integrable).  For r = 1, D2 = 0, f ≡ c/D1 and the Gibbs density is recovered
exactly, for any walls.

Φ is built on panels of Gauss–Legendre nodes in the amplitude A (H = G(A), below
the lowest wall energy) and in s = sqrt(H − G(x_w)) above each wall energy
(:mod:`fpk_vibro.averaging.regimes`); these variables make the integrands analytic
(each kink of p(H) at a wall energy is a sqrt-type singularity in H), and on each
panel Φ is kept as the Legendre antiderivative of f, so Φ(H) is evaluated anywhere
to the accuracy of the quadrature.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.polynomial import legendre as L

from ..model import VibroImpactSystem
from ..orbits import orbit_nodes
from ..solution import MOMENT_KEYS, Rule, Solution, Stored
from .normalisation import normalise
from .options import Options
from .regimes import Layout, Regime, gauss_legendre, panel_nodes

__all__ = ["stationary", "AveragedSolution"]

#: The inter-impact law and its estimate (:mod:`fpk_vibro.averaging.inter_impact`),
#: handed over by the package's ``__init__``: the law needs the first-passage
#: machinery, which lies above this module.
INTER_IMPACT: dict[str, Any] = {}

_GEO = 0.5 ** np.arange(40, 0, -1)       # geometric sub-panels toward a near-singular end


class AveragedSolution(Solution):
    """Stationary density of the averaged energy process.

    Built by :func:`stationary`.  Energies above ``H_end`` (where Φ exceeds
    ``phi_cut``, i.e. p/p_max < e^-phi_cut) use Φ extended linearly with slope
    f(H_end); their total mass is below e^-phi_cut.
    """

    kind = "averaging"

    def __init__(self, system: VibroImpactSystem, *, n_theta: int, n_panel: int,
                 phi_cut: float, regimes: tuple[Regime, ...], Z: float,
                 H_end: float, f_end: float, moments: dict[str, float]) -> None:
        self.system = system
        self.n_theta, self.n_panel, self.phi_cut = n_theta, n_panel, phi_cut
        self._low, *self._highs = regimes
        self._layout = Layout(system)
        self.Z, self.H_end, self.f_end = Z, H_end, f_end
        self._moments = moments
        self._mean_x: float | None = None
        self._estimate: dict[str, Any] | None = None
        self._indicator_estimate: dict[str, Any] | None = None
        #: What the solve did (``panels``: Φ's panels in all regimes) and, once asked
        #: for, the model error (``info["error_estimate"]``, the largest relative figure).
        self.info: dict[str, Any] = {"n_theta": n_theta, "n_panel": n_panel, "phi_cut": phi_cut,
                                     "panels": sum(r.coef.shape[1] for r in regimes)}

    # -- how far off it is ----------------------------------------------------------
    def error_estimate(self, reference: Any = None, *, by: str = "fem") -> dict[str, Any]:
        """The model error of averaging.

        Parameters
        ----------
        reference : FEMSolution, optional
            An FE solution of the same system already at hand (``by="fem"`` only; it
            replaces any estimate made before).  Anything else (another method's
            answer, another system's, a transient's member) is refused, naming it.
        by : {"fem", "indicators"}
            ``"fem"``: a finite-element check of the same system
            (:mod:`fpk_vibro.averaging.validity`; one FE solve on the first call,
            0.1–10 s, unless ``reference`` is given).  ``"indicators"``: the
            calibrated indicator model (:mod:`fpk_vibro.averaging.error_model`;
            no FE solve, milliseconds; within 3× of the true error on ~99 % of
            random systems for E[H], E[y²], ~96 % for P_impact, ~80 % for E[x²]).

        Returns
        -------
        dict
            ``E_H``, ``E_x2``, ``E_y2`` (and ``P_impact`` with walls): relative;
            ``L1`` (``by="fem"`` only): ∫|p − p_FE| plus FE's own; ``assumes``,
            ``reference``, ``seconds``; ``indicators`` (``by="indicators"``).

        Examples
        --------
        >>> from fpk_vibro import VibroImpactSystem, averaging
        >>> sol = averaging.stationary(VibroImpactSystem.paper(r=0.6))
        >>> 0.01 < sol.error_estimate(by="indicators")["E_H"] < 0.3
        True
        """
        cache = "_indicator_estimate" if by == "indicators" else "_estimate"
        if by not in ("fem", "indicators") or reference is not None \
                or getattr(self, cache) is None:
            from .validity import estimate
            setattr(self, cache, estimate(self, reference, by))
        return dict(getattr(self, cache))

    def validity(self) -> dict[str, Any]:
        """The small parameters averaging assumes small, at the mean energy, with a
        verdict in plain words (:func:`fpk_vibro.averaging.validity.indicators`), the
        indicator model's features (``model``) and estimate (``estimated_error``, its
        largest key, ``estimated_key``; :mod:`fpk_vibro.averaging.error_model`, no FE
        solve) and the weakest assumption (:func:`~fpk_vibro.averaging.validity.weakest`)."""
        from .validity import report
        return report(self)

    # -- Φ and its panel structure ------------------------------------------------
    def _maps(self) -> list[tuple[Regime, Any, Any, bool]]:
        """(regime, H(t), dH/dt, is an s-regime) for the amplitude and s-regimes."""
        out = [(self._low, self.system.potential, self.system.restoring_force, False)]
        for E, reg in zip(self._layout.kinks, self._highs):
            out.append((reg, lambda s, E=E: E + s * s, lambda s: 2.0 * s, True))
        return out

    def phi(self, H: np.ndarray) -> np.ndarray:
        """Φ(H) = ∫ (2c J1 + δ)/J2 du from the floor, so that p(x, y) = exp(−Φ(H))/Z."""
        lay = self._layout
        H = np.maximum(np.asarray(H, dtype=float), lay.floor)
        out = np.empty_like(H)
        done = np.zeros(H.shape, dtype=bool)
        if not self._low.empty:
            top = float(lay.kinks[0]) if lay.kinks.size else np.inf
            done = H <= min(top, self.H_end)
            if np.any(done):
                out[done] = self._low(self.system.amplitude(H[done]))
        for k, reg in enumerate(self._highs):
            if reg.empty:
                continue
            sel = ~done & (H <= min(lay.top(k), self.H_end))
            if np.any(sel):
                out[sel] = reg(np.sqrt(H[sel] - lay.kinks[k]))
            done = done | sel
        beyond = ~done
        if np.any(beyond):
            out[beyond] = self.phi_cut_value + self.f_end * (H[beyond] - self.H_end)
        return out

    @property
    def phi_cut_value(self) -> float:
        """Φ at the end of the last panel (H_end)."""
        return [r for r in [self._low, *self._highs] if not r.empty][-1].end_value

    def _energy_edges(self) -> list[tuple[np.ndarray, bool]]:
        """Panel edges in H of each regime (capped at the next wall energy, which
        E + s_max² may pass by a rounding), and whether it is an s-regime."""
        tops = [np.inf] + [self._layout.top(k) for k in range(len(self._highs))]
        return [(np.minimum(H_of(reg.edges), top), is_s)
                for (reg, H_of, _, is_s), top in zip(self._maps(), tops)]

    # -- the Solution interface ---------------------------------------------------
    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        """p(H) = T(H) exp(−Φ(H)) / Z (paper Eq. 24), zero below the floor."""
        H = np.asarray(H, dtype=float)
        floor = self._layout.floor
        Hc = np.maximum(H, floor)
        T = orbit_nodes(self.system, Hc, self.n_theta).period
        return np.where(H >= floor, T * np.exp(-self.phi(Hc)) / self.Z, 0.0)

    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """p(x, y) = p(H)/T(H) = exp(−Φ(H))/Z on the strip (paper Eq. 25)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        p = np.exp(-self.phi(self.system.energy(x, y))) / self.Z
        return np.where(self.system.in_strip(x), p, 0.0)

    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        """p(x) = (2/Z) ∫₀^∞ exp(−Φ(G(x) + v²/2)) dv (paper Eq. 26).

        Composite Gauss–Legendre in v on the images of the Φ panels.  For an
        s-regime starting at E > G(x) the variable is s = sqrt(H − E) instead
        (dv = 2s ds/v), which removes the sqrt singularity where the orbit starts to
        impact; for E < G(x) the v-panels are graded geometrically toward v = 0,
        where s = sqrt(G(x) − E + v²/2) is nearly singular.
        """
        x = np.asarray(x, dtype=float)
        G = self.system.potential(x.ravel())
        t, gw = L.leggauss(self.n_panel)
        edges = self._energy_edges()
        total = np.zeros(G.size)
        H_low = edges[0][0]
        if H_low.size > 1:
            total += self._v_integral(G, H_low, t, gw)
        for E, reg, (H_high, _) in zip(self._layout.kinks, self._highs, edges[1:]):
            if H_high.size < 2:
                continue
            below = G < E
            above = G > E
            on = ~below & ~above
            total[on] += self._v_integral(G[on], H_high, t, gw)
            if np.any(above):
                total[above] += self._v_integral(G[above], H_high, t, gw, graded=True)
            # dv/ds = 2s/sqrt(v*² + 2s²) turns over at s ~ v* → 0 as G(x) → E:
            # geometric sub-panels toward s = 0 resolve it for every x
            e = reg.edges
            s_edges = np.concatenate([[0.0], e[1] * _GEO, e[1:]])
            s, ds = panel_nodes(s_edges, t, gw)
            Hs = E + s * s
            vv = np.sqrt(2.0 * (Hs - G[below, None]))
            total[below] += np.sum(ds * np.exp(-self.phi(Hs)) * 2.0 * s / vv, axis=-1)
        p = np.where(self.system.in_strip(x.ravel()), 2.0 * total / self.Z, 0.0)
        return p.reshape(x.shape)

    def _v_integral(self, G: np.ndarray, H_edges: np.ndarray, t, gw,
                    graded: bool = False) -> np.ndarray:
        """∫ exp(−Φ(G + v²/2)) dv over the v-images of the energy panels ``H_edges``
        (``graded``: with geometric sub-panels below the first non-empty image)."""
        v_e = np.sqrt(2.0 * np.maximum(H_edges - G[:, None], 0.0))
        if graded:
            v1 = np.min(np.where(v_e > 0, v_e, np.inf), axis=-1, keepdims=True)
            v1 = np.where(np.isfinite(v1), v1, 0.0)
            v_e = np.concatenate([np.zeros_like(v1), v1 * _GEO, np.maximum(v_e, v1)], axis=-1)
        v, dv = panel_nodes(v_e, t, gw)
        return np.sum(dv * np.exp(-self.phi(G[:, None] + 0.5 * v * v)), axis=-1)

    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        """p(y) = ∫ exp(−Φ(y²/2 + G(x))) dx / Z over the strip (paper Eq. 27).

        G is even, so the integral is a sum over the two sides of x = 0 of
        ∫ over |x| ∈ [X0, X1] (X0 = 0 when the strip contains 0, a wall's |x_w| for
        a strip on one side; X1 = |x_w| at a wall, ∞ where none).  Composite
        Gauss–Legendre in |x| on the images of the Φ panels; in the s-regimes with
        |x| = x_l + u², which smooths the (x − x*)^{3/2} behaviour of Φ where the
        orbit starts to impact.
        """
        y = np.asarray(y, dtype=float)
        K = 0.5 * y.ravel() ** 2
        lo, hi = self.system.x_bounds
        total = np.zeros(K.size)
        for X0, X1 in ((max(lo, 0.0), hi), (max(-hi, 0.0), -lo)):
            if X1 > X0:
                total += self._x_integral(K, X0, X1)
        return (total / self.Z).reshape(y.shape)

    def _x_integral(self, K: np.ndarray, X0: float, X1: float) -> np.ndarray:
        t, gw = L.leggauss(self.n_panel)
        floor = min(0.0, self._layout.floor)
        total = np.zeros(K.size)
        for He, smooth_start in self._energy_edges():
            if He.size < 2:
                continue
            A = self.system.amplitude(np.maximum(He - K[:, None], floor))
            x_e = np.minimum(np.where(np.isfinite(A), A, X1), X1)
            if X0 > 0:
                x_e = np.maximum(x_e, X0)
                if smooth_start:
                    x_e = _graded_start(x_e)
            if smooth_start:
                u, du = gauss_legendre(0.0, np.sqrt(x_e[:, 1:] - x_e[:, :-1]), t, gw)
                xx = x_e[:, :-1, None] + u * u
                w = du * 2.0 * u
            else:
                xx, w = gauss_legendre(x_e[:, :-1], x_e[:, 1:], t, gw)
            total += np.sum(w * np.exp(-self.phi(K[:, None, None] + self.system.potential(xx))),
                            axis=(-1, -2))
        return total

    def moments(self) -> dict[str, float]:
        return dict(self._moments)

    def impacts(self) -> dict[str, dict[str, float]]:
        """Per wall: impact rate, speed moments and energy removed per unit time, from
        p(H) and the orbits (:mod:`fpk_vibro.averaging.impacts`)."""
        from .impacts import impact_statistics
        return impact_statistics(self)

    def impact_speed_pdf(self, wall: str, u):
        """Density of the speed just before impact on ``wall`` ("left"/"right")."""
        from .impacts import impact_speed_pdf
        return impact_speed_pdf(self, wall, u)

    def inter_impact_pdf(self, t):
        """Density of the time between successive impacts (any wall) at ``t`` ≥ 0.

        Assumes the energy nearly constant over an orbit (weak damping and noise): an
        impact at energy H is followed by the next one T(H)/n(H) later (n walls
        reached; two legs of T/2 between two walls), weighted by the impact flux at H,
        plus the excursions below the lowest wall energy that Kac's identity requires
        (:mod:`fpk_vibro.averaging.inter_impact`; :meth:`inter_impact_estimate` says
        how far to trust it).
        """
        return INTER_IMPACT["law"](self).pdf(t)

    def mean_inter_impact_time(self) -> float:
        """Mean time between successive impacts, the mean of :meth:`inter_impact_pdf`:
        P_impact/ν from the periodic gaps plus q τ_X from the excursions, 1/ν (ν the
        total impact rate of :meth:`impacts`) by construction."""
        return INTER_IMPACT["law"](self).mean

    def inter_impact_estimate(self, reference: Any = None) -> dict[str, Any]:
        """How far to trust :meth:`inter_impact_pdf` (:func:`~fpk_vibro.averaging.
        inter_impact.estimate`): ``mean`` (relative, from the FE impact rate),
        ``excursion_share`` q, ``frozen_energy``, ``reference``, ``assumes``."""
        return INTER_IMPACT["estimate"](self, reference)

    def mean_x(self) -> float:
        """E[x] from the orbit averages of x: ∫ exp(−Φ) 2∫ x dx/|y| dH / Z.

        Exactly 0 for walls at ±Δ (or none); computed once from the Φ panels.
        """
        if self.system.symmetric:
            return 0.0
        if self._mean_x is None:
            total = 0.0
            for reg, H_of, dH_of, _ in self._maps():
                if reg.empty:
                    continue
                t, w, phi = reg.nodes(self.n_panel)
                o = orbit_nodes(self.system, H_of(t), self.n_theta)
                total += float(np.sum(w * dH_of(t) * np.exp(-phi) * 2.0 * o.integrate(o.x)))
            self._mean_x = total / self.Z
        return self._mean_x

    # -- persistence --------------------------------------------------------------
    @staticmethod
    def _names(n_high: int) -> list[str]:
        """Array prefixes: "low", "high", then "high2", ... for further wall energies."""
        return ["low", "high"] + [f"high{k}" for k in range(2, n_high + 1)]

    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        meta = dict(n_theta=self.n_theta, n_panel=self.n_panel, phi_cut=self.phi_cut,
                    Z=self.Z, H_end=self.H_end, f_end=self.f_end, moments=self._moments)
        if len(self._highs) > 1:
            meta["n_high"] = len(self._highs)
        arrays = {}
        for name, reg in zip(self._names(len(self._highs)), (self._low, *self._highs)):
            arrays[f"{name}_edges"] = reg.edges
            arrays[f"{name}_coef"] = reg.coef
            arrays[f"{name}_phi0"] = reg.phi0
        return meta, arrays

    _meta_schema = {**{k: Rule.of(Options.declared()[k])
                       for k in ("n_theta", "n_panel", "phi_cut")},
                    "Z": Rule.number(0.0, lo_open=True), "H_end": Rule.number(),
                    "f_end": Rule.number(),
                    "moments": Rule.mapping(Rule.number(), MOMENT_KEYS[:5], MOMENT_KEYS),
                    "n_high": Rule.integer(2, 2).optional()}

    @classmethod
    def _array_schema(cls, meta):
        """Per regime: panel edges (n), Legendre coefficients (n_panel + 1, n - 1), Φ₀
        (n - 1); regimes "low", "high" and, with a second wall energy, "high2"."""
        rows, out = meta["n_panel"] + 1, {}
        for r in cls._names(meta.get("n_high", 1)):
            out[f"{r}_edges"] = Stored((r,), min_size=1, increasing=True,
                                       nonneg=True)
            out[f"{r}_coef"] = Stored((rows, f"{r}-1"))
            out[f"{r}_phi0"] = Stored((f"{r}-1",))
        return out

    @classmethod
    def _check_state(cls, system, meta, arrays):
        """P_impact among the moments exactly when the system has a barrier; one
        s-regime per distinct wall energy."""
        if ("P_impact" in meta["moments"]) != system.has_barrier:
            raise ValueError("meta['moments'] must hold P_impact exactly when the system "
                             f"has a barrier (barriers={system.barriers!r})")
        if meta.get("n_high", 1) != Layout(system).n_high:
            raise ValueError(f"meta['n_high'] must be {Layout(system).n_high}, the number "
                             "of distinct wall energies of the system")

    @classmethod
    def _from_state(cls, system, meta, arrays):
        regimes = tuple(Regime(arrays[f"{n}_edges"], arrays[f"{n}_coef"], arrays[f"{n}_phi0"])
                        for n in cls._names(meta.get("n_high", 1)))
        return cls(system, n_theta=meta["n_theta"], n_panel=meta["n_panel"],
                   phi_cut=meta["phi_cut"], regimes=regimes, Z=meta["Z"],
                   H_end=meta["H_end"], f_end=meta["f_end"], moments=meta["moments"])


def _graded_start(x_e: np.ndarray) -> np.ndarray:
    """Edges (rows) with geometric sub-panels (ratio 4 in x, 2 in u = sqrt(x − x_a)) on
    the first non-empty panel [x_a, x_b]: at a wall |x_w| = X0 > 0 with K + G(X0) just
    above a wall energy, s = sqrt(K + G(x) − E) is nearly singular at x_a."""
    x_a = x_e[:, :1]
    x_b = np.min(np.where(x_e > x_a, x_e, np.inf), axis=-1, keepdims=True)
    x_b = np.where(np.isfinite(x_b), x_b, x_a)
    graded = x_a + (x_b - x_a) * 0.25 ** np.arange(20, 0, -1)
    return np.concatenate([x_a, graded, np.maximum(x_e, x_b)], axis=-1)


def stationary(system: VibroImpactSystem, *, n_theta: int = 48, n_panel: int = 24,
               phi_cut: float = 60.0) -> AveragedSolution:
    """Stationary density of the averaged energy process (paper Eqs. 22–27).

    Parameters
    ----------
    system : VibroImpactSystem
        Any walls; G must increase with |x| on the strip (one orbit per energy
        level, :func:`fpk_vibro.orbits.require_single_well`), else ValueError.
    n_theta : int
        Gauss–Legendre nodes along each orbit (θ substitution of :mod:`fpk_vibro.orbits`).
    n_panel : int
        Gauss–Legendre nodes per energy panel.
    phi_cut : float
        Energies are covered until Φ(H) ≥ phi_cut: the neglected mass is below
        e^-phi_cut (≈ 1e-26 for the default).

    Returns
    -------
    AveragedSolution

    Notes
    -----
    Accuracy: with the defaults, moments and normalisation agree with the exact
    Gibbs solution (r = 1, D2 = 0) to ~1e-13 relative, also for asymmetric and
    preloaded walls, and T, m, σ² with adaptive quadrature to ~1e-13
    (tests/test_averaging.py, tests/test_walls_averaging.py).
    """
    opts, _ = Options.prepare(system, "stationary", locals())
    return solve(system, opts)


def solve(system: VibroImpactSystem, opts: Options) -> AveragedSolution:
    """The closed form of :func:`stationary` for validated ``opts``."""
    n = normalise(system, opts.n_theta, opts.n_panel, opts.phi_cut)
    return AveragedSolution(system, n_theta=opts.n_theta, n_panel=opts.n_panel,
                            phi_cut=float(opts.phi_cut), regimes=n.regimes, Z=n.Z,
                            H_end=n.H_end, f_end=n.f_end, moments=n.moments)
