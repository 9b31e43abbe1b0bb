"""Deprecated path: fpk_vibro.resume moved to fpk_vibro.app.resume (kept for one release)."""
import sys
import warnings

from .app import resume as _module

warnings.warn("fpk_vibro.resume moved to fpk_vibro.app.resume; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
