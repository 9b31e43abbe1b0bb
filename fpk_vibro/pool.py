"""Deprecated path: fpk_vibro.pool moved to fpk_vibro.app.pool (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
