"""Reference solutions one method asks of another, without importing it.

Averaging's model error is measured against the finite-element density of the same
system (``"fem"``, :mod:`fpk_vibro.averaging.validity`) and its transient's against
the FE transient from the same initial condition (``"fem-transient"``,
:meth:`fpk_vibro.averaging.EnergyGridSolution.error_estimate`), and its first
passage's against the FE first passage of the same system, energy and start
(``"fem-first-passage"``, :func:`fpk_vibro.averaging.first_passage.model_error`),
while the FE first passage already builds on averaging: a direct import would close a
circle.  The registry (:mod:`fpk_vibro.registry`, above every method) provides the
solvers here when the package loads; a method asks by name.
"""
from __future__ import annotations

from typing import Any, Callable

__all__ = ["provide", "reference"]

_PROVIDERS: dict[str, Callable[..., Any]] = {}


def provide(name: str, solve: Callable[..., Any]) -> None:
    """Make ``solve(system, **options)`` the reference solution called ``name``."""
    _PROVIDERS[name] = solve


def reference(name: str, system: Any, **options: Any) -> Any:
    """The reference solution ``name`` of ``system`` (``options``: what that solver
    takes besides the system, e.g. ``initial``, ``times`` and ``rtol`` of
    ``"fem-transient"``).

    Raises
    ------
    LookupError
        If no solver of that name was provided.
    """
    try:
        solve = _PROVIDERS[name]
    except KeyError:
        raise LookupError(f"no {name!r} reference solver is provided (known: "
                          f"{sorted(_PROVIDERS)})") from None
    return solve(system, **options)
