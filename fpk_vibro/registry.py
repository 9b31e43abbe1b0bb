"""The methods, registered by name behind one contract.

Every part of the package that runs "a method" — the scene parser, ``fpk-vibro
check``, the runner, results.json, the figures, the capability table — loops over
:func:`methods`; this module is the only place that names them.

The contract (how to add a method)
----------------------------------
A method is a :class:`Method`: a name, the ``modes`` it solves (``"stationary"``,
``"transient"``, ``"first_passage"``), the ``quantities`` its solutions give, the
model ``features`` it handles (:data:`FEATURES`), whether its results are sampled
(Monte Carlo: standard errors), the ``Solution`` kinds it writes, and three callables:

- ``solver(mode)`` → the function ``f(system, **keywords)`` of that mode; transient
  solvers take ``initial=`` and ``times=``, first-passage solvers ``energy=``,
  ``start=``, ``times=``; each returns a :class:`fpk_vibro.solution.Solution` (a list
  of them for a transient) whose ``error_estimate()`` says how far off it is
  (:meth:`fpk_vibro.solution.Solution.error_estimate`);
- ``options()`` → its :class:`fpk_vibro.options.Options` subclass (the declared
  numerical keywords, budget and scene table: the method's table in a scene); leave
  ``options`` None for a method without numerical options;
- ``check(system, mode, quantities)`` (optional) → a reason it cannot, or None, for
  rules beyond the features (or it raises the InputError itself, naming the argument
  at fault, e.g. ``quantities``).  No built-in method needs one.

:meth:`Method.supports` raises one :class:`~fpk_vibro._checks.InputError` naming the
feature (or mode, or quantity) the method lacks and the registered methods that have
it.  :func:`register` adds a method (a toy one in a few lines:
``tests/test_registry.py``); the built-in ones are registered below.

Examples
--------
>>> from fpk_vibro import methods, VibroImpactSystem
>>> sorted(methods())
['averaging', 'exact', 'fem', 'montecarlo']
>>> methods()["exact"].supports(VibroImpactSystem.paper(r=1.0, D2=0.0))
>>> methods()["exact"].supports(VibroImpactSystem.paper())
Traceback (most recent call last):
...
fpk_vibro._checks.InputError: exact: does not handle inelastic walls (r < 1); averaging, fem, montecarlo do
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Callable

from ._checks import InputError, show
from .first_passage import ESTIMATORS as PASSAGE_ESTIMATORS
from .model import VibroImpactSystem
from .references import provide
from .safe_sets import SUPPORTED_BY as SAFE_SETS_SUPPORTED_BY

__all__ = ["Method", "FEATURES", "MODES", "QUANTITIES", "features_of", "methods", "register",
           "unregister", "capability_table"]

MODES = ("stationary", "transient", "first_passage", "periodic")
#: The modes of an unforced system.
_UNFORCED = MODES[:3]
QUANTITIES = ("energy", "x", "y", "joint", "moments", "impacts", "first_passage",
              "inter_impact", "impact_energy", "spectra", "crossings")
#: The safe sets a first passage may leave (:mod:`fpk_vibro.safe_sets`).
SAFE_SETS = ("energy", "displacement", "impact_speed")
#: The model features a method may or may not handle, with what each means.
FEATURES = {
    "walls": "walls (impacts)",
    "inelastic walls": "inelastic walls (r < 1)",
    "parametric noise": "parametric noise (D2 > 0)",
    "several wells": "a potential not increasing in |x| on the strip (double well, "
                     "softening beyond its hump)",
    "no damping": "no damping (c = 0)",
    "restitution laws": "restitution that depends on the impact speed (a law r(u))",
    "harmonic forcing": "harmonic forcing F cos(Ωt + φ0) (a periodic response)",
    "coloured noise": "coloured external noise (Ornstein–Uhlenbeck, correlation time τ)",
}


def features_of(system: VibroImpactSystem) -> tuple[str, ...]:
    """The :data:`FEATURES` of ``system``."""
    from .orbits import single_well
    out = []
    if system.has_barrier:
        out.append("walls")
    if any(not w.elastic for _, w in system.walls):
        out.append("inelastic walls")
    if system.D2 != 0:
        out.append("parametric noise")
    if not single_well(system):
        out.append("several wells")
    if system.c == 0:
        out.append("no damping")
    if any(w.law is not None for _, w in system.walls):
        out.append("restitution laws")
    if system.forcing is not None:
        out.append("harmonic forcing")
    if system.external is not None:
        out.append("coloured noise")
    return tuple(out)


@dataclass(frozen=True)
class Method:
    """One method (module docstring: the contract)."""

    name: str
    summary: str
    modes: tuple[str, ...]
    quantities: tuple[str, ...]
    features: tuple[str, ...]
    solver: Callable[[str], Callable[..., Any]] = field(repr=False)
    options: Callable[[], Any] | None = field(default=None, repr=False)
    sampled: bool = False
    solution_kinds: tuple[str, ...] = ()
    check: Callable[[VibroImpactSystem, str, tuple], str | None] | None = field(
        default=None, repr=False)
    study: str = ""
    benchmark: str = ""
    safe_sets: tuple[str, ...] = ("energy",)
    #: ``spectrum()`` → the method's ``spectrum(system, omega, of=..., **keywords)``
    #: (a :class:`~fpk_vibro.spectrum.Spectrum`); given where "spectra" is a quantity.
    spectrum: Callable[[], Callable[..., Any]] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        # ``solver(mode)`` refuses a mode the method does not declare, whatever the
        # factory would return (a mode is declared once: ``modes``)
        factory = getattr(self.solver, "factory", self.solver)
        object.__setattr__(self, "solver", _DeclaredModes(self.name, self.modes, factory))

    def options_class(self) -> Any:
        """The Options class (imports the method), or None."""
        return None if self.options is None else self.options()

    def supports(self, system: VibroImpactSystem, mode: str = "stationary",
                 quantities: tuple[str, ...] | list[str] = ()) -> None:
        """None if the method solves ``system`` in ``mode`` for ``quantities``; else
        :class:`InputError` naming what it lacks and the methods that have it."""
        def others(test: Callable[[Method], bool]) -> str:
            names = [m.name for m in methods().values() if m.name != self.name and test(m)]
            return f"; {', '.join(names)} do" if names else "; no registered method does"

        if mode not in self.modes:
            raise InputError(f"{self.name}: does not solve {mode} problems"
                             f"{others(lambda m: mode in m.modes)}", where=self.name,
                             name="mode")
        for q in quantities:
            if q not in self.quantities:
                raise InputError(f"{self.name}: does not give the quantity {q!r}"
                                 f"{others(lambda m: q in m.quantities)}", where=self.name,
                                 name="quantities")
        for feature in features_of(system):
            if feature not in self.features:
                raise InputError(f"{self.name}: does not handle {FEATURES[feature]}"
                                 f"{others(lambda m: feature in m.features)}",
                                 where=self.name, name="system")
        if self.check is not None:
            why = self.check(system, mode, tuple(quantities))
            if why:
                raise InputError(f"{self.name}: {why}", where=self.name, name="system")


class _DeclaredModes:
    """A method's ``solver(mode)``: the factory's solver for a declared mode, else one
    :class:`InputError` naming ``mode``, the method's modes and the methods that have it."""

    def __init__(self, name: str, modes: tuple[str, ...],
                 factory: Callable[[str], Callable[..., Any]]) -> None:
        self.name, self.modes, self.factory = name, modes, factory

    def __call__(self, mode: str) -> Callable[..., Any]:
        if not isinstance(mode, str) or mode not in self.modes:
            others = [m.name for m in methods().values()
                      if m.name != self.name and isinstance(mode, str) and mode in m.modes]
            also = f"; {', '.join(others)} do" if others else ""
            raise InputError(f"{self.name}: solver: mode must be one of {list(self.modes)}; "
                             f"got {show(mode)}{also}", where=self.name, name="mode")
        return self.factory(mode)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _DeclaredModes) and (self.name, self.modes, self.factory) \
            == (other.name, other.modes, other.factory)

    def __hash__(self) -> int:
        return hash((self.name, self.modes, self.factory))


_REGISTRY: dict[str, Method] = {}


def register(method: Method) -> Method:
    """Add ``method`` (replacing one of the same name); returns it."""
    if not isinstance(method, Method):
        raise TypeError(f"register needs a Method; got {type(method).__name__}")
    _REGISTRY[method.name] = method
    _declare_safe_sets()
    return method


def unregister(name: str) -> None:
    """Remove a registered method (tests register toy methods)."""
    _REGISTRY.pop(name, None)
    _declare_safe_sets()


def _declare_safe_sets() -> None:
    """Tell :mod:`fpk_vibro.safe_sets` which methods leave which safe set."""
    SAFE_SETS_SUPPORTED_BY.clear()
    for kind in SAFE_SETS:
        SAFE_SETS_SUPPORTED_BY[kind] = tuple(
            m.name for m in _REGISTRY.values()
            if "first_passage" in m.modes and kind in m.safe_sets)


def methods() -> dict[str, Method]:
    """The registered methods by name (a copy: register to add one)."""
    return dict(_REGISTRY)


# -- the built-in methods -------------------------------------------------------------
def _averaging_solver(mode: str):
    from . import averaging
    return getattr(averaging, mode)          # its stationary, transient, first_passage


def _averaging_options():
    from .averaging.options import Options
    return Options


def _fem_solver(mode: str):
    from . import fem
    return getattr(fem, mode)          # its stationary, transient, first_passage


def _spectrum_of(package: str) -> Callable[[], Callable[..., Any]]:
    def spectrum() -> Callable[..., Any]:
        from importlib import import_module
        return import_module(f".{package}", __package__).spectrum
    return spectrum


def _fem_options():
    from .fem.options import Options
    return Options


def _montecarlo_solver(mode: str):
    from . import montecarlo
    return getattr(montecarlo, mode)          # its stationary, transient, first_passage


def _montecarlo_options():
    from .montecarlo.options import Options
    return Options


def _exact_solver(mode: str):
    from .exact import gibbs
    return lambda system, **_: gibbs(system)


def _fem_reference(system: VibroImpactSystem, **options: Any) -> Any:
    """The FE density other methods are checked against (averaging's model error):
    ``fem.stationary(system, **options)``, the default solve without options."""
    return _fem_solver("stationary")(system, **options)


def _fem_transient_reference(system: VibroImpactSystem, *, initial: Any, times: Any,
                             **numerics: Any) -> Any:
    """The FE transient other methods are checked against (the averaged transient's
    model error): ``fem.transient(system, initial=..., times=..., **numerics)``."""
    return _fem_solver("transient")(system, initial=initial, times=times, **numerics)


def _montecarlo_passage_estimate(fp: Any, reference: Any = None) -> dict[str, Any]:
    from .montecarlo._first_passage_estimate import error_estimate
    return error_estimate(fp)


def _averaging_passage_estimate(fp: Any, reference: Any = None) -> dict[str, Any]:
    from .averaging.first_passage import model_error
    return model_error(fp, reference)


PASSAGE_ESTIMATORS.update(montecarlo=_montecarlo_passage_estimate,
                          averaging=_averaging_passage_estimate)
provide("fem", _fem_reference)
provide("fem-transient", _fem_transient_reference)
provide("fem-first-passage", lambda system, **kw: _fem_solver("first_passage")(system, **kw))

#: What a system with coloured noise gives, per method: the modes, and the quantities
#: (fem: those of the ζ-marginal; the impact-to-impact records need ζ at the impact).
COLOURED = {"fem": (("stationary", "transient"),
                    ("energy", "x", "y", "joint", "moments", "impacts", "crossings")),
            "montecarlo": (("stationary", "transient"),
                           ("energy", "x", "y", "joint", "moments", "impacts",
                            "inter_impact", "impact_energy", "spectra", "crossings"))}


def _forced_modes(system: VibroImpactSystem, mode: str, quantities: tuple,
                  method: str = "fem") -> str | None:
    """A forced system's response is periodic: no stationary density, no
    time-invariant first passage (fem and montecarlo: periodic and transient); a
    system with coloured noise is solved in the modes and for the quantities of
    :data:`COLOURED`."""
    if system.forcing is not None and mode in ("stationary", "first_passage"):
        return (f"a system with harmonic forcing has no {mode.replace('_', ' ')} answer "
                "(its response is periodic); use the modes periodic or transient")
    if system.external is not None:
        modes, given = COLOURED[method]
        if mode not in modes:
            also = [m for m, (ms, _) in COLOURED.items() if mode in ms and m != method]
            return (f"does not solve {mode.replace('_', ' ')} problems of a system with "
                    f"coloured noise" + (f"; {', '.join(also)} does" if also else ""))
        other = [q for q in quantities if q not in given]
        if other:
            return (f"does not give {other[0]!r} for a system with coloured noise (it "
                    f"gives {', '.join(given)})")
    return None


def _montecarlo_modes(system: VibroImpactSystem, mode: str, quantities: tuple) -> str | None:
    return _forced_modes(system, mode, quantities, "montecarlo")


for _m in (
    Method("averaging", "stochastic averaging of the energy envelope (1-D in H)",
           _UNFORCED, QUANTITIES,
           tuple(f for f in FEATURES
                 if f not in ("several wells", "harmonic forcing", "coloured noise")),
           _averaging_solver, _averaging_options, safe_sets=SAFE_SETS,
           solution_kinds=("averaging", "averaging_grid"), study="n_panel ladder",
           benchmark="averaging", spectrum=_spectrum_of("averaging")),
    Method("fem", "finite elements for the 2-D FPK on the strip", MODES, QUANTITIES,
           tuple(FEATURES), _fem_solver, _fem_options, solution_kinds=("fem",),
           safe_sets=SAFE_SETS, check=_forced_modes,
           study="degree and nx ladder", benchmark="fem", spectrum=_spectrum_of("fem")),
    Method("montecarlo", "Monte Carlo simulation of the SDE with located impacts",
           MODES, QUANTITIES, tuple(FEATURES), _montecarlo_solver, _montecarlo_options,
           sampled=True, safe_sets=SAFE_SETS, check=_montecarlo_modes,
           solution_kinds=("montecarlo",), study="target standard error ladder",
           benchmark="montecarlo", spectrum=_spectrum_of("montecarlo")),
    Method("exact", "the Gibbs density exp(−(c/D1) H)/Z (r = 1, D2 = 0)", ("stationary",),
           ("energy", "x", "y", "joint", "moments", "impacts", "crossings"),
           ("walls", "several wells", "restitution laws"), _exact_solver,
           solution_kinds=("exact",)),
):
    register(_m)


def capability_table() -> str:
    """The Markdown table method × (modes, quantities, model features): ``fpk-vibro
    methods`` prints it and docs/guide/methods.md holds it (a test keeps them equal)."""
    cols = (list(MODES) + [q for q in QUANTITIES if q not in MODES] + list(FEATURES)
            + [f"leaves {k}" for k in SAFE_SETS[1:]])
    head = ["method", "sampled"] + cols
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for m in methods().values():
        cells = [f"`{m.name}`", "yes" if m.sampled else "no"]
        for c in cols:
            have = (c in m.modes or c in m.quantities or c in m.features
                    or c.removeprefix("leaves ") in m.safe_sets)
            cells.append("yes" if have else "–")
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"


def replace(method: Method, **changes: Any) -> Method:
    """A copy of ``method`` with ``changes`` (e.g. to register a variant)."""
    return dataclasses.replace(method, **changes)
