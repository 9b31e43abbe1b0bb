"""Deprecated path: fpk_vibro.runner moved to fpk_vibro.app.runner (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
