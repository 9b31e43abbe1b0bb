"""A density of the energy given on finite-volume cells, lifted to phase space.

Under the averaging hypothesis the phase-space density is uniform in time along
each orbit: p(x, y) = p(H)/T(H) at H = y²/2 + G(x) (docs/theory.md, §Averaged density;
paper Eq. 25).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..model import VibroImpactSystem
from ..orbits import energy_floor, orbit_nodes
from ..solution import Rule, Solution, Stored

__all__ = ["EnergyGridSolution"]

_NODES = 4  # Gauss nodes per cell image in the marginal integrals


class EnergyGridSolution(Solution):
    """p(H) as cell averages on ``faces`` (e.g. one time of :func:`transient`).

    p(H) is interpolated linearly between cell centres (constant in the end
    half-cells) and is zero outside [faces[0], H_max].  Moments use the midpoint rule
    per cell with the exact orbit averages at the centres; P_impact is exact for the
    cell masses because every wall energy G(x_w) is a face.

    ``error_estimate()`` (one time of :func:`transient`): averaging's model error at
    that time, by the FE transient of the same system from the same initial condition
    (:mod:`fpk_vibro.averaging.model_error`).
    """

    kind = "averaging_grid"

    def __init__(self, system: VibroImpactSystem, *, faces: np.ndarray, density: np.ndarray,
                 time: float | None = None) -> None:
        self.system = system
        self.faces = np.asarray(faces, dtype=float)
        self.density = np.asarray(density, dtype=float)
        self.time = time
        #: What the density is and, once asked for, its model error
        #: (``info["error_estimate"]``, the largest relative figure).
        self.info: dict[str, Any] = {"n_cells": int(self.density.size)}
        self._estimate: dict[str, Any] | None = None
        #: The FE check shared by the members of one transient (set by it; None for a
        #: density read from a file, which does not know its initial condition).
        self._check: Any = None
        self.centres = 0.5 * (self.faces[1:] + self.faces[:-1])
        o = orbit_nodes(system, self.centres)
        self._T = o.period
        self._sums = {"x2": 2 * o.integrate(o.x ** 2), "x4": 2 * o.integrate(o.x ** 4),
                      "y2": 2 * o.integrate(o.v ** 2), "y4": 2 * o.integrate(o.v ** 4),
                      "x1": 2 * o.integrate(o.x)}

    @property
    def mass(self) -> float:
        """∫ p dH: 1 to round-off for a transient solution (mass is conserved)."""
        return float(np.sum(self.density * np.diff(self.faces)))

    @property
    def min_density(self) -> float:
        return float(self.density.min())

    # -- how far off it is ----------------------------------------------------------
    def error_estimate(self, reference: Any = None) -> dict[str, Any]:
        """The model error of averaging at this time, by the finite-element transient of
        the same system from the same initial condition
        (:func:`fpk_vibro.averaging.model_error.transient_model_error`): the first call
        of any member of one :func:`transient` list solves ``fem.transient(...,
        degree=4, nx=16)`` at all its times, for them all; ``reference``: an FE density at
        this time of the same system (with an estimate, e.g. from
        ``fem.transient(..., rtol=...)``) used instead, replacing any estimate made
        before.

        Returns
        -------
        dict
            ``E_H``, ``E_x2``, ``E_y2`` (and ``P_impact`` with walls): relative (P_impact
            absolute below 1e-3); ``L1``: ∫|p − p_FE| plus FE's own; ``assumes``,
            ``reference``, ``seconds``.  Infinite, with the reason in ``reference``,
            when there is no FE density: a sampler initial condition (FE needs a
            density), or FE refused (e.g. its rtol not reached within its time limit).

        Raises
        ------
        NotImplementedError
            For a density not made by :func:`transient` (read from a file): its initial
            condition is unknown.
        fpk_vibro._checks.InputError
            A ``reference`` that is not an FE density of the same system at this time.
        """
        if self._estimate is None or reference is not None:
            from ..keys import JUDGED
            from .model_error import transient_model_error
            self._estimate = transient_model_error(self, reference)
            self.info["error_estimate"] = max(
                float(self._estimate[k]) for k in JUDGED if k in self._estimate)
        return dict(self._estimate)

    # -- densities ----------------------------------------------------------------
    def validity(self) -> dict[str, Any]:
        """The small parameters averaging assumes small, at this density's mean energy,
        with a verdict in plain words (:func:`fpk_vibro.averaging.validity.indicators`;
        the stationary solution's adds the indicator model's estimate, which is
        calibrated on stationary densities only)."""
        from .validity import indicators, verdict, weakest
        ind = indicators(self)
        return {**ind, "verdict": verdict(ind), "weakest": weakest(ind)}

    def _interp(self, values: np.ndarray, H: np.ndarray) -> np.ndarray:
        inside = (H >= self.faces[0]) & (H <= self.faces[-1])
        return np.where(inside, np.interp(H, self.centres, values), 0.0)

    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        return self._interp(self.density, np.asarray(H, dtype=float))

    def _q(self, H: np.ndarray) -> np.ndarray:
        """p(H)/T(H): the phase-space density on the orbit of energy H."""
        return self._interp(self.density / self._T, H)

    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        return np.where(self.system.in_strip(x), self._q(self.system.energy(x, y)), 0.0)

    def _edges(self) -> np.ndarray:
        """Where the piecewise-linear q changes slope: centres and the domain ends."""
        return np.concatenate([[self.faces[0]], self.centres, [self.faces[-1]]])

    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        """p(x) = 2 ∫₀^∞ q(G(x) + v²/2) dv, Gauss in v on the images of the q pieces."""
        x = np.asarray(x, dtype=float)
        G = self.system.potential(x.ravel())[:, None]
        v_e = np.sqrt(2.0 * np.maximum(self._edges() - G, 0.0))
        total = _gauss(v_e, lambda v: self._q(G[..., None] + 0.5 * v * v))
        return np.where(self.system.in_strip(x), 2.0 * total.reshape(x.shape), 0.0)

    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        """p(y) = ∫ q(y²/2 + G(x)) dx over the strip: the parts |x| ∈ [X0, X1] on
        either side of x = 0 (X0 > 0 for a strip that does not contain 0)."""
        y = np.asarray(y, dtype=float)
        K = 0.5 * y.ravel()[:, None] ** 2
        lo, hi = self.system.x_bounds
        floor = min(0.0, energy_floor(self.system))
        total = np.zeros(K.shape[0])
        for X0, X1 in ((max(lo, 0.0), hi), (max(-hi, 0.0), -lo)):
            if not X1 > X0:
                continue
            A = self.system.amplitude(np.maximum(self._edges() - K, floor))
            x_e = np.minimum(np.where(np.isfinite(A), A, X1), X1)
            if X0 > 0:
                x_e = np.maximum(x_e, X0)
            total += _gauss(x_e, lambda xx: self._q(K[..., None] + self.system.potential(xx)))
        return total.reshape(y.shape)

    def moments(self) -> dict[str, float]:
        m = self.density * np.diff(self.faces)
        out = {"E_H": float(np.sum(m * self.centres))}
        for k, key in (("x2", "E_x2"), ("y2", "E_y2"), ("x4", "E_x4"), ("y4", "E_y4")):
            out[key] = float(np.sum(m * self._sums[k] / self._T))
        if self.system.has_barrier:
            out["P_impact"] = float(np.sum(m[self.centres > self.system.barrier_energy]))
        return out

    def mean_x(self) -> float:
        """E[x] by the midpoint rule per cell with the exact orbit averages of x
        (0 for walls at ±Δ or none)."""
        if self.system.symmetric:
            return 0.0
        m = self.density * np.diff(self.faces)
        return float(np.sum(m * self._sums["x1"] / self._T))

    # -- persistence --------------------------------------------------------------
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return {"time": self.time}, {"faces": self.faces, "density": self.density}

    _meta_schema = {"time": Rule.number(0.0, none=True)}

    @classmethod
    def _array_schema(cls, meta):
        """Cell faces (n, increasing) and the cell densities (n - 1, non-negative)."""
        return {"faces": Stored(("faces",), min_size=2, increasing=True),
                "density": Stored(("faces-1",), nonneg=True)}

    @classmethod
    def _from_state(cls, system, meta, arrays):
        return cls(system, faces=arrays["faces"], density=arrays["density"], time=meta["time"])


def _gauss(edges: np.ndarray, f) -> np.ndarray:
    """Σ over consecutive intervals of ``edges`` (last axis) of a Gauss rule applied to f."""
    t, w = np.polynomial.legendre.leggauss(_NODES)
    lo, hi = edges[..., :-1], edges[..., 1:]
    half = 0.5 * (hi - lo)
    nodes = (0.5 * (hi + lo))[..., None] + half[..., None] * t
    return np.sum(half[..., None] * w * f(nodes), axis=(-1, -2))
