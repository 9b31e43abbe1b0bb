"""Deprecated path: fpk_vibro.runner moved to fpk_vibro.app.runner (kept for one release)."""
import sys
import warnings

from .app import runner as _module

warnings.warn("fpk_vibro.runner moved to fpk_vibro.app.runner; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
