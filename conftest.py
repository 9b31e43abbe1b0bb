"""pytest at the repository root.

The doctests of the package (``--doctest-modules``, ``testpaths`` in pyproject.toml)
skip the deprecated module paths (:data:`fpk_vibro._moved.MOVED`: ``fpk_vibro/runner.py``,
``fpk_vibro/fem/benchmark.py`` and the like): each only aliases its new module and
warns on import, and its doctests are collected at the new path.
"""
from pathlib import Path

from fpk_vibro._moved import MOVED

collect_ignore = [str(Path(__file__).parent.joinpath(*old.split(".")).with_suffix(".py"))
                  for old in MOVED]
