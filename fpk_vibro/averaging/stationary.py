"""Stationary density of the averaged energy process (DESIGN §2, paper Eqs. 22–27).

With T, J1, J2, K, m, σ² as in :mod:`fpk_vibro.averaging.coefficients`:

Stationary density (paper Eq. 24).  Because dJ2/dH = 2K (the integrand of J2
vanishes at turning points and the barriers are fixed), 2m/σ² = J2'/J2 −
(2cJ1 + δ)/J2, so the paper's exp(∫ 2m/σ²)/σ² integrates in closed form to

    p(H) = T(H) exp(−Φ(H)) / Z,   Φ(H) = ∫₀ᴴ f(u) du,   f = (2c J1 + δ)/J2,

and the joint density p(x, y) = p(H)/T(H) = exp(−Φ(H))/Z (paper Eq. 25).  f is
bounded at H = 0 (→ c/D1), so this is the exact form of DESIGN §2's "integrate
2m/σ² − 1/u and add log H": no singular term is left.  For r = 1, D2 = 0,
f ≡ c/D1 and the Gibbs density is recovered exactly.

Φ is built on panels of Gauss–Legendre nodes in the amplitude A (H = G(A),
H ≤ G(Δ)) and in s = sqrt(H − G(Δ)) above the barrier energy; both variables make
the integrands analytic (the kink of p(H) at G(Δ) is a sqrt-type singularity in H),
and on each panel Φ is kept as the Legendre antiderivative of f, so Φ(H) is
evaluated anywhere to the accuracy of the quadrature.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.polynomial import legendre as L

from ..model import VibroImpactSystem
from ..orbits import orbit_nodes
from ..solution import MOMENT_KEYS, Rule, Solution, Stored
from .coefficients import _gl, _panel_nodes, _rate
from .options import Options

__all__ = ["stationary", "AveragedSolution"]

_MAX_PANELS = 400

class _Regime:
    """Φ on consecutive panels of one variable t (A or s): Legendre antiderivatives."""

    def __init__(self, edges: np.ndarray, coef: np.ndarray, phi0: np.ndarray) -> None:
        self.edges, self.coef, self.phi0 = edges, coef, phi0

    @property
    def empty(self) -> bool:
        return self.edges.size < 2

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Φ(t) for t within [edges[0], edges[-1]] (clipped)."""
        e = self.edges
        k = np.clip(np.searchsorted(e, t, side="right") - 1, 0, e.size - 2)
        tau = np.clip((2.0 * t - e[k] - e[k + 1]) / (e[k + 1] - e[k]), -1.0, 1.0)
        return self.phi0[k] + L.legval(tau, self.coef[:, k], tensor=False)


class AveragedSolution(Solution):
    """Stationary density of the averaged energy process (DESIGN §2).

    Built by :func:`stationary`.  Energies above ``H_end`` (where Φ exceeds
    ``phi_cut``, i.e. p/p_max < e^-phi_cut) use Φ extended linearly with slope
    f(H_end); their total mass is below e^-phi_cut.
    """

    kind = "averaging"

    def __init__(self, system: VibroImpactSystem, *, n_theta: int, n_panel: int,
                 phi_cut: float, regimes: tuple[_Regime, _Regime], Z: float,
                 H_end: float, f_end: float, moments: dict[str, float]) -> None:
        self.system = system
        self.n_theta, self.n_panel, self.phi_cut = n_theta, n_panel, phi_cut
        self._low, self._high = regimes
        self.Z, self.H_end, self.f_end = Z, H_end, f_end
        self._moments = moments

    # -- Φ and its panel structure ------------------------------------------------
    @property
    def _Hb(self) -> float:
        return self.system.barrier_energy

    def phi(self, H: np.ndarray) -> np.ndarray:
        """Φ(H) = ∫₀ᴴ (2c J1 + δ)/J2 du, so that p(x, y) = exp(−Φ(H))/Z."""
        H = np.maximum(np.asarray(H, dtype=float), 0.0)
        out = np.empty_like(H)
        low = H <= min(self._Hb, self.H_end)
        if np.any(low):
            out[low] = self._low(self.system.amplitude(H[low]))
        high = ~low & (H <= self.H_end)
        if np.any(high):
            out[high] = self._high(np.sqrt(H[high] - self._Hb))
        beyond = H > self.H_end
        if np.any(beyond):
            out[beyond] = self.phi_cut_value + self.f_end * (H[beyond] - self.H_end)
        return out

    @property
    def phi_cut_value(self) -> float:
        last = self._low if self._high.empty else self._high
        k = last.edges.size - 2
        return float(last.phi0[k] + L.legval(1.0, last.coef[:, k]))

    def _energy_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Panel edges in H of the low (amplitude) and high (excess) regimes."""
        return self.system.potential(self._low.edges), self._Hb + self._high.edges ** 2

    # -- the Solution interface ---------------------------------------------------
    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        """p(H) = T(H) exp(−Φ(H)) / Z (paper Eq. 24), zero for H < 0."""
        H = np.asarray(H, dtype=float)
        Hc = np.maximum(H, 0.0)
        T = orbit_nodes(self.system, Hc, self.n_theta).period
        return np.where(H >= 0, T * np.exp(-self.phi(Hc)) / self.Z, 0.0)

    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """p(x, y) = p(H)/T(H) = exp(−Φ(H))/Z on the strip (paper Eq. 25)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        p = np.exp(-self.phi(self.system.energy(x, y))) / self.Z
        return np.where(self.system.in_strip(x), p, 0.0)

    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        """p(x) = (2/Z) ∫₀^∞ exp(−Φ(G(x) + v²/2)) dv (paper Eq. 26).

        Composite Gauss–Legendre in v on the images of the Φ panels; above G(Δ),
        for G(x) < G(Δ), in s = sqrt(H − G(Δ)) instead (dv = 2s ds/v), which
        removes the sqrt singularity where the orbit starts to impact.
        """
        x = np.asarray(x, dtype=float)
        G = self.system.potential(x.ravel())
        t, gw = L.leggauss(self.n_panel)
        H_low, H_high = self._energy_edges()
        total = np.zeros(G.size)
        if H_low.size > 1:
            total += self._v_integral(G, H_low, t, gw)
        if H_high.size > 1:
            below = G < self._Hb
            total[~below] += self._v_integral(G[~below], H_high, t, gw)
            # dv/ds = 2s/sqrt(v*² + 2s²) turns over at s ~ v* → 0 as x → ±Δ:
            # geometric sub-panels toward s = 0 resolve it for every x
            e = self._high.edges
            s_edges = np.concatenate([[0.0], e[1] * 0.5 ** np.arange(40, 0, -1), e[1:]])
            s, ds = _panel_nodes(s_edges, t, gw)
            Hs = self._Hb + s * s
            vv = np.sqrt(2.0 * (Hs - G[below, None]))
            total[below] += np.sum(ds * np.exp(-self.phi(Hs)) * 2.0 * s / vv, axis=-1)
        p = np.where(self.system.in_strip(x.ravel()), 2.0 * total / self.Z, 0.0)
        return p.reshape(x.shape)

    def _v_integral(self, G: np.ndarray, H_edges: np.ndarray, t, gw) -> np.ndarray:
        """∫ exp(−Φ(G + v²/2)) dv over the v-images of the energy panels ``H_edges``."""
        v_e = np.sqrt(2.0 * np.maximum(H_edges - G[:, None], 0.0))
        v, dv = _panel_nodes(v_e, t, gw)
        return np.sum(dv * np.exp(-self.phi(G[:, None] + 0.5 * v * v)), axis=-1)

    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        """p(y) = ∫ exp(−Φ(y²/2 + G(x))) dx / Z over the strip (paper Eq. 27).

        G is even, so the integral is a sum of I(X) = ∫₀^X over the two sides
        (X = Δ at a barrier, ∞ where none).  Composite Gauss–Legendre in x on the
        images of the Φ panels; above G(Δ) with x = x_l + u², which smooths the
        (x − x*)^{3/2} behaviour of Φ where the orbit starts to impact.
        """
        y = np.asarray(y, dtype=float)
        K = 0.5 * y.ravel() ** 2
        lo, hi = self.system.x_bounds
        total = self._x_integral(K, hi) + self._x_integral(K, -lo)
        return (total / self.Z).reshape(y.shape)

    def _x_integral(self, K: np.ndarray, X: float) -> np.ndarray:
        t, gw = L.leggauss(self.n_panel)
        H_low, H_high = self._energy_edges()
        total = np.zeros(K.size)
        for He, smooth_start in ((H_low, False), (H_high, True)):
            if He.size < 2:
                continue
            A = self.system.amplitude(np.maximum(He - K[:, None], 0.0))
            x_e = np.minimum(np.where(np.isfinite(A), A, X), X)
            if smooth_start:
                u, du = _gl(0.0, np.sqrt(x_e[:, 1:] - x_e[:, :-1]), t, gw)
                xx = x_e[:, :-1, None] + u * u
                w = du * 2.0 * u
            else:
                xx, w = _gl(x_e[:, :-1], x_e[:, 1:], t, gw)
            total += np.sum(w * np.exp(-self.phi(K[:, None, None] + self.system.potential(xx))),
                            axis=(-1, -2))
        return total

    def moments(self) -> dict[str, float]:
        return dict(self._moments)

    # -- persistence --------------------------------------------------------------
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        meta = dict(n_theta=self.n_theta, n_panel=self.n_panel, phi_cut=self.phi_cut,
                    Z=self.Z, H_end=self.H_end, f_end=self.f_end, moments=self._moments)
        arrays = {}
        for name, reg in (("low", self._low), ("high", self._high)):
            arrays[f"{name}_edges"] = reg.edges
            arrays[f"{name}_coef"] = reg.coef
            arrays[f"{name}_phi0"] = reg.phi0
        return meta, arrays

    _meta_schema = {**{k: Rule.of(Options.declared()[k])
                       for k in ("n_theta", "n_panel", "phi_cut")},
                    "Z": Rule.number(0.0, lo_open=True), "H_end": Rule.number(0.0),
                    "f_end": Rule.number(),
                    "moments": Rule.mapping(Rule.number(), MOMENT_KEYS[:5], MOMENT_KEYS)}

    @classmethod
    def _array_schema(cls, meta):
        """Per regime: panel edges (n), Legendre coefficients (n_panel + 1, n - 1), Φ₀ (n - 1)."""
        rows, out = meta["n_panel"] + 1, {}
        for r, least in (("low", 2), ("high", 1)):
            out[f"{r}_edges"] = Stored((r,), min_size=least, nonneg=True, increasing=True)
            out[f"{r}_coef"] = Stored((rows, f"{r}-1"))
            out[f"{r}_phi0"] = Stored((f"{r}-1",))
        return out

    @classmethod
    def _check_state(cls, system, meta, arrays):
        """P_impact among the moments exactly when the system has a barrier."""
        if ("P_impact" in meta["moments"]) != system.has_barrier:
            raise ValueError("meta['moments'] must hold P_impact exactly when the system "
                             f"has a barrier (barriers={system.barriers!r})")

    @classmethod
    def _from_state(cls, system, meta, arrays):
        regimes = tuple(_Regime(arrays[f"{n}_edges"], arrays[f"{n}_coef"], arrays[f"{n}_phi0"])
                        for n in ("low", "high"))
        return cls(system, n_theta=meta["n_theta"], n_panel=meta["n_panel"],
                   phi_cut=meta["phi_cut"], regimes=regimes, Z=meta["Z"],
                   H_end=meta["H_end"], f_end=meta["f_end"], moments=meta["moments"])


def _build_regime(system, H_of, dH_of, t_max, h0, phi_start, phi_cut, n_panel, n_theta):
    """Panels of Φ in variable t from 0 until t_max or Φ ≥ phi_cut (adaptive widths)."""
    tq, gw = L.leggauss(n_panel)
    j = np.arange(n_panel)
    proj = (j[:, None] + 0.5) * L.legvander(tq, n_panel - 1).T * gw   # values → Legendre coefs
    edges, coefs, phi0, nodes = [0.0], [], [], []
    t, h, phi = 0.0, h0, phi_start
    while t < t_max and phi < phi_cut:
        if len(coefs) >= _MAX_PANELS:
            raise ValueError(
                f"averaging: the density decays too slowly to be normalised (Φ = {phi:.3g} "
                f"< {phi_cut} after {_MAX_PANELS} panels, H = {float(H_of(t)):.3g}); the "
                f"parametric noise D2={system.D2} may be too strong for a stationary density")
        t1 = min(t + h, t_max)
        tt, wt = _gl(t, t1, tq, gw)
        H = H_of(tt)
        f, sums = _rate(system, H, n_theta)
        g = f * dH_of(tt)
        inc = float(np.sum(wt * g))
        if inc > 8.0 and (t1 - t) > 1e-9 * max(t1, 1e-300):
            h = 0.5 * (t1 - t)
            continue
        ci = L.legint(proj @ g, lbnd=-1) * (0.5 * (t1 - t))
        nodes.append((H, wt * dH_of(tt), phi + L.legval(tq, ci), sums))
        edges.append(t1)
        coefs.append(ci)
        phi0.append(phi)
        phi += float(L.legval(1.0, ci))
        t = t1
        if inc < 2.0:
            h *= 2.0
    coef = np.stack(coefs, axis=1) if coefs else np.zeros((n_panel + 1, 0))
    return _Regime(np.array(edges), coef, np.array(phi0)), nodes, phi, t


def stationary(system: VibroImpactSystem, *, n_theta: int = 48, n_panel: int = 24,
               phi_cut: float = 60.0) -> AveragedSolution:
    """Stationary density of the averaged energy process (paper Eqs. 22–27).

    Parameters
    ----------
    system : VibroImpactSystem
        G must increase on (0, Δ) (one orbit per energy level), else ValueError.
    n_theta : int
        Gauss–Legendre nodes along each orbit (θ substitution, DESIGN §2).
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
    Gibbs solution (r = 1, D2 = 0) to ~1e-13 relative, and T, m, σ² with adaptive
    quadrature to ~1e-13 (tests/test_averaging.py).
    """
    opts, _ = Options.prepare(system, "stationary", locals())
    return solve(system, opts)


def solve(system: VibroImpactSystem, opts: Options) -> AveragedSolution:
    """The closed form of :func:`stationary` for validated ``opts``."""
    n_theta, n_panel, phi_cut = opts.n_theta, opts.n_panel, opts.phi_cut
    a, b, c = system.a, system.b, system.c
    Hb = system.barrier_energy
    A_max = system.delta if system.has_barrier else np.inf
    # initial panel width from the energy scale D1/c of the Gibbs limit
    if c > 0:
        A0 = float(system.amplitude(system.D1 / c))
        h0 = 0.5 * (A0 if np.isfinite(A0) else A_max)
        h0 = min(h0, A_max)
    else:
        h0 = 0.25 * A_max
    low, nodes, phi, t_end = _build_regime(
        system, system.potential, lambda A: A * (a + b * A * A), A_max, h0, 0.0,
        phi_cut, n_panel, n_theta)
    high = _Regime(np.zeros(1), np.zeros((n_panel + 1, 0)), np.zeros(0))
    H_end = float(system.potential(t_end))
    n_low = len(nodes)
    if system.has_barrier and phi < phi_cut:
        f_b = float(_rate(system, np.array([Hb]), n_theta)[0][0])
        h0 = 0.5 / np.sqrt(f_b) if f_b > 0 else 0.25 * np.sqrt(Hb)
        high, more, phi, s_end = _build_regime(
            system, lambda s: Hb + s * s, lambda s: 2.0 * s, np.inf, h0, phi,
            phi_cut, n_panel, n_theta)
        nodes += more
        H_end = Hb + s_end ** 2
    f_end = float(_rate(system, np.array([H_end]), n_theta)[0][0])

    H = np.concatenate([n[0] for n in nodes])
    w = np.concatenate([n[1] * np.exp(-n[2]) for n in nodes])
    sums = {k: np.concatenate([n[3][k] for n in nodes]) for k in nodes[0][3]}
    Z = float(np.sum(w * sums["T"]))
    mom = {"E_H": float(np.sum(w * sums["T"] * H)) / Z,
           "E_x2": float(np.sum(w * sums["x2"])) / Z,
           "E_y2": float(np.sum(w * sums["y2"])) / Z,
           "E_x4": float(np.sum(w * sums["x4"])) / Z,
           "E_y4": float(np.sum(w * sums["y4"])) / Z}
    # a power-law tail reaches Φ ≥ phi_cut only at astronomic H: its last panel
    # then still carries mass (or moment weight), which a light tail never does
    last = nodes[-1]
    w_last = last[1] * np.exp(-last[2]) * last[3]["T"]
    for name, g in (("the density", 1.0), ("E_H", last[0]), ("E_y4", last[3]["y4"] / last[3]["T"])):
        share = float(np.sum(w_last * g)) / (Z * (mom.get(name, 1.0)))
        if not share < 1e-10:
            raise ValueError(
                f"averaging: {name} does not converge: the averaged density has a power-law "
                f"tail (the last energy panel, H ≈ {float(last[0][-1]):.3g}, holds a share "
                f"{share:.2g}); parametric noise D2={system.D2} is too strong for damping "
                f"c={system.c} here")
    if system.has_barrier:
        k0 = sum(n[0].size for n in nodes[:n_low])
        mom["P_impact"] = float(np.sum(w[k0:] * sums["T"][k0:])) / Z
    return AveragedSolution(system, n_theta=n_theta, n_panel=n_panel, phi_cut=float(phi_cut),
                            regimes=(low, high), Z=Z, H_end=H_end, f_end=f_end, moments=mom)
