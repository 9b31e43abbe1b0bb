"""fpk_vibro: response densities of a randomly excited vibro-impact Duffing oscillator.

Three methods share one model (:class:`VibroImpactSystem`) and one result
interface (:class:`Solution`):

- :mod:`fpk_vibro.averaging`  — stochastic averaging of the energy envelope;
- :mod:`fpk_vibro.fem`        — finite elements for the 2-D FPK on the strip;
- :mod:`fpk_vibro.montecarlo` — Monte Carlo simulation of the SDE with impacts;
- :mod:`fpk_vibro.exact`      — the exact Gibbs density for r = 1, D2 = 0.

Submodules are imported on first use, so ``import fpk_vibro`` stays light.
"""
from __future__ import annotations

import importlib

from . import _version
from .model import VibroImpactSystem, Wall
from .restitution import Restitution
from .forcing import Harmonic
from .noise import OrnsteinUhlenbeck
from .registry import methods
from .solution import MOMENT_KEYS, Solution

__all__ = ["VibroImpactSystem", "Wall", "Restitution", "Harmonic", "OrnsteinUhlenbeck", "Solution", "MOMENT_KEYS", "methods",
           "averaging", "exact", "fem", "montecarlo"]


#: The package version (fpk_vibro._version): solution files, results.json and
#: ``fpk-vibro --version`` record it.
__version__ = _version.__version__
_installed_version = _version._installed_version

#: Submodules imported on first use, by attribute name: the application wing's
#: command line and figures live in :mod:`fpk_vibro.app`.
_LAZY = {"averaging": ".averaging", "exact": ".exact", "fem": ".fem",
         "montecarlo": ".montecarlo", "orbits": ".orbits", "io": ".io", "app": ".app",
         "cli": ".app.cli", "plotting": ".app.plotting"}


def __getattr__(name: str):
    if name in _LAZY:
        return importlib.import_module(_LAZY[name], __name__)
    raise AttributeError(f"module 'fpk_vibro' has no attribute {name!r}")
