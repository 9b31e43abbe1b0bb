"""Benchmarks: ``fpk-vibro bench NAME [--quick] [options]``.

Each benchmark is a module of this package with ``main(argv) -> int`` that prints a
table (timings, errors against references; targets are reported, never asserted).
``--quick`` runs every one of them in a few seconds at reduced sizes: a smoke test
(CI runs them all so), not a measurement.  Measured tables: docs/measurements.md.

The benchmarks sit above the solvers and the application: they import the methods,
and only the command line (:mod:`fpk_vibro.app.cli`) imports them, when asked for.

Examples
--------
>>> from fpk_vibro.benchmarks import BENCHMARKS
>>> BENCHMARKS["fem-scale"].module
'fem_scale'
"""
from __future__ import annotations

import importlib
import warnings
from typing import Callable, NamedTuple

__all__ = ["BENCHMARKS", "Benchmark", "load"]


class Benchmark(NamedTuple):
    """A registered benchmark: its module in this package and what it measures."""

    module: str
    summary: str


#: The benchmarks by ``fpk-vibro bench`` name.
BENCHMARKS: dict[str, Benchmark] = {
    "averaging": Benchmark("averaging", "wall time of the stationary averaged solution"),
    "montecarlo": Benchmark("montecarlo", "kernel rates, time-step bias, wall time, "
                                          "first-passage kernel; --device cuda: the GPU "
                                          "against the CPU threads"),
    "fem": Benchmark("fem_rtol", "what accuracy costs: rtol against error, estimate, seconds"),
    "fem-scale": Benchmark("fem_scale", "DOFs and solvers on the exact case up to 10⁶ DOFs; AMG"),
    "fem-transient": Benchmark("fem_transient", "the FE transient on the paper packet"),
    "fem-doublewell": Benchmark("fem_doublewell", "the smooth double well, every degree"),
    "fem-first-passage": Benchmark("fem_first_passage", "accuracy and speed of "
                                                        "fem.first_passage by default"),
    "fem-scenes": Benchmark("fem_scenes", "the default stationary solve on random scenes"),
    "fem-restitution": Benchmark("fem_restitution", "cost of a tabulated restitution law "
                                 "against a constant r"),
    "fem-periodic": Benchmark("fem_periodic", "the periodic FE state under harmonic "
                              "forcing: seconds, K, estimate, amplitude and lag"),
    "fem-coloured": Benchmark("fem_coloured", "the 3-D coloured-noise solve: unknowns, "
                              "iterations, memory and seconds against LU"),
    "fem-spectrum": Benchmark("fem_spectrum", "the FE spectrum (fem.spectrum): seconds, "
                              "level, Krylov basis, estimate and error, linear and paper cases"),
}


def load(name: str) -> Callable[[list[str] | None], int]:
    """The ``main(argv)`` of a benchmark, its module imported on first use.

    Parameters
    ----------
    name : str
        A key of :data:`BENCHMARKS` (``fpk-vibro bench NAME``).

    Returns
    -------
    callable
        ``main(argv)``: parses ``argv`` (``--quick``, ``--help``, its own options),
        prints the table and returns the exit status.
    """
    return importlib.import_module(f".{BENCHMARKS[name].module}", __name__).main


def __getattr__(name: str):
    # fpk_vibro.benchmarks was the averaging benchmark's module (a deprecated path
    # to fpk_vibro.app.benchmarks); its ``main`` stays for one release
    if name == "main":
        warnings.warn("fpk_vibro.benchmarks.main moved to fpk_vibro.benchmarks.averaging.main "
                      "(`fpk-vibro bench averaging`); the old name goes in the next release",
                      DeprecationWarning, stacklevel=2)
        return load("averaging")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
