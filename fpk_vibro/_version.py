"""The package version, read once from the installed metadata (``version`` in
pyproject.toml, the one place it is written); "0+unknown" when the package runs
uninstalled.  Solution files, results.json and ``fpk-vibro --version`` record it."""
from __future__ import annotations

from importlib import metadata

__all__ = ["__version__"]


def _installed_version() -> str:
    try:
        return metadata.version("fpk_vibro")
    except metadata.PackageNotFoundError:
        return "0+unknown"


__version__ = _installed_version()
