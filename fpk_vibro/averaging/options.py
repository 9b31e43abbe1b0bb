"""The options of the averaging method, declared once (see :mod:`fpk_vibro.options`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .._checks import InputError
from ..budget import Cost
from ..model import VibroImpactSystem
from ..options import Options as _Options
from ..options import option
from .energy_grid import check_coverage, energy_faces, initial_cell_masses
from .normalisation import normalise

__all__ = ["Options"]

S, T, FP = ("stationary",), ("transient",), ("first_passage",)


@dataclass(frozen=True)
class Options(_Options):
    """Numerical options of :func:`~fpk_vibro.averaging.stationary`,
    :func:`~fpk_vibro.averaging.transient` and
    :func:`~fpk_vibro.averaging.first_passage`."""

    WHERE = "averaging"

    n_theta: int = option(48, "Gauss–Legendre nodes along each orbit", "int", lo=4, hi=2000)
    n_panel: int = option(24, "Gauss–Legendre nodes per energy panel", "int", lo=4, hi=200)
    phi_cut: float = option(60.0, "energies covered until Φ(H) ≥ phi_cut (neglected mass "
                            "< e^-phi_cut)", "float", lo=10.0, hi=700.0)
    n_cells: int = option(400, "finite-volume cells in H (first passage: of the "
                          "reliability, up to H_c)", "int", lo=16, hi=50_000,
                          modes=T + FP, reduced=200)
    n_grid: int = option(4000, "quadrature nodes of the mean first-passage time integral "
                         "(graded at the floor of the potential)", "int", lo=16,
                         hi=10 ** 7, modes=FP)
    H_max: float | None = option(None, "upper end of the energy grid", "float", lo=0.0,
                                 lo_open=True, unit="J/kg", modes=T,
                                 auto="where the stationary density is e^-40 of its peak, "
                                      "or beyond the initial density")
    rtol: float = option(1e-8, "relative tolerance of the Radau time integration", "float",
                         lo=1e-13, hi=1e-2, modes=T)
    seed: int = option(0, "seed for histogramming a sampler initial condition", "int",
                       lo=0, hi=2 ** 63 - 1, modes=T)

    def validate_for(self, system: VibroImpactSystem, mode: str, *, probe: bool = False) -> None:
        """The system-dependent checks: one orbit per energy level, and (``probe``) a
        light tail where a linear spring meets parametric noise on an open side.
        First passage checks its system itself (with the energy)."""
        if mode == "first_passage":
            return
        from ..orbits import require_single_well
        try:
            require_single_well(system)
            if probe and system.barriers != "both" and system.b == 0 and system.D2 > 0:
                # the only case with a power-law tail: normalise refuses it
                normalise(system, self.n_theta, self.n_panel, self.phi_cut)
        except InputError:
            raise
        except ValueError as exc:
            msg = str(exc) if str(exc).startswith("averaging") else f"averaging: {exc}"
            raise InputError(msg, where="averaging", name="system") from None

    def validate_initial(self, system: VibroImpactSystem, init: Any) -> None:
        """A given ``H_max`` must hold the initial density (its energy grid)."""
        if self.H_max is None:
            return
        faces = energy_faces(system, self.H_max, self.n_cells)
        check_coverage(initial_cell_masses(init, faces, seed=self.seed), self.H_max)

    def estimate(self, system: VibroImpactSystem, mode: str, times: Any = None) -> Cost:
        """Memory and seconds measured on the paper's case (docs/costs.md); first
        passage: the dense eigen-decomposition of its n_cells generator."""
        nodes = self.n_theta * self.n_panel
        if mode == "first_passage":       # A, V (complex), LU and eig's workspace
            n = float(self.n_cells)
            return Cost(100e6 + 64.0 * n * n + 200.0 * self.n_grid, n ** 3, "flops/10",
                        0.5 + 1e-9 * n ** 3 + 2e-6 * self.n_grid, "n_cells")
        stationary = Cost(60e6 + 400 * nodes * 8 * 12, nodes * 400, "orbit nodes",
                          0.01 + 0.02 * nodes / (48 * 24), "n_theta")
        if mode == "stationary":
            return stationary
        # Radau LU steps: ~60 to the first relaxation time, then about one per 4/λ
        # until the run stops at equilibrium (averaging.transient stops when the
        # masses are within rtol of it, t ≈ ln(1/rtol)/λ; 2× that bounds it); order
        # 5: steps ∝ rtol^(-1/5) (measured: docs/costs.md)
        from ..scales import relaxation_rate
        lam = relaxation_rate(system)
        t_end = float(max(times)) if times is not None and len(times) else 0.0
        t_run = min(t_end, 2.0 * math.log(1.0 / max(self.rtol, 1e-9)) / lam)
        steps = (60.0 + 0.25 * lam * t_run) * max(0.25, (1e-8 / self.rtol) ** 0.2)
        return Cost(100e6 + 64e3 * self.n_cells, self.n_cells * steps, "cell-steps",
                    stationary.seconds + 0.1 + 4.5e-4 * self.n_cells * steps / 60.0,
                    "n_cells")
