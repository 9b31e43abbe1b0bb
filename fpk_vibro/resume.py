"""Deprecated path: fpk_vibro.resume moved to fpk_vibro.app.resume (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
