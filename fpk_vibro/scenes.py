"""Deprecated path: fpk_vibro.scenes moved to fpk_vibro.app.scenes (kept for one release)."""
import sys
import warnings

from .app import scenes as _module

warnings.warn("fpk_vibro.scenes moved to fpk_vibro.app.scenes; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
