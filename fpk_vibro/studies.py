"""Deprecated path: fpk_vibro.studies moved to fpk_vibro.app.studies (kept for one release)."""
import sys
import warnings

from .app import studies as _module

warnings.warn("fpk_vibro.studies moved to fpk_vibro.app.studies; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
