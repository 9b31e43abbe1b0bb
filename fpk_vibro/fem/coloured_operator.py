"""The FPK generator in (x, y, ζ) for coloured external noise, by Kronecker factors.

Theory: docs/theory.md, §Coloured noise.  With the external force an
Ornstein–Uhlenbeck process ζ (:mod:`fpk_vibro.noise`) the probability flux is

    J = ( y p,  (−c y − a x − b x³ + ζ) p − D2 x² ∂p/∂y,  −(ζ/τ) p − (D1/τ²) ∂p/∂ζ ),

on the box (strip) × (−ζ_max, ζ_max).  Every term of ∫ J·∇q is a product of 1-D
factors, so L is a sum of three-factor Kronecker products on tensor hexahedra
(:func:`fpk_vibro.fem.kron.kron_sum`), DOF (i, j, k) ↦ (i·n_y + j)·n_ζ + k:

    L = A ⊗ M_ζ + (M_x ⊗ C_y) ⊗ W_ζ + (M_x ⊗ M_y) ⊗ K_ζ,

with A the 2-D operator of the white system without its D1 diffusion (transport,
restoring force, damping, parametric diffusion and the impact coupling of each wall:
:func:`fpk_vibro.fem.generator.tensor_terms`), C_y = ∫ χ_l χ_k' (the drift ζ moves
y), W_ζ = ∫ ζ θ_n θ_m and K_ζ = −(1/τ) ∫ ζ θ_n θ_m' − (D1/τ²) ∫ θ_n' θ_m' (the OU
generator).  The impact coupling acts on every ζ-slice (A ⊗ M_ζ): ζ is continuous
at an impact, and 1ᵀ(B_wall ⊗ M_ζ) = (1ᵀ B_wall) ⊗ (1ᵀ M_ζ) = 0 keeps the mass exact.
At ζ = ±ζ_max the flux is zero (the natural condition of the weak form), so every
column of L sums to zero as in 2-D.

The ζ-marginal of ζ is exactly N(0, D1/τ) whatever the oscillator does (ζ is
autonomous), so ζ_max = :data:`Z_SPREAD` standard deviations leaves a mass below
1e-8 outside, and the discrete p(ζ) is a check of the solve.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import skfem

from ..model import VibroImpactSystem
from . import forms
from .generator import assemble_tensor_bases, mesh_domain, tensor_terms
from .kron import kron_sum
from .mesh import Domain

__all__ = ["ColouredOperator", "assemble_coloured", "zeta_nodes", "Z_SPREAD"]

#: ζ_max in standard deviations sqrt(D1/τ): the Gaussian mass beyond is 1.2e-8.
Z_SPREAD = 5.7


def zeta_nodes(system: VibroImpactSystem, n: int, z_max: float | None = None) -> np.ndarray:
    """``n + 1`` uniform nodes on [−ζ_max, ζ_max] (n even: ζ = 0 a node)."""
    if z_max is None:
        z_max = Z_SPREAD * math.sqrt(system.external.variance(system.D1))
    return np.linspace(-z_max, z_max, n + 1)


@dataclass
class ColouredOperator:
    """L in (x, y, ζ) and its factors (module docstring).

    Attributes
    ----------
    L : csr_matrix
        The generator, DOF (i, j, k) ↦ (i·n_y + j)·n_ζ + k.
    unit : ndarray
        ∫ φ_(i,j,k): the mass of p is ``unit @ p``.
    xbasis, ybasis, zbasis : skfem.CellBasis
        The 1-D bases.
    domain : Domain
        The strip (walls, y_max).
    parts : dict
        The factors: ``A`` (2-D, without D1), ``C`` = M_x ⊗ C_y, ``Mxy``, and the ζ
        matrices ``Mz``, ``Wz``, ``Kz`` (the preconditioner and the transient use them).
    """
    L: sp.csr_matrix
    unit: np.ndarray
    xbasis: skfem.CellBasis
    ybasis: skfem.CellBasis
    zbasis: skfem.CellBasis
    domain: Domain
    parts: dict = field(repr=False)
    _M: sp.csr_matrix | None = None

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.xbasis.N, self.ybasis.N, self.zbasis.N

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    @property
    def M(self) -> sp.csr_matrix:
        """The mass matrix M_x ⊗ M_y ⊗ M_ζ (made on first use)."""
        if self._M is None:
            self._M = kron_sum([(self.parts["Mxy"], self.parts["Mz"])])
        return self._M


def assemble_coloured(system: VibroImpactSystem, xnodes: np.ndarray, ynodes: np.ndarray,
                      znodes: np.ndarray, degree: int = 2, degree_z: int | None = None,
                      dom: Domain | None = None) -> ColouredOperator:
    """L of the module docstring on the tensor mesh ``xnodes × ynodes × znodes``
    (Lagrange degree ``degree`` in x and y, ``degree_z`` (default the same) in ζ)."""
    tau, D1 = system.external.tau, system.D1
    if dom is None:
        xs, ys = np.sort(xnodes), np.sort(ynodes)
        mesh = skfem.MeshQuad.init_tensor(xs[[0, -1]], np.array([ys[0], 0.0, ys[-1]]))
        dom = mesh_domain(system, mesh)
    bx, by = assemble_tensor_bases(xnodes, ynodes, degree)
    dz = degree if degree_z is None else degree_z
    bz = assemble_tensor_bases(znodes, znodes, dz)[0]
    terms2, (Mx, My) = tensor_terms(system, bx, by, dom, degree, external=False)
    A = kron_sum(terms2)
    C = kron_sum([(Mx, skfem.asm(forms.convection_1d, by, coef=(1.0,)))])
    Mxy = kron_sum([(Mx, My)])
    Mz = skfem.asm(forms.weighted_mass_1d, bz, coef=(1.0,)).tocsr()
    Wz = skfem.asm(forms.weighted_mass_1d, bz, coef=(0.0, 1.0)).tocsr()
    Kz = (-(1.0 / tau) * skfem.asm(forms.convection_1d, bz, coef=(0.0, 1.0))
          - (D1 / tau ** 2) * skfem.asm(forms.stiffness_1d, bz)).tocsr()
    L = kron_sum([(A, Mz), (C, Wz), (Mxy, Kz)])
    ones = [np.asarray(m.sum(axis=0)).ravel() for m in (Mx, My, Mz)]
    unit = np.kron(np.kron(ones[0], ones[1]), ones[2])
    return ColouredOperator(L, unit, bx, by, bz, dom,
                            {"A": A, "C": C, "Mxy": Mxy, "Mz": Mz, "Wz": Wz, "Kz": Kz})
