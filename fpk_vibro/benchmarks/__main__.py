"""``python -m fpk_vibro.benchmarks``: the averaging benchmark, a deprecated path.

It ran :mod:`fpk_vibro.benchmarks.averaging` when this package was one module; use
``fpk-vibro bench averaging`` (``fpk-vibro bench NAME`` for the others).
"""
import warnings

from .averaging import main

warnings.warn("python -m fpk_vibro.benchmarks is deprecated: use `fpk-vibro bench averaging` "
              "(`fpk-vibro bench NAME` for the others); the old path goes in the next release",
              DeprecationWarning, stacklevel=1)
raise SystemExit(main())
