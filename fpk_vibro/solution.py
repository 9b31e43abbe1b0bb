"""The one result interface every method implements, and its file format.

File format (``Solution.save``): a NumPy ``.npz`` archive holding

- ``format``  : the string ``"fpk_vibro.solution"``;
- ``version`` : integer format version (currently 1);
- ``kind``    : which class wrote it (``"averaging"``, ``"exact"``, ...);
- ``system``  : the :class:`~fpk_vibro.VibroImpactSystem` as a JSON string;
- ``meta``    : a JSON string with the class's scalar settings;
- every other key: a float64/int64 array of the class's state, stored bit for bit.

``Solution.load(path)`` reads any of them back as the class that wrote it; the
loaded object evaluates every density and moment to the same bits as the saved one.

- ``package`` : the version of fpk_vibro that wrote it.

An error estimate made before saving (``error_estimate()``, or the one an rtol solve
made) is part of the answer: it is stored in ``meta["estimate"]`` (floats to the bit,
inf and NaN kept) and the loaded object's ``error_estimate()`` returns it as made,
with no second run (an FE transient's richer run, Monte Carlo's run at 2 dt).

Before building anything, ``load`` checks the file (:mod:`fpk_vibro.solution_file`):
any problem is one ``ValueError`` line naming the file.  The class of a kind is
found through :data:`~fpk_vibro.solution_file.KIND_MODULES`, imported on demand.
"""
from __future__ import annotations

import abc
import functools
import json
import os
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ._checks import InputError, check_points, invalid
from .io import atomic_write
from .keys import ESTIMATE_KEYS, MOMENT_KEYS
from .model import VibroImpactSystem
from .solution_file import (ESTIMATE, FORMAT_NAME, FORMAT_VERSION, KIND_MODULES, RESERVED,
                            Corrupt, Rule, Stored, open_archive, read)

__all__ = ["Solution", "MOMENT_KEYS", "ESTIMATE_KEYS", "KIND_MODULES", "Rule", "Stored",
           "TransientResult"]

#: The density methods and their arguments, in order: every definition of one of them
#: in a subclass gets the one argument check (:func:`_checked`).
_POINT_ARGS = {"pdf_energy": ("H",), "pdf_joint": ("x", "y"), "pdf_x": ("x",),
               "pdf_y": ("y",), "impact_speed_pdf": ("wall", "u"),
               "impact_energy_pdf": ("wall", "e"), "inter_impact_pdf": ("t",)}


def _checked(name: str, method):
    """``method`` with its arguments checked first: the wall by
    :meth:`Solution.wall_named`, the points by :func:`~fpk_vibro._checks.check_points`
    (finite real numbers; NaN, ±inf, None, strings: one line naming the argument)."""
    params = _POINT_ARGS[name]

    @functools.wraps(method)
    def checked(self, *args, **kwargs):
        where = f"{type(self).__name__}.{name}"
        for i, param in enumerate(params):
            if i < len(args):
                value = args[i]
            elif param in kwargs:
                value = kwargs[param]
            else:
                continue                 # missing: the method's own TypeError
            if param == "wall":
                self.wall_named(value)
            else:
                check_points(param, value, where=where)
        return method(self, *args, **kwargs)

    checked._points_checked = True
    return checked


class Solution(abc.ABC):
    """Stationary or transient response densities of a :class:`VibroImpactSystem`.

    All densities are vectorised over NumPy arrays (broadcasting ``x`` with ``y``)
    and are zero outside the strip ``left ≤ x ≤ right``.  Their points must be finite
    real numbers: NaN, ±inf, None or a string is an :class:`~fpk_vibro._checks.InputError`
    naming the argument (one check, given to every subclass's densities).
    """

    kind: ClassVar[str] = ""
    _registry: ClassVar[dict[str, type["Solution"]]] = {}
    system: VibroImpactSystem

    @property
    def partial(self) -> bool:
        """True when a signal cut the run short: what it holds was finished, but not
        all that was asked (every method; a transient's list says the same)."""
        return bool(self.__dict__.get("_partial", False))

    @partial.setter
    def partial(self, value: bool) -> None:
        self.__dict__["_partial"] = bool(value)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.kind:
            Solution._registry[cls.kind] = cls
        for name in _POINT_ARGS:        # every override checks its arguments alike
            method = cls.__dict__.get(name)
            if callable(method) and not getattr(method, "_points_checked", False):
                setattr(cls, name, _checked(name, method))

    # -- densities ----------------------------------------------------------------
    @abc.abstractmethod
    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        """Density of the energy H = y²/2 + G(x)."""

    @abc.abstractmethod
    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Joint density p(x, y) on the strip."""

    @abc.abstractmethod
    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        """Marginal density of the displacement, p(x) = ∫ p(x, y) dy."""

    @abc.abstractmethod
    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        """Marginal density of the velocity, p(y) = ∫ p(x, y) dx."""

    @abc.abstractmethod
    def moments(self) -> dict[str, float]:
        """E[H], E[x²], E[y²], E[x⁴], E[y⁴] and P_impact = P(H > G(Δ)).

        ``P_impact`` is absent when the system has no barrier.
        """

    def error_estimate(self) -> dict[str, Any]:
        """Estimated errors of this answer: ``E_H``, ``E_x2``, ``E_y2``, ``P_impact``
        (relative; P_impact absolute below 1e-3), ``L1`` where the method can, and
        ``assumes`` (what the estimate rests on).  Every method's stationary solution
        gives it (FE: discretisation; Monte Carlo: statistics and time-step bias;
        averaging: its model error; exact: zero)."""
        raise NotImplementedError(f"{type(self).__name__} ({self.kind or 'this kind'}) has "
                                  "no error estimate yet")

    def impacts(self) -> dict[str, dict[str, float]]:
        """Per wall ("left"/"right"): ``rate`` (impacts per unit time), ``mean_speed``
        and ``mean_square_speed`` just before impact, and ``energy_rate`` (energy the
        impacts remove per unit time); Monte Carlo adds ``*_se`` standard errors."""
        raise NotImplementedError(f"{type(self).__name__} gives no impact statistics")

    def wall_named(self, wall: Any):
        """The system's :class:`~fpk_vibro.model.Wall` called ``wall`` ("left"/"right");
        a one-line error naming the walls there are otherwise."""
        sides = [side for side, _ in self.system.walls]
        if not isinstance(wall, str) or wall not in sides:
            raise invalid("impact_speed_pdf", "wall", f"one of the system's walls {sides}",
                          wall)
        return getattr(self.system, wall)

    def impact_speed_pdf(self, wall: str, u: np.ndarray) -> np.ndarray:
        """Density of the speed u ≥ 0 just before an impact on ``wall``."""
        raise NotImplementedError(f"{type(self).__name__} gives no impact-speed density")

    # -- impact statistics beyond rates (issue 32) ------------------------------
    def inter_impact_pdf(self, t: np.ndarray) -> np.ndarray:
        """Density of the time between successive impacts (on any wall), at ``t`` ≥ 0."""
        raise NotImplementedError(f"{type(self).__name__} gives no inter-impact time "
                                  "density")

    def mean_inter_impact_time(self) -> float:
        """Mean time between successive impacts (any wall), computed by the method's own
        route: the exact identity says it equals 1/(total impact rate)."""
        raise NotImplementedError(f"{type(self).__name__} gives no inter-impact time")

    def _impact_speed_reach(self, wall: str) -> float:
        """A speed beyond which impacts on ``wall`` are negligible (from the energy
        tail: u = sqrt(2 (H_tail − G(x_w))))."""
        from . import scales
        s = self.system
        try:
            H = scales.tail_energy(s)
        except ValueError:
            H = scales.potential_min(s) + 40.0 * scales.energy_scale(s)
        xw = getattr(s, wall).position
        return float(np.sqrt(2.0 * max(H - float(s.potential(xw)), 1e-12)))

    def impact_energy_pdf(self, wall: str, e: np.ndarray) -> np.ndarray:
        """Density of the energy one impact on ``wall`` dissipates, e = (1 − r(u)²) u²/2
        (:func:`fpk_vibro.impact_energy.energy_density` from :meth:`impact_speed_pdf`
        and the wall's law; zero at every e > 0 for an elastic wall)."""
        from .impact_energy import energy_density
        w = self.wall_named(wall)
        return energy_density(w, lambda u: self.impact_speed_pdf(wall, u), e,
                              u_max=self._impact_speed_reach(wall))

    def mean_impact_energy(self, wall: str) -> float:
        """Mean energy one impact on ``wall`` dissipates (the mean of
        :meth:`impact_energy_pdf`; the identity: energy_rate / rate of :meth:`impacts`)."""
        from .impact_energy import mean_energy
        w = self.wall_named(wall)
        return mean_energy(w, lambda u: self.impact_speed_pdf(wall, u),
                           u_max=self._impact_speed_reach(wall))

    def to_xarray(self, grids: dict | None = None):
        """The densities on their grids, the moments and the provenance as an
        ``xarray.Dataset`` (:func:`fpk_vibro.labelled.solution_dataset`); write it with
        ``ds.to_netcdf(path, engine="h5netcdf")``."""
        from .labelled import solution_dataset
        return solution_dataset(self, grids)

    def snapshot_time(self) -> float | None:
        """The time of a transient density (``time``, or ``info["time"]`` of a loaded
        FE snapshot); None for a stationary one."""
        t = getattr(self, "time", None)
        if t is None and isinstance(getattr(self, "info", None), dict):
            t = self.info.get("time")
        return None if t is None else float(t)

    def power_balance(self) -> dict[str, float]:
        """The stationary power balance D1 + D2 E[x²] = c E[y²] + Σ_w P_w
        (docs/impacts.md): its three terms and the relative residual (with
        ``residual_se`` where the method has standard errors).

        Raises
        ------
        InputError
            For a transient density (one time of ``transient``): its balance has the
            extra term dE[H]/dt, which one time does not give.
        """
        t = self.snapshot_time()
        if t is not None:
            raise invalid(f"{type(self).__name__}.power_balance", "time",
                          "None (a stationary density)", t, "a transient density: its "
                          "balance needs dE[H]/dt, which one time does not give")
        s, m = self.system, self.moments()
        if s.external is not None:
            zeta = self.coloured_moments()          # the work of ζ is E[ζ y], not D1
            external = zeta["E_zeta_y"]
        else:
            zeta, external = {}, s.D1
        imp = self.impacts() if s.has_barrier else {}
        noise = external + s.D2 * m["E_x2"]
        damping = s.c * m["E_y2"]
        impacts = sum(v["energy_rate"] for v in imp.values())
        out = {"noise": noise, "damping": damping, "impacts": impacts,
               "residual": (noise - damping - impacts) / noise}
        if hasattr(self, "moments_se"):
            se = self.moments_se()
            out["residual_se"] = (s.D2 * se["E_x2"] + s.c * se["E_y2"] + sum(
                v.get("energy_rate_se", 0.0) for v in imp.values())
                + zeta.get("E_zeta_y_se", 0.0)) / noise
        return out

    def coloured_moments(self) -> dict[str, float]:
        """With coloured external noise (:mod:`fpk_vibro.noise`): ``E_zeta2`` = E[ζ²]
        and ``E_zeta_y`` = E[ζ y], the power the force ζ puts in (with ``*_se`` where
        sampled).  Methods solving such systems override it.

        Raises
        ------
        InputError
            For a system with white external noise (ζ does not exist).
        """
        if self.system.external is None:
            raise invalid(f"{type(self).__name__}.coloured_moments", "system.external",
                          "OrnsteinUhlenbeck(tau=...)", None, "white external noise has no "
                          "state ζ")
        raise NotImplementedError(f"{type(self).__name__} does not give E[ζ y]")

    def upcrossing_rate(self, b: Any) -> Any:
        """ν⁺(b) = ∫_{y>0} y p(b, y) dy, the rate of upcrossings of the level x = b
        (a number or an array; 0 beyond a wall; at a wall, the impact rate there):
        :func:`fpk_vibro.crossings.upcrossing_rate` on :meth:`pdf_joint`.  On a
        Monte Carlo histogram the bins bias it (3 % high at the paper's wall);
        :func:`fpk_vibro.montecarlo.crossings` counts crossings on the paths instead."""
        from .crossings import upcrossing_rate
        return upcrossing_rate(self, b)

    def peak_rate(self, b: Any) -> Any:
        """The rate of peaks (one per excursion above the mean) higher than ``b``:
        from a density, ν⁺(b), exact when an excursion crosses b at most once; for b
        below the mean, the rate of excursions ν⁺(mean)
        (:func:`fpk_vibro.crossings.peak_rate`)."""
        from .crossings import peak_rate
        return peak_rate(self, b)

    def mean_x(self) -> float:
        """E[x] = ∫ x p(x) dx: zero for walls at ±Δ, not for asymmetric walls.

        Composite Gauss–Legendre quadrature of :meth:`pdf_x` over the strip (a side
        without a wall is cut where G reaches the tail energy of
        :func:`fpk_vibro.scales.tail_energy`); methods that know it better override it.
        """
        from . import scales
        lo, hi = self.system.x_bounds
        if not (np.isfinite(lo) and np.isfinite(hi)):
            try:
                H = scales.tail_energy(self.system)
            except ValueError:
                H = scales.potential_min(self.system) + 40.0 * scales.energy_scale(self.system)
            X = float(scales.reach(self.system, H))
            lo, hi = max(lo, -X), min(hi, X)
        t, w = np.polynomial.legendre.leggauss(8)
        edges = np.linspace(lo, hi, 513)
        half = 0.5 * np.diff(edges)[:, None]
        x = (0.5 * (edges[1:] + edges[:-1]))[:, None] + half * t
        return float(np.sum(half * w * x * self.pdf_x(x.ravel()).reshape(x.shape)))

    # -- persistence --------------------------------------------------------------
    @abc.abstractmethod
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """(JSON-able scalar settings, arrays) that rebuild this object exactly."""

    @classmethod
    @abc.abstractmethod
    def _from_state(cls, system: VibroImpactSystem, meta: dict[str, Any],
                    arrays: dict[str, np.ndarray]) -> "Solution":
        """Inverse of :meth:`_state`."""

    #: The keys of the ``meta`` JSON object and what each must be (others are ignored).
    _meta_schema: ClassVar[dict[str, Rule]] = {}

    @classmethod
    def _array_schema(cls, meta: dict[str, Any]) -> dict[str, Stored]:
        """The arrays a file of this kind holds (exactly these), given its checked ``meta``."""
        return {}

    @classmethod
    def _check_state(cls, system: VibroImpactSystem, meta: dict[str, Any],
                     arrays: dict[str, np.ndarray]) -> None:
        """Raise ValueError on what the schemas cannot say (relations between the parts)."""

    def save(self, path: str | os.PathLike) -> Path:
        """Write this solution to ``path`` (``.npz``, see module docstring), atomically,
        with the error estimate if one was made.

        Returns the path written (``.npz`` appended if missing).

        Raises
        ------
        InputError
            Where that path is an existing directory (one line naming it).
        """
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        where = f"{type(self).__name__}.save"
        if path.is_dir():
            raise invalid(where, "path", "a file path, not an existing directory", str(path))
        meta, arrays = self._state()
        made = self.__dict__.get("_estimate")
        if isinstance(made, dict):
            meta = {**meta, ESTIMATE: _plain(made)}
        clash = set(RESERVED) & set(arrays)
        if clash:
            raise RuntimeError(f"state arrays use reserved names {sorted(clash)}")
        payload = {
            "format": np.array(FORMAT_NAME),
            "version": np.array(FORMAT_VERSION),
            "kind": np.array(self.kind),
            "system": np.array(self.system.to_json()),
            "meta": np.array(json.dumps(meta, sort_keys=True)),
            "package": np.array(_package_version()),
            **{k: np.asarray(v) for k, v in arrays.items()},
        }
        try:
            atomic_write(path, lambda fh: np.savez(fh, **payload))
        except IsADirectoryError:       # made a directory meanwhile
            raise invalid(where, "path", "a file path, not an existing directory",
                          str(path)) from None
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Solution":
        """Read a solution written by :meth:`save`, as the class that wrote it.

        Parameters
        ----------
        path : str or os.PathLike
            An ``.npz`` file written by :meth:`save`.

        Returns
        -------
        Solution
            Of the class that wrote the file (imported on demand), with the error
            estimate the saved one had made, if any.

        Raises
        ------
        ValueError
            One line naming the file and the first problem found, before anything
            is built: not a readable zip of ``.npy`` arrays, pickled data, another
            format or version, bad metadata or system, a missing, extra, mistyped or
            misshapen array, non-finite or negative values where they cannot occur.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise invalid("Solution.load", "path", "a file path", path)
        name = os.fsdecode(path)
        name = name if name.isprintable() else repr(name)
        try:
            with open_archive(path) as zf:
                target, system, meta, arrays = read(zf, Solution._registry, cls)
            made = meta.pop(ESTIMATE, None)
            out = target._from_state(system, meta, arrays)
            if made is not None:
                out._estimate = made
            return out
        except (Corrupt, ValueError) as exc:
            problem = " ".join(str(exc).split())
            raise InputError(f"{name}: {problem}", where=name, name="path") from None

    def __repr__(self) -> str:
        return f"{type(self).__name__}(system={self.system!r})"


class TransientResult(list):
    """The densities of a transient at its output times, in order (every method).

    ``partial`` is True when a signal stopped the run: the list then holds the times
    reached, ``times_requested`` all of them.
    """

    partial: bool = False
    times_requested: tuple = ()


def _plain(value: Any) -> Any:
    """``value`` (an estimate) as JSON values, floats to the bit: NumPy scalars as
    Python ones, inf and NaN kept (written as ``Infinity`` and ``NaN``)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if value is None or isinstance(value, (bool, np.bool_)):
        return None if value is None else bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    return float(value) if isinstance(value, (float, np.floating)) else str(value)


def _package_version() -> str:
    from ._version import __version__
    return __version__
