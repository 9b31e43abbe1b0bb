"""Deprecated path: fpk_vibro.montecarlo.benchmark moved to fpk_vibro.benchmarks.montecarlo (kept for one release)."""
from .._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
