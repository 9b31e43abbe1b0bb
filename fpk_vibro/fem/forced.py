"""The forcing's operator on a transient's discretisation: M ṗ = (L0 + F cos ψ L1) p
with L1 of :func:`fpk_vibro.fem.harmonic.forcing_matrix`, for the IMEX-BDF2 steps of
:func:`fpk_vibro.fem.transient` (the constant L0 implicit with its kept
factorisations, F cos ψ L1 p explicit from the second-order extrapolation of p)."""
from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
import skfem

from .._checks import InputError
from . import forms
from .generator import assemble_tensor_bases
from .harmonic import forcing_matrix

__all__ = ["forcing_operator", "ForcingTerm"]


def forcing_operator(disc: Any, where: str = "fem.transient") -> sp.csr_matrix:
    """L1 in the solver's order of a Galerkin tensor discretisation."""
    if disc.tensor is None or disc.assembly != "tensor" or disc.positivity not in (
            False, "auto") or disc.kind != "galerkin":
        raise InputError(f"{where}: a forced system needs the Galerkin structured "
                         "quadrilateral mesh with tensor assembly (no mesh, no "
                         f"positivity); got {disc.kind} / {disc.assembly} assembly",
                         where=where, name="system")
    bx, by = assemble_tensor_bases(*disc.tensor, disc.degree)
    Mx = skfem.asm(forms.weighted_mass_1d, bx, coef=(1.0,))
    return forcing_matrix(bx, by, Mx)


class ForcingTerm:
    """h F cos(Ωt + φ0) L1 p* for a step of length h ending at t."""

    def __init__(self, system: Any, disc: Any, where: str = "fem.transient") -> None:
        self.f = system.forcing
        self.L1 = forcing_operator(disc, where)

    def __call__(self, t: float, h: float, p_star: np.ndarray) -> np.ndarray:
        return (h * self.f.force(t)) * (self.L1 @ p_star)
