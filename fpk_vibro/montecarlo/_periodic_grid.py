"""The time grid and the phase bins of :func:`fpk_vibro.montecarlo.periodic`.

A period T = 2π/Ω is cut into M equal steps h = T/M ≤ dt; grid point g (g = 0..M−1)
is the phase φ0 + 2π g/M.  M is a multiple of ``N_HARM`` (the points of the first
harmonic's fit) and, where the requested phases are commensurate with the grid
(equally spaced ones are), of their common divisor, so that they fall on grid points.

A phase's statistics are the average over the bin [φ − w/2, φ + w/2] (w =
``phase_bin``) of the piecewise-linear interpolant of the statistics sampled at the
grid points: grid point g gets the weight (1/w) ∫ hat_g over the bin (all ≥ 0, sum 1).
For w → 0 that is the linear interpolation between the two neighbouring grid points
(the point value where φ is a grid point).  For a smooth response m(φ) the bin average
is m(φ) + m''(φ) w²/24 + …: for the first harmonic a factor sin(w/2)/(w/2) on its
amplitude (4·10⁻⁴ at the default w = 2π/64); the interpolation adds at most
(2π/M)² |m''| / 8.  Impacts are counted per step and given to a bin by the fraction of
the step's phase interval inside it (w = 0: the step holding φ), so the impact rate of
a phase is the bin average of the rate.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["N_HARM", "steps_per_period", "instant_weights", "step_weights", "Slots"]

TWO_PI = 2.0 * math.pi
#: Equally spaced phases per period at which E[x] is sampled for the first harmonic.
N_HARM = 16


def _divisor(offsets: np.ndarray) -> int:
    """The smallest L ≤ 64 with every offset (in periods) a multiple of 1/L, else 1."""
    for L in range(1, 65):
        q = offsets * L
        if np.all(np.abs(q - np.round(q)) < 1e-9 * L):
            return L
    return 1


def steps_per_period(period: float, dt: float, phases: np.ndarray, phi0: float) -> int:
    """M: the fewest steps per period with T/M ≤ dt, a multiple of N_HARM and of the
    phases' common divisor (module docstring)."""
    L = _divisor(np.mod(np.asarray(phases) - phi0, TWO_PI) / TWO_PI)
    base = N_HARM * L // math.gcd(N_HARM, L)
    return base * max(1, math.ceil(period / dt / base - 1e-9))


def _hat_integral(s: np.ndarray) -> np.ndarray:
    """∫_{−∞}^{s} max(0, 1 − |u|) du."""
    s = np.clip(s, -1.0, 1.0)
    return np.where(s <= 0.0, 0.5 * (s + 1.0) ** 2, 1.0 - 0.5 * (1.0 - s) ** 2)


def _unit(phase: float, phi0: float, M: int) -> float:
    return (phase - phi0) % TWO_PI / TWO_PI * M


def instant_weights(phase: float, phi0: float, M: int, width: float) -> dict[int, float]:
    """{grid point: weight} of the bin average at ``phase`` (module docstring)."""
    u = _unit(phase, phi0, M)
    hw = width / TWO_PI * M / 2.0
    js = np.arange(math.floor(u - hw) - 1, math.ceil(u + hw) + 2)
    if hw > 0:
        w = (_hat_integral(u + hw - js) - _hat_integral(u - hw - js)) / (2.0 * hw)
    else:
        w = np.maximum(0.0, 1.0 - np.abs(u - js))
    out: dict[int, float] = {}
    for j, wj in zip(js, w):
        if wj > 1e-14:
            out[int(j) % M] = out.get(int(j) % M, 0.0) + float(wj)
    return out


def step_weights(phase: float, phi0: float, M: int, width: float) -> dict[int, float]:
    """{step: weight} (step g runs from grid point g to g + 1): the fraction of the
    bin in each step's phase interval; w = 0: the step holding the phase (half each
    to the two steps meeting at a grid point)."""
    u = _unit(phase, phi0, M)
    hw = width / TWO_PI * M / 2.0
    out: dict[int, float] = {}
    if hw > 0:
        for j in range(math.floor(u - hw), math.ceil(u + hw) + 1):
            ov = min(j + 1, u + hw) - max(j, u - hw)
            if ov > 1e-14:
                out[j % M] = out.get(j % M, 0.0) + ov / (2.0 * hw)
    elif abs(u - round(u)) < 1e-9:
        g = round(u)
        out[(g - 1) % M] = 0.5
        out[g % M] = out.get(g % M, 0.0) + 0.5
    else:
        out[math.floor(u) % M] = 1.0
    return out


class Slots:
    """The grid points and steps the phases need, numbered: ``slot_of[g]`` /
    ``step_slot[g]`` (−1: none) as the kernel takes them, and per phase the weights
    by slot number."""

    def __init__(self, phases: np.ndarray, phi0: float, M: int, width: float) -> None:
        self.M = M
        inst = [instant_weights(p, phi0, M, width) for p in phases]
        steps = [step_weights(p, phi0, M, width) for p in phases]
        self.slot_of = np.full(M, -1, dtype=np.int64)
        self.step_slot = np.full(M, -1, dtype=np.int64)
        for table, per in ((self.slot_of, inst), (self.step_slot, steps)):
            for g in sorted({g for d in per for g in d}):
                table[g] = int(table.max()) + 1
        self.n_inst = int(self.slot_of.max()) + 1
        self.n_steps = int(self.step_slot.max()) + 1
        self.inst = [{int(self.slot_of[g]): w for g, w in d.items()} for d in inst]
        self.steps = [{int(self.step_slot[g]): w for g, w in d.items()} for d in steps]
