"""Deprecated path: fpk_vibro.fem.benchmark_first_passage moved to fpk_vibro.benchmarks.fem_first_passage (kept for one release)."""
from .._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
