"""Deprecated path: fpk_vibro.study_plots moved to fpk_vibro.app.study_plots (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
