"""Deprecated path: fpk_vibro.fem.benchmark_doublewell moved to fpk_vibro.benchmarks.fem_doublewell (kept for one release)."""
from .._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
