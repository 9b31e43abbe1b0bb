"""Deprecated path: fpk_vibro.scenes moved to fpk_vibro.app.scenes (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
