"""The slowest decay rate of the FE transient operator (:func:`relaxation_time`;
also importable from :mod:`fpk_vibro.fem.transient`)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse.linalg as spla

from .._checks import check_float
from ..model import VibroImpactSystem
from .discretisation import Discretisation, discretise

__all__ = ["relaxation_time"]


def relaxation_time(system: VibroImpactSystem, *, tol: float = 1e-3,
                    discretisation: Discretisation | None = None, **mesh_kw: Any
                    ) -> dict[str, float]:
    """Slowest decay rate of the FE operator and the time to relax to ``tol`` in L1.

    The generalised eigenproblem L v = λ M v has λ0 = 0 (the stationary density)
    and Re λ < 0 otherwise; the slowest rate is λ1 = min |Re λ| over the rest
    (``scipy.sparse.linalg.eigs`` in shift-invert mode near 0).  A perturbation of
    L1 size ε0 ~ 1 decays below ``tol`` after about ln(1/tol)/λ1.

    Returns
    -------
    dict with ``rate`` (λ1), ``time`` (ln(1/tol)/λ1) and ``eigenvalues`` (the few
    computed, sorted by |Re|).
    """
    check_float("tol", tol, 0.0, 1.0, hi_open=True, where="fem.relaxation_time")
    disc = discretisation or discretise(system, **mesh_kw)
    sigma = -1e-6
    vals = spla.eigs(disc.L.tocsc(), k=6, M=disc.M.tocsc(), sigma=sigma,
                     return_eigenvectors=False)
    vals = vals[np.argsort(np.abs(vals.real))]
    rest = vals[np.abs(vals) > 1e-8 * max(1.0, np.abs(vals).max())]
    rate = float(np.min(np.abs(rest.real)))
    return {"rate": rate, "time": math.log(1.0 / tol) / rate,
            "eigenvalues": [complex(v) for v in vals]}

