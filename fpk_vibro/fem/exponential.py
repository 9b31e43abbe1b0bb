"""Positivity-preserving transients by the exponential of the positive generator.

Uniformisation: with the positive tensor-grid generator A and lumped masses diag(m)
(:mod:`fpk_vibro.fem.positivity`), B = diag(m)⁻¹ A has non-negative off-diagonals,
so every term of the Poisson series of exp(τB) is non-negative
(docs/theory.md, §Transients).
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp

from .._checks import check_float
from ..initial import parse_times
from ..model import VibroImpactSystem, check_system
from .discretisation import Discretisation
from .solution import FEMSolution
from .transient import _initial_vector, _snapshot, default_dt, discretise

__all__ = ["exponential"]


def exponential(system: VibroImpactSystem, *, initial: Any, times: Sequence[float],
                positivity: bool | str = "first-order", dt: float | None = None,
                nx: int | None = None, ny: int | None = None, y_max: float | None = None,
                discretisation: Discretisation | None = None) -> list[FEMSolution]:
    """Non-negative densities at ``times`` by the exponential of the positive generator.

    With the positive tensor-grid generator A and lumped masses diag(m) (module
    docstring), B = diag(m)⁻¹ A has non-negative off-diagonals, so with c ≥ max |B_ii|
    the matrix P = I + B/c is entrywise non-negative and exp(τB) = Σ_k w_k P^k with
    Poisson weights w_k = e^(−cτ)(cτ)^k/k! (uniformisation).  Every term is
    non-negative, so the result is ≥ 0 in floating point, and mᵀP = mᵀ keeps the mass.

    - ``"first-order"``: A is constant and p(t) = exp(tB) p(0) is exact in time (the
      Poisson series is cut where its tail is below 1e-15); first order in space.
    - ``True``/``"quick"``/``"van-albada"``: A = A(g(p)) with the clipped high-order
      flux factors; exponential midpoint rule with steps of at most ``dt``:
      p* = exp(h B(pⁿ)) pⁿ, pⁿ⁺¹ = exp(h B((pⁿ + p*)/2)) pⁿ — non-negative for any h.

    Parameters
    ----------
    system : VibroImpactSystem
    initial, times
        As in :func:`transient`.
    positivity : bool or {"quick", "van-albada", "first-order"}
        The positive generator to exponentiate.
    dt : float, optional
        Largest step of the limited variants (default :func:`default_dt`); unused
        for "first-order".
    nx, ny, y_max
        The structured Q1 grid, as in :func:`fpk_vibro.fem.stationary`.
    discretisation : Discretisation, optional
        A positive discretisation from :func:`discretise` to reuse.

    Returns
    -------
    list of FEMSolution
        One per time, with ``info["matvecs"]`` the products with P so far.
    """
    check_system("fem.exponential", system)
    t_out = parse_times(times, "fem.exponential")
    disc = discretisation or discretise(system, nx=nx, ny=ny, y_max=y_max,
                                        positivity=positivity)
    if disc.kind != "positive":
        raise ValueError("fem.exponential: needs a positive discretisation "
                         f"(positivity True, 'quick', 'van-albada' or 'first-order'); "
                         f"got {disc.positivity!r}")
    positivity = disc.positivity
    linear = positivity == "first-order"
    dt = default_dt(system) if dt is None else check_float("dt", dt, 0.0, math.inf,
                                                           lo_open=True, where="fem.exponential")
    inv_m = sp.diags(1.0 / disc.unit)
    count = [0]

    def propagator(A):
        B = (inv_m @ A).tocsr()
        c = float(np.max(-B.diagonal()))
        c = c if c > 0 else 1.0
        return (sp.identity(B.shape[0], format="csr") + B / c).tocsr(), c

    def expm(P, c, p, tau):
        vec, n = _uniformised(P, c, p, tau)
        count[0] += n
        return vec

    p = _initial_vector(disc, initial)
    if linear:
        P, c = propagator(disc.L)
    out: list[FEMSolution] = []
    t_now = 0.0
    for t_target in t_out:
        span = float(t_target) - t_now
        if span > 0 and linear:
            p = expm(P, c, p, span)
        elif span > 0:
            n = int(math.ceil(span / dt - 1e-9))
            h = span / n
            for _ in range(n):
                P0, c0 = propagator(disc.limited_generator(p))
                q = expm(P0, c0, p, h)
                P1, c1 = propagator(disc.limited_generator(0.5 * (p + q)))
                p = expm(P1, c1, p, h)
        t_now = float(t_target)
        out.append(_snapshot(disc, p, t_now, scheme="exponential", positivity=positivity,
                             matvecs=count[0]))
    return out


def _uniformised(P, c: float, p: np.ndarray, tau: float, chunk: float = 400.0,
                 eps: float = 1e-15) -> tuple[np.ndarray, int]:
    """exp(τ c (P − I)) p by the Poisson series, in substeps of c·τ ≤ ``chunk``.

    Returns the vector and the number of products with P.
    """
    from scipy.special import gammaln
    n_sub = max(1, int(math.ceil(c * tau / chunk)))
    lam = c * tau / n_sub
    kmax = int(lam + 12.0 * math.sqrt(lam) + 30)
    k = np.arange(kmax + 1)
    w = np.exp(k * math.log(lam) - lam - gammaln(k + 1)) if lam > 0 else (k == 0) * 1.0
    cum = np.cumsum(w)
    last = int(np.searchsorted(cum, cum[-1] * (1.0 - eps)))
    first = int(np.searchsorted(cum, cum[-1] * eps))
    w = w[:last + 1] / w[:last + 1].sum()    # the cut tail is redistributed: mass kept
    for _ in range(n_sub):
        term = p
        acc = w[0] * p
        for j in range(1, last + 1):
            term = P @ term
            if j >= first:
                acc += w[j] * term
        p = acc
    return p, n_sub * last
