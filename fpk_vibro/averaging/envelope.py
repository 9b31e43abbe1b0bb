"""The orbits' Fourier series and the phase and energy diffusion of the energy envelope:
what :mod:`fpk_vibro.averaging.spectrum` builds its spectrum from.

Harmonics.  On the orbit of energy H (period T, Ω = 2π/T; with walls it reflects at
them, :mod:`fpk_vibro.orbits`) the phase θ = Ω t is counted from the orbit's left end
(a turning point or a wall).  Then x is even and y odd in θ:

    x = c₀ + Σ_k 2 c_k cos kθ,   c_k = (2/T) ∫₀^{T/2} x cos kΩt dt,
    y = Σ_k 2 s_k sin kθ,        s_k = (2/T) ∫₀^{T/2} |y| sin kΩt dt,

integrated on the orbit nodes (one traversal, in the θ-substitution variable ϑ of
:mod:`fpk_vibro.orbits`), the time t(ϑ) being the spectral antiderivative of dt/dϑ on
the same nodes.  The coefficients keep their sign (it matters when H moves).

Phase diffusion.  The noise in dy = ... + sqrt(2D(x)) dW moves the phase too:
dθ = Ω dt + (∂θ/∂y)_x sqrt(2D) dW + ....  Averaged over the orbit, the drift terms
and the correlation with the energy's noise cancel between the two velocity
branches (the orbit is time-reversal symmetric), and e^{ikθ} loses coherence at
k² σ_φ²/2 with

    σ_φ² = ⟨2D(x) g²⟩,   g = y (∂θ/∂H)_x = v [Ω' τ + Ω (∂τ/∂H)_ϑ] − Ω A' sin ϑ,

τ(ϑ, H) the time from the left end, A the amplitude (G(A) = H, A' = 1/G'(A)) and
(∂τ/∂H)_ϑ = ∫ ∂_H(1/w) dϑ − ∂_H ϑ_lo / w(ϑ_lo), ϑ_lo = arcsin(x_L/A) at a wall
(the terms at a turning point vanish).  Linear spring: σ_φ² = D1/(2H).  Where no
amplitude exists (softening spring above its hilltop, orbits spanning the strip) the
nodes are in x and g = v [Ω' τ + Ω (∂τ/∂H)_x].
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.polynomial import legendre as L

from ..model import VibroImpactSystem
from ..orbits import energy_floor

__all__ = ["orbit_terms"]


@lru_cache(maxsize=16)
def _antiderivative(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(τ, gw, Q): Gauss–Legendre nodes and weights on [−1, 1] and Q with
    (Q @ f)_j = ∫_{−1}^{τ_j} f (exact for polynomials of degree < n)."""
    tau, gw = L.leggauss(n)
    coef = (L.legvander(tau, n - 1) * gw[:, None] * (np.arange(n) + 0.5)).T
    anti = np.stack([L.legval(tau, L.legint(np.eye(n)[k], lbnd=-1.0)) for k in range(n)], 1)
    return tau, gw, anti @ coef


def _nodes(system: VibroImpactSystem, H: np.ndarray, n: int) -> dict[str, np.ndarray]:
    """Nodes of one traversal (as :func:`fpk_vibro.orbits.orbit_nodes`) with what the
    phase diffusion needs: x, v, dt/ds (s the reference variable), d(dt/ds)/dH, the
    end terms of ∂τ/∂H, ∂ϑ/∂H at fixed x times v, per energy (rows)."""
    tau, gw, _ = _antiderivative(n)
    lo, hi = system.x_bounds
    a, b = system.a, system.b
    A = system.amplitude(np.maximum(H, min(0.0, energy_floor(system))))[:, None]
    has_A = np.isfinite(A) & (A > 0)
    A = np.where(has_A, A, 1.0)
    dA = 1.0 / (a * A + b * A ** 3)                           # A'(H) = 1/G'(A)
    q_hi, q_lo = np.clip(hi / A, -1.0, 1.0), np.clip(lo / A, -1.0, 1.0)
    th_hi, th_lo = np.arcsin(q_hi), np.arcsin(q_lo)
    th_hi = np.maximum(th_hi, th_lo)
    # ∂ϑ_end/∂H = −tan ϑ_end A'/A at a wall (inside the turning points), 0 at a turning point
    d_hi = np.where(np.abs(q_hi) < 1.0, -np.tan(th_hi) * dA / A, 0.0)
    d_lo = np.where(np.abs(q_lo) < 1.0, -np.tan(th_lo) * dA / A, 0.0)
    mid, half = 0.5 * (th_hi + th_lo), 0.5 * (th_hi - th_lo)
    th = mid + half * tau
    s = np.sin(th)

    def w_of(t):
        return np.sqrt(a + 0.5 * b * A ** 2 * (1.0 + np.sin(t) ** 2))
    w = w_of(th)
    dinv_w = -b * A * dA * (1.0 + s * s) / (2.0 * w ** 3)       # ∂(1/w)/∂H at fixed ϑ
    out = {"x": A * s, "v": A * np.cos(th) * w, "dt": half / w, "ddt": half * dinv_w,
           "start": -d_lo / w_of(th_lo), "end": d_hi / w_of(th_hi), "sin_term": dA * s}
    if not np.all(has_A):             # softening above its hilltop: nodes in x, no amplitude
        m = ~has_A[:, 0]
        xg = 0.5 * (hi + lo) + 0.5 * (hi - lo) * tau
        vg = np.sqrt(np.maximum(2.0 * H[m, None] - 2.0 * system.potential(xg), 1e-300))
        hx = 0.5 * (hi - lo)
        for key, val in (("x", xg + 0 * vg), ("v", vg), ("dt", hx / vg), ("ddt", -hx / vg ** 3),
                         ("start", 0.0 * vg[:, :1]), ("end", 0.0 * vg[:, :1]),
                         ("sin_term", 0.0 * vg)):
            out[key] = out[key].copy()
            out[key][m] = val
    return out


def orbit_terms(system: VibroImpactSystem, H: np.ndarray, K: int, n: int, of: str
                ) -> dict[str, np.ndarray]:
    """Per energy H (1-D): ``omega`` Ω, ``c`` the signed coefficients c_k or s_k
    (k = 1..K, shape (H, K)), ``c0``, ``msq`` the orbit mean of q², ``sigma2`` the
    energy's diffusion (2/T) J2, ``phase2`` σ_φ², ``loss`` d(H) = (2cJ1)/T (damping's
    share; the impacts' is added by the caller) (module docstring).

    Examples
    --------
    The linear spring: x = −A cos θ from the left turning point, so c₁ = −A/2, and
    σ_φ² = D1/(2H):

    >>> import numpy as np
    >>> from fpk_vibro import VibroImpactSystem
    >>> s = VibroImpactSystem(a=4.0, b=0.0, c=0.1, D1=0.02, barriers="none")
    >>> o = orbit_terms(s, np.array([0.5]), 3, 48, "x")
    >>> A = np.sqrt(2 * 0.5 / 4.0)
    >>> np.allclose([o["omega"][0], o["c"][0, 0], o["phase2"][0]], [2.0, -A / 2, 0.02])
    True
    >>> bool(np.allclose(o["c"][0, 1:], 0.0, atol=1e-14))
    True
    """
    H = np.asarray(H, dtype=float)
    _, gw, Q = _antiderivative(n)
    nd = _nodes(system, H, n)
    x, v, dt = nd["x"], nd["v"], nd["dt"]
    wt = dt * gw                                            # dt weights of one traversal
    half = np.sum(wt, -1)                                   # T/2
    ok = half > 0
    safe = np.where(ok, half, 1.0)
    omega = np.pi / safe
    t = dt @ Q.T                                            # time from the left end
    d_half = np.sum(nd["ddt"] * gw, -1) + nd["end"][:, 0] + nd["start"][:, 0]
    d_omega = -np.pi * d_half / safe ** 2
    dtau = nd["ddt"] @ Q.T + nd["start"]                    # (∂τ/∂H) at fixed ϑ
    g = v * (d_omega[:, None] * t + omega[:, None] * dtau) - omega[:, None] * nd["sin_term"]
    D = system.noise_intensity(x)
    phase = omega[:, None] * t
    q = x if of == "x" else v
    wq = wt * q
    c1, s1 = np.cos(phase), np.sin(phase)
    c = np.empty((H.size, K))
    ck, sk = c1, s1
    for k in range(K):                                      # cos kφ, sin kφ by the angle sum
        c[:, k] = np.sum(wq * (ck if of == "x" else sk), -1)
        ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
    inv = np.where(ok, 1.0 / safe, 0.0)
    return {"omega": np.where(ok, omega, 0.0), "c": c * inv[:, None],
            "c0": (np.sum(wq, -1) * inv) if of == "x" else np.zeros(H.size),
            "msq": np.sum(wq * q, -1) * inv,
            "sigma2": np.sum(wt * 2.0 * v * v * D, -1) * inv,
            "phase2": np.sum(wt * 2.0 * D * g * g, -1) * inv,
            "loss": system.c * np.sum(wt * v * v, -1) * inv}
