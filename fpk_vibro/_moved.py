"""Modules that moved, and the deprecated paths that alias them for one release.

Each old path is a short file at its old place (its docstring begins "Deprecated
path:") that calls :func:`alias`: importing it warns (DeprecationWarning) and gives
the new module; ``python -m OLD.PATH`` warns and runs the new module's ``main``.
The new module is looked up in :data:`MOVED` by name, so an old path in a lower
folder (the benchmarks that were in ``fem/``) does not import the folder above it.
"""
from __future__ import annotations

import importlib
import sys
import warnings

__all__ = ["MOVED", "alias", "message"]

#: Old module path → new module path.  The old paths go in the next release.
MOVED = {
    **{f"fpk_vibro.{name}": f"fpk_vibro.app.{name}" for name in (
        "cli", "interrupt", "outdir", "plan", "plotting", "pool", "resume", "runner",
        "scene_keys", "scenes", "scheduler", "studies", "study_plots")},
    "fpk_vibro.app.benchmarks": "fpk_vibro.benchmarks.averaging",
    "fpk_vibro.montecarlo.benchmark": "fpk_vibro.benchmarks.montecarlo",
    "fpk_vibro.fem.benchmark": "fpk_vibro.benchmarks.fem_scale",
    "fpk_vibro.fem.benchmark_rtol": "fpk_vibro.benchmarks.fem_rtol",
    "fpk_vibro.fem.benchmark_transient": "fpk_vibro.benchmarks.fem_transient",
    "fpk_vibro.fem.benchmark_doublewell": "fpk_vibro.benchmarks.fem_doublewell",
    "fpk_vibro.fem.benchmark_first_passage": "fpk_vibro.benchmarks.fem_first_passage",
    "fpk_vibro.fem.benchmark_scenes": "fpk_vibro.benchmarks.fem_scenes",
}


def message(old: str) -> str:
    """The warning of the old module path ``old`` (a key of :data:`MOVED`): where it
    went, and when the old path goes."""
    new = MOVED[old]
    hint = " (benchmarks run as `fpk-vibro bench NAME`)" \
        if new.startswith("fpk_vibro.benchmarks.") else ""
    return f"{old} moved to {new}{hint}; the old path goes in the next release"


def alias(old: str, run: bool = False) -> None:
    """Make module ``old`` (the caller, at its deprecated path) the new module.

    Parameters
    ----------
    old : str
        The caller's module path (``__spec__.name``: right under ``python -m`` too).
    run : bool
        The caller runs as ``__main__`` (``python -m OLD.PATH``): run the new
        module's ``main`` and exit with what it returns.
    """
    module = importlib.import_module(MOVED[old])
    # the warning names the line that imported the old path (or, run as a script, it)
    warnings.warn(message(old), DeprecationWarning, stacklevel=2 if run else 3)
    if run:
        raise SystemExit(module.main())
    sys.modules[old] = module
