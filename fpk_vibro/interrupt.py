"""Deprecated path: fpk_vibro.interrupt moved to fpk_vibro.app.interrupt (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
