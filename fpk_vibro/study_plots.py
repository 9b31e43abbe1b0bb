"""Deprecated path: fpk_vibro.study_plots moved to fpk_vibro.app.study_plots (kept for one release)."""
import sys
import warnings

from .app import study_plots as _module

warnings.warn("fpk_vibro.study_plots moved to fpk_vibro.app.study_plots; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _module
