"""Deprecated path: fpk_vibro.interrupt moved to fpk_vibro.app.interrupt (kept for one release)."""
import sys
import warnings

from .app import interrupt as _module

warnings.warn("fpk_vibro.interrupt moved to fpk_vibro.app.interrupt; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
