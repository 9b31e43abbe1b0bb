"""Deprecated path: fpk_vibro.studies moved to fpk_vibro.app.studies (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
