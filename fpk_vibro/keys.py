"""The names every method's answers share: its moments and its error estimate."""
from __future__ import annotations

__all__ = ["MOMENT_KEYS", "ESTIMATE_KEYS"]

#: The moments every Solution gives (P_impact only with walls).
MOMENT_KEYS = ("E_H", "E_x2", "E_y2", "E_x4", "E_y4", "P_impact")
#: The figures of every method's ``error_estimate()`` (relative; L1 absolute).
ESTIMATE_KEYS = ("E_H", "E_x2", "E_y2", "P_impact", "L1")
