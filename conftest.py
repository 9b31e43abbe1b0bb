"""pytest at the repository root.

The doctests of the package (``--doctest-modules``, ``testpaths`` in pyproject.toml)
skip the deprecated module paths (``fpk_vibro/runner.py`` and the like): each only
aliases its :mod:`fpk_vibro.app` module and warns on import, and its doctests are
collected at the new path.
"""
from pathlib import Path

collect_ignore = [str(p) for p in sorted((Path(__file__).parent / "fpk_vibro").glob("*.py"))
                  if p.read_text(encoding="utf-8").startswith('"""Deprecated path:')]
