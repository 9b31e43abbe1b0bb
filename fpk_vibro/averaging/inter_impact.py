"""The time between successive impacts under averaging (docs/impacts.md).

What it assumes
---------------
Averaging freezes the energy over one orbit (weak damping and noise: the energy
changes little in one quasi-period T(H)).  A path at energy H above the lowest wall
energy E₀ then meets the walls periodically at that energy: once per T(H) when its
orbit reaches one wall, twice when it reaches two, and the two legs between the walls
take T(H)/2 each whatever the walls' positions (the upper and lower velocity branches
of an orbit take equal times).  So the gap that follows an impact at energy H is

    g(H) = T(H)/n(H),   n(H) = number of walls with G(x_w) < H,

and impacts at energy H happen at the rate ν(H) = n(H) p(H)/T(H) (summed over walls:
:mod:`fpk_vibro.averaging.impacts`).  The "periodic" gaps, the impacts' gaps weighted
by the flux ν(H)/ν, have the mean ∫ ν g dH / ν = P_impact/ν: the time the paths spend
below E₀, where they do not impact, is missing from them.  Kac's identity (the mean
gap is 1/ν exactly) puts it back: it is spent in excursions below E₀, each inserted
into one gap.

Excursions.  Averaging sees the energy at the orbit's wall visits, spaced g(E₀) apart;
a path is found below E₀ at a visit on average ρ σ(E₀) sqrt(g(E₀)) below it (the mean
overshoot of a Gaussian walk with that step, ρ = −ζ(½)/sqrt(2π) ≈ 0.5826).  An
excursion lasts the averaged first passage X from E₀ − h up to E₀ (h that depth; its
density from the finite-volume generator of :mod:`fpk_vibro.averaging.first_passage`,
its mean τ_X), and the share q = (1 − P_impact)/(ν τ_X) of the gaps hold one.  The gap
density is

    f(t) = (1 − q) f_per(t) + q (f_per ∗ f_X)(t),

with mean ḡ + q τ_X = P_impact/ν + (1 − P_impact)/ν = 1/ν: Kac's identity holds by
construction, for any h (h shapes only the long-gap tail).  The periodic part is exact
to the averaging order; the excursion tail is a model (q gives its weight).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._checks import InputError, invalid
from ..orbits import energy_floor, orbit_nodes
from .coefficients import coefficients

__all__ = ["InterImpact", "inter_impact", "estimate", "OVERSHOOT", "ASSUMES"]

#: −ζ(1/2)/sqrt(2π): the mean overshoot of a Gaussian random walk over a level, per
#: unit step standard deviation (Siegmund's constant).
OVERSHOOT = 0.5825971579390107
#: Energy cells per regime of the periodic part (each a uniform spread of its gaps).
CELLS = 400
#: Times at which the excursion's distribution is tabulated.
TABLE = 4001
_T8, _W8 = np.polynomial.legendre.leggauss(8)


class InterImpact:
    """The gap law of one averaged stationary solution (module docstring).

    Attributes: ``g_lo``, ``g_hi``, ``mass``, ``g_mean`` (per energy cell: the gap
    range, its share of the impacts and its mean gap), ``rate`` (ν), ``p_impact``,
    ``q`` (share of gaps holding an excursion), ``tau_x`` (mean excursion), ``h``,
    ``survival_x`` (R_X(t), vectorised) and ``info``.
    """

    def __init__(self, sol: Any) -> None:
        s = sol.system
        if not s.walls:
            raise invalid(f"{type(sol).__name__}.inter_impact_pdf", "system",
                          "a system with a wall (without walls there are no impacts)",
                          "barriers = 'none'")
        self.energies = np.array(sorted(float(s.potential(w.position)) for _, w in s.walls))
        E0 = float(self.energies[0])
        cells_H, cells_w = self._nodes(sol)
        n = np.sum(cells_H[..., None] > self.energies, axis=-1)
        T = orbit_nodes(s, cells_H, sol.n_theta).period
        p = sol.pdf_energy(cells_H)
        with np.errstate(divide="ignore", invalid="ignore"):
            nu = np.where(T > 0, n * p / T, 0.0) * cells_w
            g = np.where(n > 0, T / np.maximum(n, 1), 0.0)
        self.mass_abs = nu.sum(axis=-1)
        self.rate = float(self.mass_abs.sum())
        if not self.rate > 0.0:
            raise InputError(f"{type(sol).__name__}.inter_impact_pdf: the density never "
                             "reaches a wall (impact rate 0): there is no time between "
                             "impacts", where=f"{type(sol).__name__}.inter_impact_pdf",
                             name="system")
        self._cells = (cells_H, cells_w, nu, g)
        self.p_impact = float(np.sum(p * cells_w))
        self.mass = self.mass_abs / self.rate
        self.g_mean = np.sum(nu * g, axis=-1) / np.where(self.mass_abs > 0, self.mass_abs, 1.0)
        self.g_lo, self.g_hi = g.min(axis=-1), g.max(axis=-1)
        self.info: dict[str, Any] = {"E0": E0}
        self._excursions(sol, E0)

    def _nodes(self, sol: Any) -> tuple[np.ndarray, np.ndarray]:
        """Gauss nodes (cells × 8) in H and their weights, cells uniform in
        s = sqrt(H − E) above each wall energy E up to the next (or the top)."""
        from .impacts import _top
        top = max(_top(sol), float(self.energies[-1]) * (1 + 1e-9) + 1e-12)
        bounds = np.append(self.energies, top)
        Hs, Ws = [], []
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            if not hi > lo:
                continue
            edges = np.linspace(0.0, math.sqrt(hi - lo), CELLS + 1)
            half = 0.5 * np.diff(edges)[:, None]
            sv = 0.5 * (edges[1:] + edges[:-1])[:, None] + half * _T8
            Hs.append(np.minimum(lo + sv * sv, hi))
            Ws.append(half * _W8 * 2.0 * sv)
        return np.concatenate(Hs), np.concatenate(Ws)

    def _excursions(self, sol: Any, E0: float) -> None:
        from .first_passage import _eigen_survival, _log_tau
        s = sol.system
        floor = energy_floor(s)
        self.q, self.tau_x, self.h = 0.0, 0.0, 0.0
        self.survival_x = None
        self._table = None
        below = 1.0 - self.p_impact
        if not E0 > floor or below <= 1e-14:
            self.info["excursions"] = "none: every orbit meets a wall"
            return
        above = self.mass_abs > 0
        k = int(np.argmax(above))                   # the first cell above E0
        g0 = float(self.g_lo[k])
        _, _, s2 = coefficients(s, np.array([E0]), n_theta=sol.n_theta)
        self.h = min(OVERSHOOT * math.sqrt(float(s2[0]) * g0), 0.5 * (E0 - floor))
        H0 = E0 - self.h
        x0 = float(s.amplitude(H0))        # floor 0 here: the strip holds x = 0
        u, ltau = _log_tau(s, sol, E0, 2000)
        tau = float(np.exp(np.interp(H0, u, ltau)))
        info: dict[str, Any] = {}
        surv = _eigen_survival(s, sol, E0, 400, "point", (x0, 0.0), tau, info)
        if surv is None:
            def surv(t, tau=tau):
                return np.exp(-np.asarray(t, dtype=float) / tau)
        else:
            tau = float(info["tau_fv"])
        self.tau_x, self.survival_x = tau, surv
        self.q = below / (self.rate * tau)
        self.info.update(h=self.h, tau_x=tau, q=self.q,
                         excursion_survival=info.get("survival_method"))

    @property
    def periodic_mean(self) -> float:
        """ḡ = Σ mass × cell mean gap = P_impact/ν (the identity ν(H) g(H) = p(H))."""
        return float(np.sum(self.mass * self.g_mean))

    @property
    def mean(self) -> float:
        """ḡ + q τ_X: 1/ν (Kac) by construction."""
        return self.periodic_mean + self.q * self.tau_x

    def _F_x(self, t: np.ndarray) -> np.ndarray:
        """CDF of the excursion X (0 for t ≤ 0), from R_X tabulated once on
        TABLE times up to 60 τ_X (R_X ~ e^-60 there) and interpolated linearly."""
        if self._table is None:
            grid = self.tau_x * 60.0 * np.linspace(0.0, 1.0, TABLE) ** 2
            R = np.asarray(self.survival_x(grid), dtype=float).reshape(grid.shape)
            R = np.minimum.accumulate(np.clip(R, 0.0, 1.0))
            R[0] = 1.0
            self._table = (grid, 1.0 - R)
        grid, F = self._table
        return np.interp(t, grid, F, left=0.0, right=1.0)

    def pdf(self, t: np.ndarray) -> np.ndarray:
        """f(t) at the times ``t`` (module docstring), each cell's share spread evenly
        over its gap range [g_lo, g_hi]."""
        t = np.asarray(t, dtype=float)
        flat = t.ravel()
        out = np.zeros(flat.size)
        keep = self.mass > 0
        lo, hi, m = self.g_lo[keep], self.g_hi[keep], self.mass[keep]
        width = hi - lo
        narrow = width <= 1e-12 * np.maximum(hi, 1e-300)
        w_safe = np.where(narrow, 1.0, width)
        for a in range(0, flat.size, 256):
            b = flat[a:a + 256, None]
            inside = (b >= lo) & (b < hi) & ~narrow
            per = np.sum(np.where(inside, m / w_safe, 0.0), axis=1)
            if self.q > 0.0:
                Fl, Fh = self._F_x(b - lo), self._F_x(b - hi)
                conv = np.where(narrow, (Fl - self._F_x(b - lo - 1e-9 * np.maximum(lo, 1)))
                                / (1e-9 * np.maximum(lo, 1)), (Fl - Fh) / w_safe)
                out[a:a + 256] = (1.0 - self.q) * per + self.q * np.sum(m * conv, axis=1)
            else:
                out[a:a + 256] = per
        return np.maximum(out, 0.0).reshape(t.shape)


def inter_impact(sol: Any) -> InterImpact:
    """The :class:`InterImpact` law of ``sol`` (made once and kept on it)."""
    law = getattr(sol, "_inter_impact", None)
    if law is None:
        law = InterImpact(sol)
        sol._inter_impact = law
    return law


ASSUMES = ("the energy nearly constant over one orbit (weak damping and noise): impacts "
           "at the current energy once per orbit per wall reached; excursions below the "
           "lowest wall energy from the averaged first passage (their shape is a model: "
           "excursion_share says how many gaps hold one)")


def estimate(sol: Any, reference: Any = None) -> dict[str, Any]:
    """How far to trust the averaged gap law of ``sol``.

    Returns
    -------
    dict
        ``mean``: |τ̄ − τ̄_ref|/τ̄_ref against the reference's mean gap
        (``mean_inter_impact_time()`` where it has one, else 1/its total rate, which
        Kac's identity makes the same), plus the reference's own estimate of P_impact
        as its share; the reference is ``reference`` or ``fem.stationary`` of the same
        system (infinite, with the reason, where FE refuses).  ``excursion_share``: q,
        the share of gaps whose length rests on the excursion model.
        ``frozen_energy``: the flux-weighted mean of sqrt(σ² g)/(H − G(x_w)) over
        the impacts (the diffusive energy change over one gap against the kinetic
        energy at the wall, capped at 1): what averaging assumes small.
        ``reference``, ``assumes``, ``seconds``.
    """
    import time
    from ..references import reference as solve_reference
    t0 = time.perf_counter()
    law = inter_impact(sol)
    H, w, nu, g = law._cells
    _, _, s2 = coefficients(sol.system, H.ravel(), n_theta=sol.n_theta)
    kin = H - law.energies[np.clip(np.searchsorted(law.energies, H) - 1, 0, None)]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.minimum(np.sqrt(s2.reshape(H.shape) * g) / kin, 1.0)
    frozen = float(np.sum(np.where(nu > 0, nu * ratio, 0.0)) / law.rate)
    out: dict[str, Any] = {"mean": math.inf, "excursion_share": float(law.q),
                           "frozen_energy": frozen, "assumes": ASSUMES}
    try:
        ref = reference if reference is not None else solve_reference("fem", sol.system)
        try:
            ref_mean = float(ref.mean_inter_impact_time())
            how = "its mean_inter_impact_time()"
        except NotImplementedError:
            ref_mean = 1.0 / sum(v["rate"] for v in ref.impacts().values())
            how = "1/its total impact rate (Kac)"
        try:
            own = float(ref.error_estimate().get("P_impact", 0.0))
        except (NotImplementedError, ValueError, InputError):
            own = math.inf
    except (InputError, ValueError, MemoryError) as exc:
        out["reference"] = "none: fem refused (" + " ".join(str(exc).split()) + ")"
    else:
        out["mean"] = abs(law.mean - ref_mean) / ref_mean + own
        out["reference"] = f"{getattr(ref, 'kind', type(ref).__name__)}: {how} = {ref_mean:.6g}"
    out["seconds"] = time.perf_counter() - t0
    return out
