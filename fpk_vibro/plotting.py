"""Deprecated path: fpk_vibro.plotting moved to fpk_vibro.app.plotting (kept for one release)."""
import sys
import warnings

from .app import plotting as _module

warnings.warn("fpk_vibro.plotting moved to fpk_vibro.app.plotting; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
