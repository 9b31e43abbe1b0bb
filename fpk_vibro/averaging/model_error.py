"""The model error of an averaged density against a finite-element density of the
same system: the one formula of the stationary estimate
(:func:`fpk_vibro.averaging.validity.model_error`) and of a transient's
(:meth:`fpk_vibro.averaging.EnergyGridSolution.error_estimate`),

    estimate_k = |q_k(averaging) − q_k(FE)| / scale_k + estimate_k(FE),

for k = E[H], E[x²], E[y²], P_impact (scale_k: :func:`fpk_vibro.keys.moment_scale`,
|q_k(FE)|, at least 1e-3 for P_impact), and the L1 distance of the joint densities
plus FE's own L1 estimate.  An FE figure that is infinite (FE unresolved) makes the
sum infinite.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..keys import JUDGED, moment_scale

__all__ = ["judged_keys", "against", "unbounded", "l1"]


def judged_keys(sol: Any) -> list[str]:
    """The judged moments ``sol`` has (P_impact only with walls)."""
    m = sol.moments()
    return [k for k in JUDGED if k in m]


def against(sol: Any, ref: Any, fe_est: dict[str, Any]) -> dict[str, float]:
    """The per-key model error of ``sol`` against the FE density ``ref`` whose own
    estimate is ``fe_est`` (module docstring): the judged moments and ``L1``."""
    m, r = sol.moments(), ref.moments()
    out = {k: abs(m[k] - r[k]) / moment_scale(k, r[k]) + float(fe_est[k])
           for k in judged_keys(sol)}
    out["L1"] = l1(sol, ref) + float(fe_est["L1"])
    return out


def unbounded(sol: Any) -> dict[str, float]:
    """Every figure infinite: no FE density to compare with."""
    return {k: math.inf for k in judged_keys(sol) + ["L1"]}


def l1(sol: Any, ref: Any) -> float:
    """∫|p_averaging − p_FE| over FE's strip (a Gauss rule on FE's tensor grid)."""
    from ..quadrature import gauss_grid
    xs, ys = ref._tensor
    xq, wx = gauss_grid(np.asarray(xs, float), ref.degree + 2)
    yq, wy = gauss_grid(np.asarray(ys, float), ref.degree + 2)
    total = 0.0
    step = max(1, 400_000 // yq.size)
    for i in range(0, xq.size, step):
        X, Y = np.meshgrid(xq[i:i + step], yq, indexing="ij")
        diff = np.abs(sol.pdf_joint(X, Y) - ref.pdf_joint(X, Y))
        total += float(wx[i:i + step] @ diff @ wy)
    return total
