"""Deprecated path: fpk_vibro.plan moved to fpk_vibro.app.plan (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
