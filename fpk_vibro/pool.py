"""Deprecated path: fpk_vibro.pool moved to fpk_vibro.app.pool (kept for one release)."""
import sys
import warnings

from .app import pool as _module

warnings.warn("fpk_vibro.pool moved to fpk_vibro.app.pool; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
