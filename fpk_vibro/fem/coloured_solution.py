"""`ColouredFEMSolution`: the stationary (x, y, ζ) density of coloured noise, read
through its ζ-marginal.

The 3-D FE density p_h(x, y, ζ) = Σ P_ijk ψ_i(x) χ_j(y) θ_k(ζ) integrates over ζ
exactly to the 2-D tensor function p_h(x, y) = Σ_ij (Σ_k P_ijk ∫θ_k) ψ_i χ_j on the
same (x, y) bases: that function is an ordinary :class:`FEMSolution`, so
``pdf_joint(x, y)`` (the ζ-marginal), ``pdf_x``, ``pdf_y``, ``pdf_energy``, the
moments, P_impact and the impact statistics (the wall traces p(x_w, y), integrated
over ζ) are those of the 2-D class.  What needs ζ is kept beside it: the ζ-marginal
p(ζ) on its nodes (:meth:`pdf_zeta`) and E[ζ²], E[ζ y] (:meth:`coloured_moments`,
the power the force puts in, which :meth:`power_balance` uses).  The impact-to-impact
records (inter-impact times, first passage) depend on ζ at the impact and are not
given by this class.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .._checks import InputError
from ..solution_file import Rule, Stored
from .solution import FEMSolution
from .solution_files import META_SCHEMA, array_schema

__all__ = ["ColouredFEMSolution"]


class ColouredFEMSolution(FEMSolution):
    """The ζ-marginal of the stationary 3-D FE density (module docstring).

    Attributes
    ----------
    zeta_nodes, zeta_density : ndarray
        The ζ-mesh's vertices and the coefficients of p(ζ) on its Lagrange basis (of
        the solution's degree: nodal values).
    """

    kind = "fem_coloured"

    def __init__(self, *args: Any, zeta: dict | None = None,
                 zeta_nodes: np.ndarray | None = None,
                 zeta_density: np.ndarray | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.zeta = {k: float(v) for k, v in (zeta or {}).items()}
        self.zeta_nodes = np.asarray(zeta_nodes, float)
        self.zeta_density = np.asarray(zeta_density, float)

    def coloured_moments(self) -> dict[str, float]:
        """E[ζ²] and E[ζ y] of the 3-D density (its ζ-quadrature is exact)."""
        return {"E_zeta2": self.zeta["E_zeta2"], "E_zeta_y": self.zeta["E_zeta_y"]}

    def pdf_zeta(self, z: Any) -> np.ndarray:
        """p(ζ), the ζ-marginal of the FE density (zero beyond ±ζ_max).  Exactly
        N(0, D1/τ) for the true density, whatever the oscillator."""
        from .generator import assemble_tensor_bases
        z = np.asarray(z, float)
        flat = z.ravel()
        out = np.zeros(flat.size)
        inside = (flat >= self.zeta_nodes[0]) & (flat <= self.zeta_nodes[-1])
        if inside.any():
            bz = assemble_tensor_bases(self.zeta_nodes, self.zeta_nodes, self.degree)[0]
            out[inside] = bz.probes(flat[inside][None, :]) @ self.zeta_density
        return np.maximum(out, 0.0).reshape(z.shape)

    def _inter_impact(self):
        raise InputError("fem: inter-impact times of a system with coloured noise need ζ "
                         "at the impact, which the ζ-marginal does not keep; use "
                         "montecarlo.stationary", where="fem", name="external")

    # -- persistence ---------------------------------------------------------------
    _meta_schema = {**META_SCHEMA, "zeta": Rule.mapping(Rule.SCALAR)}

    def _state(self):
        meta, arrays = super()._state()
        meta["zeta"] = dict(self.zeta)
        arrays["zeta_nodes"], arrays["zeta_density"] = self.zeta_nodes, self.zeta_density
        return meta, arrays

    @classmethod
    def _array_schema(cls, meta):
        out = array_schema(meta)
        out["zeta_nodes"] = Stored(("nz",), min_size=2, increasing=True)
        out["zeta_density"] = Stored(("nzdofs",), nonneg=True)
        return out

    @classmethod
    def _from_state(cls, system, meta, arrays):
        sol = FEMSolution._from_state.__func__(cls, system, meta, arrays)
        sol.zeta = dict(meta["zeta"])
        sol.zeta_nodes, sol.zeta_density = arrays["zeta_nodes"], arrays["zeta_density"]
        return sol
