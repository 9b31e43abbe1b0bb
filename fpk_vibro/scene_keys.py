"""Deprecated path: fpk_vibro.scene_keys moved to fpk_vibro.app.scene_keys (kept for one release)."""
from ._moved import alias

alias(__spec__.name, run=__name__ == "__main__")
