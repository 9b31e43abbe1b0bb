"""Deprecated path: fpk_vibro.cli moved to fpk_vibro.app.cli (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
