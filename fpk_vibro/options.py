"""Numerical options declared once: type, range, default, unit, doc, reduced size.

Each method declares its options as a frozen dataclass (``averaging.Options``,
``fem.Options``, ``montecarlo.Options``) whose fields are made with
:func:`option`.  From that one declaration come

- the validation of the solver's Python keywords (:meth:`Options.from_call`),
- the scene schema of the method's table (``[averaging]``, ``[fem]``,
  ``[montecarlo]``) and its validation (:meth:`Options.from_scene`),
- the sizes of a reduced run (:meth:`Options.reduce`), and
- the table of scene keys, docs/guide/keys.md (:func:`fpk_vibro.app.scenes.schema_table`).

A keyword given as a Python object (a mesh, a callable) is declared with the form
it takes in a scene (a file).  A keyword that a scene sets elsewhere (the output
times, the quantities, progress) names that place in ``scene``.
"""
from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ._checks import InputError
# the schema lives in option_schema (the model declares its fields with it); these
# names stay importable from here
from .option_schema import (DENSITY_MODES, MODES, REQUIRED, Option, PerMode,  # noqa: F401
                            _Required, _toml, option)

__all__ = ["Option", "PerMode", "option", "Options", "MODES", "DENSITY_MODES", "REQUIRED"]

#: Where a run of each mode comes from in a scene (for the refusal of a key of
#: another mode).
_MODE_RUNS = {"stationary": "stationary (no study.times)",
              "transient": "transient (with study.times)",
              "first_passage": "first-passage (a stationary scene with the quantity "
                               "\"first_passage\")",
              "periodic": "periodic (a scene with [forcing], no study.times)"}


class Options:
    """Base of the per-method option dataclasses.

    Subclasses are frozen dataclasses whose fields are made with :func:`option`
    and set ``WHERE`` (the method's name in messages and scenes).
    """

    WHERE: ClassVar[str] = ""
    #: The modes whose solver handles harmonic forcing (the others refuse a forced
    #: system in one line: :func:`fpk_vibro.model.check_system`).
    FORCED_MODES: ClassVar[tuple[str, ...]] = ()
    #: The modes whose solver handles coloured external noise (the others refuse it
    #: in one line: :func:`fpk_vibro.model.check_system`).
    COLOURED_MODES: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def declared(cls) -> dict[str, Option]:
        """{name: Option} in declaration order."""
        return {f.name: f.metadata["option"] for f in dataclasses.fields(cls)}

    @classmethod
    def for_mode(cls, mode: str) -> dict[str, Option]:
        return {k: o for k, o in cls.declared().items() if mode in o.modes}

    @classmethod
    def from_call(cls, mode: str, values: dict[str, Any]):
        """Validate a solver's keywords (``locals()`` at its start) for ``mode``.

        Keys that are not options (``system``, ``initial``, ``times``) are ignored;
        options of the other mode keep their defaults.
        """
        where = f"{cls.WHERE}.{mode}"
        declared = cls.declared()
        clean = {}
        for name, opt in declared.items():
            if name in values and mode in opt.modes:
                clean[name] = opt.validate(name, values[name], where)
            else:
                clean[name] = opt.default_for(mode)
        return cls(**clean)

    @classmethod
    def from_scene(cls, mode: str, table: dict[str, Any]) -> dict[str, Any]:
        """Validate a scene table for ``mode``: {key: value} of the keys given.

        A stationary scene's table also holds the keys of first passage (which runs
        from a stationary scene); whether the scene asks for it is checked with
        the scene (:func:`fpk_vibro.app.plan.plan`).  Raises :class:`InputError`
        whose ``name`` is the scene key (``fem.nx``).
        """
        modes = (mode, "first_passage") if mode == "stationary" else (mode,)
        declared = cls.declared()
        out = {}
        for key, value in table.items():
            full = f"{cls.WHERE}.{key}"
            opt = declared.get(key)
            if opt is None or opt.scene not in ("", "file"):
                from ._checks import closest
                keys = [k for k, o in declared.items() if o.scene in ("", "file")]
                hint = f" (set by {opt.scene})" if opt is not None else closest(key, keys)
                raise InputError(f"{full}: unknown key; allowed {keys}{hint}", name=full)
            if not set(modes) & set(opt.modes):
                other = " or ".join(_MODE_RUNS[m] for m in opt.modes)
                raise InputError(f"{full}: only used by {other} runs; remove it", name=full)
            out[key] = opt.validate(full, value, None)
        return out

    @classmethod
    def reduce(cls, mode: str, given: dict[str, Any]) -> dict[str, Any]:
        """The scene values of a reduced run: each size capped at its ``reduced``."""
        out = dict(given)
        for name, opt in cls.for_mode(mode).items():
            cap = opt.reduced.of(mode) if isinstance(opt.reduced, PerMode) else opt.reduced
            if cap is None:
                continue
            if cap == "drop":
                out.pop(name, None)
                continue
            current = out.get(name, opt.default_for(mode))
            out[name] = cap if current is None else min(current, cap)
        return out

    @classmethod
    def prepare(cls, system: Any, mode: str, values: dict[str, Any], *, initial: Any = None,
                times: Any = None, probe: bool = False):
        """Everything a solver checks before its work; returns (options, cost).

        ``values`` are the solver's keywords (its ``locals()``); ``initial`` a parsed
        initial condition (checked against the options), ``times`` the output
        times; ``probe`` adds the checks a solver meets only while it works (the
        scene check).  Work beyond the budget is refused (:mod:`fpk_vibro.budget`).
        """
        from .budget import enforce
        from .model import check_system
        where = f"{cls.WHERE}.{mode}"
        check_system(where, system, forcing=mode in cls.FORCED_MODES,
                     coloured=mode in cls.COLOURED_MODES)
        opts = cls.from_call(mode, values)
        opts.validate_for(system, mode, probe=probe)
        if initial is not None and hasattr(opts, "validate_initial"):
            opts.validate_initial(system, initial)
        return opts, enforce(opts.estimate(system, mode, times), where)

    def replace(self, **changes: Any):
        return dataclasses.replace(self, **changes)
