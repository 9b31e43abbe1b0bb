"""The Monte Carlo result: histograms with standard errors (docs/theory.md, §Monte Carlo)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..model import BARRIER_KINDS, VibroImpactSystem
from ..solution import MOMENT_KEYS as _MOMENT_NAMES
from ..solution import Rule, Solution, Stored

__all__ = ["MonteCarloSolution", "QUANTITIES", "ALL_QUANTITIES"]

#: The histograms of the state, accumulated by default.
QUANTITIES = ("energy", "x", "y", "joint")
#: Everything ``quantities`` may name: the default histograms and, only when asked,
#: "impacts" (a histogram of the speed just before each impact, per wall),
#: "impact_energy" (of the energy each impact removes, per wall) and "inter_impact"
#: (of the time between successive impacts of a path, any wall).
ALL_QUANTITIES = QUANTITIES + ("impacts", "impact_energy", "inter_impact")
#: The quantities only a stationary run with a wall records.
IMPACT_QUANTITIES = ("impacts", "impact_energy", "inter_impact")
_SIDES = {"both": ("left", "right"), "left": ("left",), "right": ("right",), "none": ()}
_HISTS = {"energy": ("edges_H",), "x": ("edges_x",), "y": ("edges_y",),
          "joint": ("edges_jx", "edges_jy")}
_WALL_KEYS = ("count", "rate", "rate_se", "mean_speed", "mean_speed_se", "mean_square_speed",
              "mean_square_speed_se", "energy_rate", "energy_rate_se")
#: Per-wall keys of newer results (absent from files written before them).
_WALL_KEYS_NEW = ("mean_energy", "mean_energy_se")
_GAP_KEYS = ("count", "mean", "mean_se", "unseen", "pairs")
#: The moments of a coloured system's force ζ (:meth:`MonteCarloSolution.coloured_moments`).
_COLOURED_KEYS = ("E_zeta2", "E_zeta2_se", "E_zeta_y", "E_zeta_y_se")
_PAIR_KEYS = ("count", "fraction", "fraction_se", "mean", "mean_se")
_META_KEYS = ("dt", "n_paths", "n_batches", "t_sample", "t_burn", "time", "seed_entropy",
              "partial", "impact_rate", "impact_rate_se", "n_samples", "sample_every",
              "quantities", "mode", "overflow", "x_seen", "scheme")


#: The opt-in histograms and the tag of their arrays (``edges_<tag>_<wall>``; gaps:
#: ``edges_g``).
_FROM_ZERO = {"impacts": "u", "impact_energy": "e", "inter_impact": "g"}


def _gaps_ok(v: Any) -> bool:
    """A stored ``inter_impact`` record: its keys, numbers and wall pairs."""
    def num(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)
    if not (isinstance(v, dict) and set(v) == set(_GAP_KEYS)):
        return False
    pairs = v["pairs"]
    return all(num(v[k]) for k in _GAP_KEYS if k != "pairs") and isinstance(pairs, dict) \
        and all(p in ("left->left", "left->right", "right->left", "right->right")
                and isinstance(d, dict) and set(d) == set(_PAIR_KEYS)
                and all(num(x) for x in d.values()) for p, d in pairs.items())


def _lookup(edges: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bin index of each v (right end of the last bin included) and an inside mask."""
    k = np.searchsorted(edges, v, side="right") - 1
    k = np.where(v == edges[-1], edges.size - 2, k)
    inside = (k >= 0) & (k < edges.size - 1) & np.isfinite(v)
    return np.clip(k, 0, edges.size - 2), inside


class MonteCarloSolution(Solution):
    """Histogram densities and moments estimated by Monte Carlo.

    Built by :func:`fpk_vibro.montecarlo.stationary` (time-and-ensemble averages
    after burn-in) or :func:`fpk_vibro.montecarlo.transient` (ensemble at one
    time).  Densities are piecewise constant on the histogram bins (normalised by
    the total number of samples, so samples outside the histogram range — see
    ``overflow`` — are missing mass) and zero outside the strip.  Standard errors
    come from the spread between ``n_batches`` independent batches of paths
    (each batch has its own random stream).

    Attributes
    ----------
    system : VibroImpactSystem
    dt : float
        Time step used.
    n_paths, n_batches : int
        Paths simulated and independent batches they were split into.
    t_burn, t_sample : float
        Burn-in time and sampled time per path (stationary; ``t_sample`` is 0 and
        ``time`` the snapshot time for transient results).
    time : float or None
        Time of a transient snapshot; ``None`` for stationary results.
    impact_rate, impact_rate_se : float
        Impacts per unit time per path on all walls together (stationary: over the
        sampled time; transient: over the interval ending at ``time``) and its
        standard error; per wall see :meth:`impacts`.
    info : dict
        ``"impacts"`` (:meth:`impacts`), ``"inter_impact"`` (:meth:`inter_impact`,
        where kept), ``"mean_x"`` and ``"mean_x_se"``
        (:meth:`mean_x`); only what the result holds (files written before
        per-wall counts hold neither).
    n_samples : int
        Number of (x, y) samples accumulated (paths × sampling instants).
    partial : bool
        True when the run was interrupted (Ctrl-C) and holds what was finished.
    overflow : dict
        Fraction of samples outside each histogram's range.
    x_seen : tuple of float
        Smallest and largest x among the samples (always inside the strip).
    histograms : dict
        ``name -> (edges..., density, standard error)`` for each requested histogram
        of the state; the impact speeds ("impacts") are per wall:
        :meth:`impact_speed_histogram`.
    """

    kind = "montecarlo"
    #: The stationary solver, for the estimate's second run; the engine sets it
    #: (fpk_vibro.montecarlo._engine), which imports this module, not the reverse.
    rerun: Any = None
    #: The paired time-step bias run (fpk_vibro.montecarlo._paired.stationary_pairs),
    #: set by the engine likewise.
    rerun_paired: Any = None

    def __init__(self, system: VibroImpactSystem, meta: dict[str, Any],
                 arrays: dict[str, np.ndarray]) -> None:
        self.system = system
        self._meta = dict(meta)
        self._arrays = {k: np.asarray(v) for k, v in arrays.items()}
        for key in _META_KEYS:
            setattr(self, key, self._meta.get(key))
        self.quantities = tuple(self._meta.get("quantities", ()))
        self.partial = bool(self._meta.get("partial", False))
        self.x_seen = tuple(self._meta.get("x_seen", (np.nan, np.nan)))

    # -- histogram access ---------------------------------------------------------
    def _need(self, name: str) -> None:
        if name not in self.quantities:
            raise ValueError(f"MonteCarloSolution: the {name!r} histogram was not "
                             f"accumulated (quantities={self.quantities}); rerun with "
                             f"quantities including {name!r}")

    @property
    def histograms(self) -> dict[str, tuple[np.ndarray, ...]]:
        out = {}
        for q in (q for q in self.quantities if q in _HISTS):
            edges = tuple(self._arrays[e] for e in _HISTS[q])
            out[q] = edges + (self._arrays[f"density_{q}"], self._arrays[f"se_{q}"])
        return out

    def histogram(self, name: str) -> tuple[np.ndarray, ...]:
        """``(edges, density, se)`` for "energy", "x", "y"; ``(xedges, yedges,
        density, se)`` for "joint" (density indexed [ix, iy])."""
        self._need(name)
        return self.histograms[name]

    # -- densities ----------------------------------------------------------------
    def _pdf1(self, name: str, v: np.ndarray) -> np.ndarray:
        self._need(name)
        edges = self._arrays[_HISTS[name][0]]
        dens = self._arrays[f"density_{name}"]
        v = np.asarray(v, dtype=float)
        k, inside = _lookup(edges, v)
        return np.where(inside, dens[k], 0.0)

    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        """Histogram density of H (zero outside the histogram range)."""
        return self._pdf1("energy", H)

    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        """Histogram density of x (zero outside the strip)."""
        x = np.asarray(x, dtype=float)
        return np.where(self.system.in_strip(x), self._pdf1("x", x), 0.0)

    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        """Histogram density of y (zero outside the histogram range)."""
        return self._pdf1("y", y)

    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """2-D histogram density p(x, y), broadcasting x with y; zero off the strip."""
        self._need("joint")
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        kx, inx = _lookup(self._arrays["edges_jx"], x)
        ky, iny = _lookup(self._arrays["edges_jy"], y)
        dens = self._arrays["density_joint"]
        return np.where(inx & iny & self.system.in_strip(x), dens[kx, ky], 0.0)

    # -- impact speeds -------------------------------------------------------------
    def _wall(self, wall: Any) -> str:
        self.wall_named(wall)
        self._need("impacts")
        return wall

    def impact_speed_histogram(self, wall: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(edges, density, se)`` of the speed u just before an impact on ``wall``.

        Every impact located during sampling is counted at its speed (before the
        reflection); the density is normalised by the wall's impact count, so the
        impacts beyond the last edge (``overflow["impacts_<wall>"]``) are missing
        mass.  ``se`` per bin from the spread between batches (NaN if the wall was
        never hit).  Only in runs with "impacts" among ``quantities``.

        Raises
        ------
        ValueError
            For a wall the system does not have, or a run without "impacts".
        """
        w = self._wall(wall)
        return (self._arrays[f"edges_u_{w}"], self._arrays[f"density_u_{w}"],
                self._arrays[f"se_u_{w}"])

    def impact_speed_pdf(self, wall: str, u: np.ndarray) -> np.ndarray:
        """Density of the speed u ≥ 0 just before an impact on ``wall``: the histogram
        of :meth:`impact_speed_histogram`, piecewise constant, zero outside its bins."""
        edges, dens, _ = self.impact_speed_histogram(wall)
        u = np.asarray(u, dtype=float)
        k, inside = _lookup(edges, u)
        return np.where(inside, dens[k], 0.0)

    # -- impact energies and the time between impacts ------------------------------
    def impact_energy_histogram(self, wall: str
                                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(edges, density, se)`` of the energy e = ½ (1 − r(u)²) u² one impact on
        ``wall`` removes: every impact sampled is counted (normalised by the wall's
        impact count; ``overflow["impact_energy_<wall>"]`` beyond the last edge), ``se``
        per bin between batches.  Only in runs with "impact_energy" among
        ``quantities``."""
        self.wall_named(wall)
        self._need("impact_energy")
        return (self._arrays[f"edges_e_{wall}"], self._arrays[f"density_e_{wall}"],
                self._arrays[f"se_e_{wall}"])

    def impact_energy_pdf(self, wall: str, e: np.ndarray) -> np.ndarray:
        """Density of the energy one impact on ``wall`` removes, at ``e`` ≥ 0: the
        histogram of :meth:`impact_energy_histogram` where the run kept it, else
        transformed from the impact-speed histogram ("impacts",
        :meth:`fpk_vibro.Solution.impact_energy_pdf`); zero at every e > 0 for an
        elastic wall (each impact removes nothing)."""
        w = self.wall_named(wall)
        e = np.asarray(e, dtype=float)
        if w.elastic:
            return np.zeros(e.shape)
        if "impact_energy" not in self.quantities:
            if "impacts" not in self.quantities:
                self._need("impact_energy")
            return Solution.impact_energy_pdf(self, wall, e)
        edges, dens, _ = self.impact_energy_histogram(wall)
        k, inside = _lookup(edges, e)
        return np.where(inside, dens[k], 0.0)

    def mean_impact_energy(self, wall: str) -> float:
        """Mean energy one impact on ``wall`` removes: Σ ½ (1 − r(u)²) u² over the
        impacts sampled / their number, so exactly energy_rate / rate of
        :meth:`impacts` (the identity); standard error :meth:`mean_impact_energy_se`."""
        self.wall_named(wall)
        d = self.impacts()[wall]
        if "mean_energy" not in d:          # a file that predates it
            return super().mean_impact_energy(wall)
        return float(d["mean_energy"])

    def mean_impact_energy_se(self, wall: str) -> float:
        """Standard error of :meth:`mean_impact_energy` (between batches)."""
        self.wall_named(wall)
        return float(self.impacts()[wall].get("mean_energy_se", np.nan))

    def _gaps(self) -> dict[str, Any]:
        self._need("inter_impact")
        return self._meta["inter_impact"]

    def inter_impact(self) -> dict[str, Any]:
        """The time between successive impacts of a path (any wall).

        Each impact sampled contributes the gap since the path's impact before it
        (tracked from the burn-in on, so a gap may start before the sampling): by
        stationarity these are the gaps of the impact process with no length bias and
        none cut off by the end of the run.  Impacts with no earlier impact of their
        path are left out (``unseen``, their fraction: a bias of at most that much).

        Returns
        -------
        dict
            ``count`` (gaps), ``mean`` and ``mean_se`` (its mean: the identity says
            1/(total impact rate)), ``unseen`` and ``pairs``: per wall pair
            "left->right" etc. (previous wall → this wall) the ``count``,
            ``fraction`` of all gaps and ``mean`` gap, each with ``*_se``.
            Only in runs with "inter_impact" among ``quantities``.
        """
        g = self._gaps()
        return {k: ({p: dict(v) for p, v in g[k].items()} if k == "pairs" else g[k])
                for k in _GAP_KEYS}

    def inter_impact_histogram(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(edges, density, se)`` of the time between successive impacts (any wall),
        normalised by the number of gaps (``overflow["inter_impact"]`` beyond the last
        edge); ``se`` per bin between batches."""
        self._gaps()
        return self._arrays["edges_g"], self._arrays["density_g"], self._arrays["se_g"]

    def inter_impact_pdf(self, t: np.ndarray) -> np.ndarray:
        """Density of the time between successive impacts (any wall), at ``t`` ≥ 0: the
        histogram of :meth:`inter_impact_histogram`, zero outside its bins."""
        edges, dens, _ = self.inter_impact_histogram()
        t = np.asarray(t, dtype=float)
        k, inside = _lookup(edges, t)
        return np.where(inside, dens[k], 0.0)

    def mean_inter_impact_time(self) -> float:
        """Mean time between successive impacts of a path (any wall): the mean of the
        gaps recorded (:meth:`inter_impact`), not 1/rate, so that the identity
        mean = 1/(total impact rate) checks the run."""
        return float(self._gaps()["mean"])

    def mean_inter_impact_time_se(self) -> float:
        """Standard error of :meth:`mean_inter_impact_time` (between batches)."""
        return float(self._gaps()["mean_se"])

    # -- moments and impacts ------------------------------------------------------
    def _moment_dict(self, key: str) -> dict[str, float]:
        vals = self._arrays[key]
        names = _MOMENT_NAMES if self.system.has_barrier else _MOMENT_NAMES[:-1]
        return {n: float(vals[i]) for i, n in enumerate(names)}

    def moments(self) -> dict[str, float]:
        """E[H], E[x²], E[y²], E[x⁴], E[y⁴], P_impact = P(H > min_w G(x_w)) (with walls);
        E[x] is :meth:`mean_x`."""
        return self._moment_dict("moments")

    def moments_se(self) -> dict[str, float]:
        """Standard errors of :meth:`moments` (from independent batches of paths)."""
        return self._moment_dict("moments_se")

    def error_estimate(self, paired: bool = False) -> dict[str, Any]:
        """Statistics and time-step bias together: 2 SE plus the bias from a second run
        at 2 dt (:mod:`fpk_vibro.montecarlo.estimate`; computed on the first call; a
        transient's times share one second run, which its engine attached; once made,
        kept by ``save`` and returned after ``load``).  ``paired=True`` (stationary):
        the second run shares the answer's Brownian increments (:mod:`._paired`),
        made on that call."""
        if paired and self.time is None:
            from .estimate import error_estimate
            self._estimate = error_estimate(self, paired=True)
        elif getattr(self, "_estimate", None) is None:
            from .estimate import error_estimate
            self._estimate = error_estimate(self)
        return dict(self._estimate)

    def __getstate__(self) -> dict[str, Any]:
        # the transient's second-run source is a closure over its run (not picklable):
        # a copy sent elsewhere keeps an estimate already made, or gives 2 SE only
        return {k: v for k, v in self.__dict__.items() if k != "_second_run"}

    def coloured_moments(self) -> dict[str, float]:
        """With coloured external noise ζ (:mod:`fpk_vibro.noise`): ``E_zeta2`` = E[ζ²]
        (D1/τ exactly: ζ starts from and keeps its stationary law), ``E_zeta_y`` =
        E[ζ y], the power ζ puts in (the input of :meth:`power_balance`), and their
        standard errors ``E_zeta2_se``, ``E_zeta_y_se`` (between batches); sampled with
        the moments (stationary: over the sampled time; transient: at ``time``).

        Raises
        ------
        InputError
            For a system with white external noise (ζ does not exist).
        """
        if self.system.external is None or "coloured" not in self._meta:
            return super().coloured_moments()
        return dict(self._meta["coloured"])

    def mean_x(self) -> float:
        """E[x], the average of the sampled x (not of the histogram); from the
        histogram by quadrature for files that predate it."""
        if "mean_x" in self._meta:
            return float(self._meta["mean_x"])
        return super().mean_x()

    def mean_x_se(self) -> float:
        """Standard error of :meth:`mean_x` (NaN for files that predate it)."""
        return float(self._meta.get("mean_x_se", np.nan))

    def impacts(self) -> dict[str, dict[str, float]]:
        """Impact statistics of each wall, over the sampled time (stationary) or the
        interval ending at ``time`` (transient).

        Returns
        -------
        dict
            ``{"left": {...}, "right": {...}}`` for the walls that exist, each with
            ``count`` (impacts of all paths), ``rate`` (impacts per unit time per
            path), ``mean_speed`` and ``mean_square_speed`` (of the speed u = |y|
            just before impact), ``energy_rate`` (Σ ½ (1 − r(u)²) u² over the
            impacts per unit time per path: the energy the wall removes) and
            ``mean_energy`` (the same sum per impact), and a standard error ``*_se``
            of each (between batches; NaN with no impact).  Below r ≈ 0.16 the count
            includes the chattering sequences resolved at the time step, so it
            depends on dt there.

        Raises
        ------
        ValueError
            For a file written before per-wall impacts were recorded.
        """
        if "impacts" not in self._meta:
            raise ValueError("MonteCarloSolution: no per-wall impact statistics in this "
                             "result (written by an older version); rerun it")
        return {side: dict(d) for side, d in self._meta["impacts"].items()}

    @property
    def info(self) -> dict[str, Any]:
        """Per-wall impacts, E[x] with its standard error (class docstring) and
        ``device``: "cpu" or the GPU's name (``device = "cuda"``)."""
        return {k: (self.impacts() if k == "impacts" else self.inter_impact()
                    if k == "inter_impact" else self._meta[k])
                for k in ("impacts", "inter_impact", "mean_x", "mean_x_se", "device")
                if k in self._meta}

    # -- persistence --------------------------------------------------------------
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return dict(self._meta), dict(self._arrays)

    _meta_schema = {
        "dt": Rule.number(0.0, lo_open=True), "n_paths": Rule.integer(1),
        "n_batches": Rule.integer(1), "t_sample": Rule.number(0.0), "t_burn": Rule.number(0.0),
        "time": Rule.number(0.0, none=True), "seed_entropy": Rule.ANY, "partial": Rule.FLAG,
        "impact_rate": Rule.number(0.0, nan=True), "impact_rate_se": Rule.number(0.0, nan=True),
        "n_samples": Rule.integer(0), "sample_every": Rule.integer(0),
        "quantities": Rule(f"a list of distinct names from {list(ALL_QUANTITIES)}",
                           lambda v: isinstance(v, list) and len(set(map(str, v))) == len(v)
                           and all(q in ALL_QUANTITIES for q in v)),
        "mode": Rule.choice(*BARRIER_KINDS),
        "overflow": Rule.mapping(Rule.number(0.0, hi=1.0)),
        "x_seen": Rule.listing(Rule.number(nan=True), 2), "scheme": Rule.TEXT,
        "impacts": Rule.mapping(Rule.mapping(Rule.number(nan=True), needs=_WALL_KEYS,
                                             keys=_WALL_KEYS + _WALL_KEYS_NEW),
                                keys=("left", "right")).optional(),
        "inter_impact": Rule("an object {count, mean, mean_se, unseen, pairs}",
                             lambda v: _gaps_ok(v)).optional(),
        "mean_x": Rule.number(nan=True).optional(),
        "mean_x_se": Rule.number(0.0, nan=True).optional(),
        "device": Rule.TEXT.optional(),
        "coloured": Rule.mapping(Rule.number(nan=True), needs=_COLOURED_KEYS,
                                 keys=_COLOURED_KEYS).optional(),
        # a phase of montecarlo.periodic ("phase", its phase and bin) or its period
        # average ("average")
        "periodic": Rule.choice("phase", "average").optional(),
        "phase": Rule.number(0.0).optional(), "phase_bin": Rule.number(0.0).optional()}

    @classmethod
    def _array_schema(cls, meta):
        """Moments and their errors (6 each); per histogram: edges, density, error."""
        out = {"moments": Stored((len(_MOMENT_NAMES),)),
               "moments_se": Stored((len(_MOMENT_NAMES),), nonneg=True, nan_ok=True)}
        for q in meta["quantities"]:
            if q in _FROM_ZERO:           # per wall (speeds, energies) or one (gaps)
                tag = _FROM_ZERO[q]
                for side in (_SIDES[meta["mode"]] if tag != "g" else ("",)):
                    sfx = f"{tag}_{side}" if side else tag
                    e = f"edges_{sfx}"
                    out[e] = Stored((e,), min_size=2, increasing=True, nonneg=True)
                    out[f"density_{sfx}"] = Stored((f"{e}-1",), nonneg=True)
                    out[f"se_{sfx}"] = Stored((f"{e}-1",), nonneg=True, nan_ok=True)
                continue
            for e in _HISTS[q]:
                out[e] = Stored((e,), min_size=2, increasing=True)
            bins = tuple(f"{e}-1" for e in _HISTS[q])
            out[f"density_{q}"] = Stored(bins, nonneg=True)
            out[f"se_{q}"] = Stored(bins, nonneg=True, nan_ok=True)
        return out

    @classmethod
    def _check_state(cls, system: VibroImpactSystem, meta: dict[str, Any],
                     arrays: dict[str, np.ndarray]) -> None:
        """``mode`` and the sides of ``impacts`` must be the stored system's walls."""
        if meta["mode"] != system.barriers:
            raise ValueError(f"meta['mode'] must be {system.barriers!r} (the walls of the "
                             f"stored system); got {meta['mode']!r}")
        sides = sorted(side for side, _ in system.walls)
        if "inter_impact" in meta["quantities"] and "inter_impact" not in meta:
            raise ValueError("meta['inter_impact'] is missing (the run kept 'inter_impact')")
        if "impacts" in meta and sorted(meta["impacts"]) != sides:
            raise ValueError(f"meta['impacts'] must have the keys {sides} (the walls of the "
                             f"stored system); got {sorted(meta['impacts'])}")

    @classmethod
    def _from_state(cls, system: VibroImpactSystem, meta: dict[str, Any],
                    arrays: dict[str, np.ndarray]) -> "MonteCarloSolution":
        return cls(system, meta, arrays)

    def __repr__(self) -> str:
        when = "stationary" if self.time is None else f"t={self.time:g}"
        flag = ", PARTIAL" if self.partial else ""
        return (f"MonteCarloSolution({when}, n_paths={self.n_paths}, dt={self.dt:g}, "
                f"t_sample={self.t_sample:g}{flag}, system={self.system!r})")
