"""Deprecated path: fpk_vibro.scheduler moved to fpk_vibro.app.scheduler (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
