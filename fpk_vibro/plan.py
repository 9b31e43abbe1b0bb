"""Deprecated path: fpk_vibro.plan moved to fpk_vibro.app.plan (kept for one release)."""
import sys
import warnings

from .app import plan as _module

warnings.warn("fpk_vibro.plan moved to fpk_vibro.app.plan; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
