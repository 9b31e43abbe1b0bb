"""Deprecated path: fpk_vibro.outdir moved to fpk_vibro.app.outdir (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
