"""Stationary paths streamed on a fixed sampling interval, and level crossings counted
at every step: the engine under :func:`~fpk_vibro.montecarlo.spectrum` and
:func:`~fpk_vibro.montecarlo.crossings`.

:class:`Paths` starts its paths as :func:`~fpk_vibro.montecarlo.stationary` does (the
same seed family: x at 0 or the nearest point of the strip, y Gaussian at the energy
scale, ζ from its stationary law), burns them in with the engine's own kernel
(:func:`._kernel.advance`, or the GPU's :class:`._cuda_engine.Ensemble`), then
advances them by :func:`._paths_kernel.paths_block` (CPU threads, one block of paths
per batch and stream) or :mod:`._cuda_paths` (one GPU thread per path), which take
the same step, write the sampled states into arrays and count crossings and peaks
(:mod:`._paths_kernel` has the counting rule).  Same seed, same numbers (on one
device: the GPU's streams are its own).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..model import VibroImpactSystem
from . import _kernel as K
from . import _setup as S
from ._engine import _initial_zeta, _run_chunks
from ._paths_kernel import PST, paths_block
from ._threads import run_blocks

__all__ = ["Paths", "effective_levels", "shared_options"]

#: The keywords :func:`shared_options` checks as :func:`~fpk_vibro.montecarlo.stationary`.
SHARED = ("n_paths", "dt", "t_burn", "t_sample", "seed", "n_batches", "target_rse",
          "max_t_sample", "max_impacts", "progress", "threads", "device")


def shared_options(where: str, system: Any, values: dict[str, Any],
                   default_paths: dict[str, int] | None = None):
    """The options these runs share with :func:`~fpk_vibro.montecarlo.stationary`,
    checked by its rules (a forced system refused, coloured noise taken) with the
    messages naming ``where``: (options, their defaults for ``system``, the device).
    ``default_paths`` ({"cpu": n, "cuda": m}): the caller's n_paths where
    ``values`` gives none, by the device."""
    from .._checks import InputError
    from ..model import check_system
    from . import _device
    from .options import Options
    unset = default_paths is not None and values.get("n_paths") is None
    if unset:
        values = {**values, "n_paths": default_paths["cpu"]}
    try:
        check_system(where, system, coloured=True)
        opts = Options.from_call("stationary", {k: values[k] for k in SHARED
                                                if k in values})
        opts.validate_for(system, "stationary")
        device = _device.resolve(opts.device, where)
    except InputError as exc:
        text = str(exc).replace("montecarlo.stationary", where)
        raise InputError(text, where=where, name=exc.name) from None
    resolved = opts.resolved(system, "stationary")
    if unset and device == "cuda":
        opts = opts.replace(n_paths=default_paths["cuda"])
    return opts, resolved, device


def effective_levels(system: VibroImpactSystem, levels: np.ndarray) -> np.ndarray:
    """The levels as the kernels count them: a level on the left wall is moved to the
    next float above it (its up-crossings are the departures from the wall,
    :mod:`._paths_kernel`)."""
    lo, _ = system.x_bounds
    out = np.array(levels, dtype=float)
    if math.isfinite(lo):
        out[out <= lo] = np.nextafter(lo, math.inf)
    return out


class Paths:
    """``n_paths`` stationary paths of ``system`` at step ``dt`` (module docstring).

    Parameters
    ----------
    system : VibroImpactSystem
    n_paths, n_batches, dt, seed, max_impacts, threads
        As :func:`~fpk_vibro.montecarlo.stationary` takes them (checked there).
    device : {"cpu", "cuda"}
        Resolved already (:func:`._device.resolve`).
    """

    def __init__(self, system: VibroImpactSystem, *, n_paths: int, n_batches: int,
                 dt: float, seed: Any, max_impacts: int, threads: int | None,
                 device: str) -> None:
        self.system = system
        self.n_paths, self.n_batches, self.dt = int(n_paths), int(n_batches), float(dt)
        self.threads = threads
        ss = S.seed_sequence(seed)
        self.seed_entropy = ss.entropy
        children = ss.spawn(n_batches + 1)
        self.rng = S.rng_states(children[:n_batches])
        gen = np.random.default_rng(children[n_batches])
        self.starts = S.block_starts(n_paths, n_batches)
        self.xs = np.full(n_paths, S.initial_x(system))
        self.ys = math.sqrt(S.energy_scale(system)) * gen.standard_normal(n_paths)
        self.zs = _initial_zeta(system, gen, n_paths)
        self.p, self.ip = S.step_params(system, dt, max_impacts)
        self.law = S.wall_laws(system)
        self.device = device
        #: What a result records as its device: "cpu" or the GPU's name.
        self.device_name = "cpu"
        self.ens = None
        self.gpu = None
        if device == "cuda":
            from . import _cuda_engine, _device
            from ._cuda_rng import seed_of
            self.device_name = _device.describe()["gpu"]
            self.ens = _cuda_engine.Ensemble(system, self.xs, self.ys, seed_of(children[0]),
                                             zs=self.zs)
        #: Impacts on the left and right wall and path-steps, per batch, since
        #: :meth:`reset_counts`.
        self.wcnt = np.zeros((n_batches, 3))
        self.levels = np.zeros(0)
        self.mean_level = 0.0
        self.cnt = np.zeros((n_batches, 2))
        self.pst = np.zeros((0, PST))
        lo, hi = system.x_bounds
        self.lo_in = float(np.nextafter(lo, math.inf))
        self.hi_in = float(np.nextafter(hi, -math.inf))

    # -- running --------------------------------------------------------------------
    def burn_in(self, n_steps: int, progress, frac=(0.0, 0.1), label="burn-in") -> None:
        """``n_steps`` steps by the stationary engine (nothing kept)."""
        nb = self.n_batches
        none = S.Histograms(self.system, (), S.check_bins("bins", 100, None), nb, 1.0)
        mom, imp = np.zeros((nb, K.NM)), np.zeros((nb, 2))
        xext = np.tile([np.inf, -np.inf], (nb, 1))
        _run_chunks(self.xs, self.ys, self.rng, self.starts, n_steps, 0, 0, self.p,
                    self.ip, mom, imp, xext, none, self.n_paths, progress, label, frac,
                    threads=self.threads, law=self.law, ens=self.ens, zeta=self.zs)

    def count_from_here(self, levels: np.ndarray, mean_level: float) -> None:
        """Start counting the up-crossings of the (sorted, effective) ``levels`` and the
        excursions above ``mean_level`` from the paths' present states."""
        self.levels = np.ascontiguousarray(levels, dtype=float)
        self.mean_level = float(mean_level)
        L = self.levels.size
        self.cnt = np.zeros((self.n_batches, 2 * L + 2))
        x = self.current_x()
        idx = np.searchsorted(self.levels, x, side="right")
        pst = np.empty((self.n_paths, PST))
        pst[:, 0] = idx
        pst[:, 1] = np.where(x >= self.mean_level, 2.0, 0.0)
        pst[:, 2] = x
        pad = np.concatenate([[-math.inf], self.levels, [math.inf]])
        pst[:, 3] = pad[idx]
        pst[:, 4] = pad[idx + 1]
        self.pst = pst
        if self.device == "cuda":
            self._gpu().count_from_here(self.levels, self.mean_level, pst)
        self.reset_counts()

    def reset_counts(self) -> None:
        self.wcnt[:] = 0.0
        self.cnt[:] = 0.0
        if self.gpu is not None:
            self.gpu.reset_counts()

    def current_x(self) -> np.ndarray:
        """The paths' positions now (from the GPU where they run there)."""
        if self.ens is not None:
            return self.ens.x.copy_to_host()
        return self.xs

    def advance(self, n_steps: int, every: int = 0, outx: np.ndarray | None = None,
                outy: np.ndarray | None = None) -> None:
        """``n_steps`` steps, counting where :meth:`count_from_here` was called, and
        writing the state after every ``every``-th step into the columns of ``outx``
        (and ``outy``: y), ``n_steps // every`` of them (``n_steps`` a multiple of
        ``every``)."""
        if every > 0 and (outx is None or n_steps % every or
                          outx.shape != (self.n_paths, n_steps // every)):
            raise ValueError("Paths.advance: n_steps must be a multiple of every, and outx "
                             "of shape (n_paths, n_steps // every)")
        ox = np.zeros((0, 0)) if outx is None else outx
        oy = np.zeros((0, 0)) if outy is None else outy
        if self.device == "cuda":
            self._gpu().advance(n_steps, every, ox, oy, self.cnt, self.wcnt)
            return
        zeta = np.zeros(0) if self.zs is None else self.zs
        run_blocks(paths_block, self.n_batches,
                   (self.xs, self.ys, zeta, self.rng, self.starts, int(n_steps),
                    int(every), self.p, self.ip, self.law, self.wcnt, ox, oy, self.levels,
                    self.mean_level, self.cnt, self.pst, self.lo_in, self.hi_in),
                   self.threads)

    def _gpu(self):
        if self.gpu is None:
            from ._cuda_paths import GpuPaths
            self.gpu = GpuPaths(self)
        return self.gpu

    # -- what was counted -----------------------------------------------------------
    def path_time(self) -> np.ndarray:
        """Path-time per batch since :meth:`reset_counts`."""
        return self.wcnt[:, 2] * self.dt

    def check_finite(self, where: str) -> None:
        """A non-finite state (the step too coarse) as one line naming dt."""
        x = self.current_x()
        bad = ~np.isfinite(x)
        if bad.any():
            raise FloatingPointError(
                f"{where}: {int(bad.sum())} of {x.size} paths left every bound (a "
                f"non-finite state) at dt = {self.dt:.3g} s: the step is too coarse for "
                "this system's fastest time scale (give a smaller dt)")
