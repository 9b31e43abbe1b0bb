"""Deprecated path: fpk_vibro.benchmarks moved to fpk_vibro.app.benchmarks (kept for one release)."""
import sys
import warnings

from .app import benchmarks as _module

warnings.warn("fpk_vibro.benchmarks moved to fpk_vibro.app.benchmarks; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
if __name__ == "__main__":     # python -m fpk_vibro.benchmarks
    raise SystemExit(_module.main())
sys.modules[__name__] = _module
