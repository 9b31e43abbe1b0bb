"""Deprecated path: fpk_vibro.scheduler moved to fpk_vibro.app.scheduler (kept for one release)."""
import sys
import warnings

from .app import scheduler as _module

warnings.warn("fpk_vibro.scheduler moved to fpk_vibro.app.scheduler; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
