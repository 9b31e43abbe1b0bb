"""What a run will cost, and the limits beyond which it is refused before any work.

Every solver estimates its memory, its work (DOFs × steps, path-steps, …) and its
run time on this kind of machine (constants measured on a 2-core x86-64 VM, see
``docs/costs.md``) and calls :func:`enforce` before allocating.  Work beyond the
machine is refused with a :class:`~fpk_vibro._checks.InputError` naming the
option, the estimate and the limit:

- memory above :data:`MEMORY_SHARE` of the memory available now;
- an estimated run time above :data:`MAX_SECONDS` (a day);
- (scenes) more sweep points than :data:`MAX_POINTS`.

``with fpk_vibro.budget.unlimited():`` (the CLI's ``--force``) lifts the limits.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
from dataclasses import dataclass

from ._checks import InputError

__all__ = ["Cost", "enforce", "unlimited", "available_memory", "MAX_SECONDS",
           "MAX_POINTS", "MEMORY_SHARE", "forced", "human_bytes", "human_seconds"]

#: Longest estimated run time accepted (s): a day.
MAX_SECONDS = 86_400.0
#: Most sweep points accepted in one scene.
MAX_POINTS = 10_000
#: Share of the available memory one run may take.
MEMORY_SHARE = 0.8

_FORCED = contextvars.ContextVar("fpk_vibro_budget_forced", default=False)


@dataclass(frozen=True)
class Cost:
    """An estimate: bytes of memory, units of work and seconds on this machine kind;
    ``note``: what the check should say beside it (e.g. a goal that may not be met)."""
    memory: float
    work: float
    unit: str
    seconds: float
    key: str = ""        # the option that drives the cost, named in a refusal
    note: str = ""

    def __add__(self, other: "Cost") -> "Cost":
        note = "; ".join(n for n in (self.note, other.note) if n)
        return Cost(max(self.memory, other.memory), self.work + other.work, self.unit,
                    self.seconds + other.seconds, self.key or other.key, note)

    def describe(self) -> str:
        return (f"~{human_bytes(self.memory)}, {self.work:.3g} {self.unit}, "
                f"~{human_seconds(self.seconds)}" + (f" ({self.note})" if self.note else ""))


def available_memory() -> float:
    """Bytes of memory available now (MemAvailable; the physical memory elsewhere)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8.0 * 2 ** 30


def forced() -> bool:
    return _FORCED.get()


@contextlib.contextmanager
def unlimited():
    """Within this block no estimate is refused (the CLI's ``--force``)."""
    token = _FORCED.set(True)
    try:
        yield
    finally:
        _FORCED.reset(token)


def human_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}"
        n /= 1024.0
    return f"{n:.3g} TiB"   # pragma: no cover


def human_seconds(s: float) -> str:
    if s < 120:
        return f"{s:.2g} s"
    if s < 7200:
        return f"{s / 60:.3g} min"
    if s < 2 * 86400:
        return f"{s / 3600:.3g} h"
    return f"{s / 86400:.3g} days"


def enforce(cost: Cost, where: str) -> Cost:
    """Raise :class:`InputError` if ``cost`` is beyond the limits (unless forced)."""
    if forced():
        return cost
    key = cost.key or "the run"
    limit = MEMORY_SHARE * available_memory()
    if cost.memory > limit:
        raise InputError(f"{where}: {key} needs an estimated {human_bytes(cost.memory)} of "
                         f"memory; the limit is {human_bytes(limit)} ({MEMORY_SHARE:.0%} of the "
                         "memory available); use a smaller size or force it (--force)",
                         where=where, name=key)
    if cost.seconds > MAX_SECONDS:
        raise InputError(f"{where}: {key} needs an estimated {human_seconds(cost.seconds)} "
                         f"({cost.work:.3g} {cost.unit}); the limit is "
                         f"{human_seconds(MAX_SECONDS)}; use a smaller size or force it "
                         "(--force)", where=where, name=key)
    return cost
