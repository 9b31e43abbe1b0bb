"""pytest at the repository root.

The doctests of the package (``--doctest-modules``, ``testpaths`` in pyproject.toml)
skip the deprecated module paths (:data:`fpk_vibro._moved.MOVED`: ``fpk_vibro/runner.py``,
``fpk_vibro/fem/benchmark.py`` and the like): each only aliases its new module and
warns on import, and its doctests are collected at the new path.
"""
import glob
import os
from pathlib import Path

# numba-cuda's simulator must be chosen before numba first loads (numba imports its
# CUDA extension when it starts): on a machine without an NVIDIA device the whole
# session runs with it, so the GPU tests (tests/test_montecarlo_cuda.py and the
# like) run on the simulator in any order; with a device they test the hardware.
if not glob.glob("/dev/nvidia[0-9]*"):
    os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "1")

from fpk_vibro._moved import MOVED  # noqa: E402

collect_ignore = [str(Path(__file__).parent.joinpath(*old.split(".")).with_suffix(".py"))
                  for old in MOVED]
