"""Deprecated path: fpk_vibro.cli moved to fpk_vibro.app.cli (kept for one release)."""
import sys
import warnings

from .app import cli as _module

warnings.warn("fpk_vibro.cli moved to fpk_vibro.app.cli; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
if __name__ == "__main__":     # python -m fpk_vibro.cli
    raise SystemExit(_module.main())
sys.modules[__name__] = _module
