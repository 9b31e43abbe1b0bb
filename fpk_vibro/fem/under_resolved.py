"""When an FE density is flagged ``under_resolved``, and why (``info``).

:func:`diagnosis` reads the density itself (its negative mass and moment shift,
:func:`fpk_vibro.fem.integrals.diagnose`) and the change the non-negative correction
made (:mod:`fpk_vibro.fem.nonnegative`); :func:`flag_estimate` adds the error
estimate against the solve's ``rtol`` (:meth:`FEMSolution.error_estimate`).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from . import integrals
from .compare import AIMED, JUDGED, worst

__all__ = ["RESOLUTION_TOL", "diagnosis", "flag_estimate"]

#: Resolution tolerance (see :meth:`fpk_vibro.fem.FEMSolution.resolution`).
RESOLUTION_TOL = 1e-3


def diagnosis(q: dict[str, Any], info: dict) -> dict[str, Any]:
    """The resolution diagnostics of the quadrature ``q`` of a density whose ``info``
    may hold its non-negative correction."""
    diag = integrals.diagnose(q, RESOLUTION_TOL)
    change = info.get("correction") or {}
    moved = max([float(change.get("L1", 0.0))]
                + [float(v) for k, v in change.items() if k in ("E_H", "E_x2", "E_y2")])
    if moved > RESOLUTION_TOL:       # the non-negative correction changed p this much
        reason = (f"the non-negative correction changed the density by {moved:.2g} "
                  f"(L1 or a relative moment) > {RESOLUTION_TOL:g}: Galerkin "
                  "undershoots strongly here (fem.nonnegative)")
        old = diag.get("under_resolved_reason") or ""
        diag = {**diag, "under_resolved": True,
                "under_resolved_reason": f"{old}; {reason}" if old else reason}
    return diag


def flag_estimate(info: dict, resolution: dict[str, Any], est: dict[str, Any]) -> None:
    """Record the largest judged entry of ``est`` in ``info`` and flag the density
    ``under_resolved`` where it exceeds ``info["rtol"]`` (or :data:`RESOLUTION_TOL`).
    With an rtol the L1 error is judged too (:data:`~fpk_vibro.fem.compare.AIMED`:
    what rtol bounds); without, the moments."""
    goal = info.get("rtol") or RESOLUTION_TOL
    e = worst(est, AIMED if info.get("rtol") else JUDGED)
    info["error_estimate"] = e if np.isfinite(e) else 1e300     # (JSON: no inf)
    if e > goal:
        reason = (f"error estimate {e:.2g} > {goal:g} ({est['richer']} differs; "
                  f"{est['assumes']})")
        old = resolution.get("under_resolved_reason") or ""
        info["under_resolved"] = True
        info["under_resolved_reason"] = f"{old}; {reason}" if old else reason
