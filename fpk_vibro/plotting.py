"""Deprecated path: fpk_vibro.plotting moved to fpk_vibro.app.plotting (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
