"""Deprecated path: fpk_vibro.outdir moved to fpk_vibro.app.outdir (kept for one release)."""
import sys
import warnings

from .app import outdir as _module

warnings.warn("fpk_vibro.outdir moved to fpk_vibro.app.outdir; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
