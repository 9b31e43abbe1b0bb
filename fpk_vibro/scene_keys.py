"""Deprecated path: fpk_vibro.scene_keys moved to fpk_vibro.app.scene_keys (kept for one release)."""
import sys
import warnings

from .app import scene_keys as _module

warnings.warn("fpk_vibro.scene_keys moved to fpk_vibro.app.scene_keys; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
