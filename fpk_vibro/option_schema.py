"""The schema of one numerical option: :class:`Option`, made with :func:`option`.

An :class:`Option` declares a value's type, range, default, unit, doc and the size
of a reduced run; it validates a value.  It knows nothing of the model or the
methods, so :mod:`fpk_vibro.model` declares its fields with it and
:mod:`fpk_vibro.options` builds the per-method option classes on it.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable

from ._checks import InputError, check_bool, check_choice, check_float, check_int, invalid

__all__ = ["Option", "PerMode", "option", "MODES", "DENSITY_MODES", "REQUIRED"]

#: The runs an option can serve: densities (stationary, transient), the first
#: passage out of a safe set (``first_passage(system, *, energy, start, times, ...)``)
#: and the periodic response to harmonic forcing (``periodic(system, phases, ...)``).
MODES = ("stationary", "transient", "first_passage", "periodic")
#: The modes of an option that does not name its own: the density runs.
DENSITY_MODES = ("stationary", "transient")


class _Required:
    """The default of an option that must be given."""

    def __repr__(self) -> str:
        return "required"


REQUIRED = _Required()


class _Same:
    """The first-passage value of a :class:`PerMode` that is the stationary one."""

    def __repr__(self) -> str:
        return "as stationary"


_SAME = _Same()


@dataclass(frozen=True)
class PerMode:
    """A default (or reduced size) that differs between the modes.

    ``first_passage`` is the stationary value unless given (first passage runs from
    a stationary scene); ``periodic`` (the periodic response to harmonic forcing) the
    transient value unless given (both march in time).
    """
    stationary: Any
    transient: Any
    first_passage: Any = _SAME
    periodic: Any = _SAME

    def of(self, mode: str) -> Any:
        """The value for ``mode`` (one of :data:`MODES`)."""
        if mode == "first_passage" and self.first_passage is _SAME:
            return self.stationary
        if mode == "periodic" and self.periodic is _SAME:
            return self.transient
        return getattr(self, mode)

    def __repr__(self) -> str:
        fp = "" if self.first_passage is _SAME else f", first passage {self.first_passage!r}"
        return f"{self.stationary!r} (transient {self.transient!r}{fp})"


@dataclass(frozen=True)
class Option:
    """One numerical option.

    ``kind`` is "int", "float", "choice", "bool", "text" or "custom" (then
    ``check(name, value, where)`` validates and ``allowed`` describes it).  ``auto``
    says what ``None`` means (None is then allowed).  ``modes`` are the runs that use
    it (default the density runs, :data:`DENSITY_MODES`; "first_passage" for the
    keywords of the methods' ``first_passage``).  ``reduced`` is the cap of a reduced
    run ("drop" removes the option).
    ``scene`` is "" (the key in the method's table), "file" (a path in the scene)
    or the scene key / CLI flag that sets it.
    """
    default: Any
    doc: str
    kind: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple = ()
    even: bool = False
    unit: str = ""
    auto: str = ""
    modes: tuple = DENSITY_MODES
    reduced: Any = None
    scene: str = ""
    check: Callable[[str, Any, str | None], Any] | None = None
    allowed: str = ""
    why: str = ""

    def validate(self, name: str, value: Any, where: str | None) -> Any:
        """The cleaned value, or :class:`InputError` naming ``name`` (and saying why)."""
        try:
            return self._validate(name, value, where)
        except InputError as exc:
            if not self.why:
                raise
            raise InputError(f"{exc} ({self.why})", where=exc.where, name=exc.name) from None

    def default_for(self, mode: str) -> Any:
        return self.default.of(mode) if isinstance(self.default, PerMode) else self.default

    @property
    def nullable(self) -> bool:
        return bool(self.auto) or self.default is None

    def _validate(self, name: str, value: Any, where: str | None) -> Any:
        if value is None:
            if self.nullable:
                return None
            raise invalid(where, name, self.describe(), value)
        if self.kind == "int":
            hi = None if math.isinf(self.hi) else int(self.hi)
            return check_int(name, value, int(self.lo), hi, where=where, even=self.even)
        if self.kind == "float":
            return check_float(name, value, self.lo, self.hi, lo_open=self.lo_open,
                               hi_open=self.hi_open, where=where)
        if self.kind == "choice":
            return check_choice(name, value, self.choices, where=where)
        if self.kind == "bool":
            return check_bool(name, value, where=where)
        if self.kind == "text":
            if not isinstance(value, str) or not value.strip() or len(value) > 4096:
                raise invalid(where, name, "a non-empty string", value)
            return value
        return self.check(name, value, where)

    def describe(self) -> str:
        """The allowed values, for messages and the table of scene keys."""
        if self.kind == "int":
            text = f"integer in [{int(self.lo)}, {int(self.hi)}]" if math.isfinite(self.hi) \
                else f"integer >= {int(self.lo)}"
            text = ("even " if self.even else "") + text
        elif self.kind == "float":
            from ._checks import interval
            text = interval(self.lo, self.hi, self.lo_open, self.hi_open)[2:]
        elif self.kind == "choice":
            text = "one of " + ", ".join(_toml(c) for c in self.choices)
        elif self.kind == "bool":
            text = "true or false"
        elif self.kind == "text":
            text = "a string"
        else:
            text = self.allowed
        return text


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


def option(default: Any, doc: str, kind: str, **spec: Any) -> Any:
    """A dataclass field declaring one :class:`Option` (see the module docstring)."""
    opt = Option(default, doc, kind, **spec)
    return dataclasses.field(default=opt.default_for("stationary"), metadata={"option": opt})
