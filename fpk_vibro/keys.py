"""The names every method's answers share: its moments and its error estimate."""
from __future__ import annotations

__all__ = ["MOMENT_KEYS", "ESTIMATE_KEYS", "JUDGED", "moment_scale"]

#: The moments every Solution gives (P_impact only with walls).
MOMENT_KEYS = ("E_H", "E_x2", "E_y2", "E_x4", "E_y4", "P_impact")
#: The figures of every method's ``error_estimate()`` (relative; L1 absolute).
ESTIMATE_KEYS = ("E_H", "E_x2", "E_y2", "P_impact", "L1")
#: The relative figures among them (what rtol and the warnings judge).
JUDGED = ESTIMATE_KEYS[:4]


def moment_scale(key: str, value: float) -> float:
    """What a moment's error is relative to: |value|, and at least 1e-3 for
    P_impact (whose error is absolute below 1e-3)."""
    return max(abs(value), 1e-3) if key == "P_impact" else abs(value)
