"""Deprecated path: fpk_vibro.app.benchmarks moved to fpk_vibro.benchmarks.averaging (kept for one release)."""
from .._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
