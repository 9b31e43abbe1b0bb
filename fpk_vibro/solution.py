"""The one result interface every method implements, and its file format.

File format (``Solution.save``): a NumPy ``.npz`` archive holding

- ``format``  : the string ``"fpk_vibro.solution"``;
- ``version`` : integer format version (currently 1);
- ``kind``    : which class wrote it (``"averaging"``, ``"exact"``, ...);
- ``system``  : the :class:`~fpk_vibro.VibroImpactSystem` as a JSON string;
- ``meta``    : a JSON string with the class's scalar settings;
- every other key: a float64/int64 array of the class's state, stored bit for bit.

``Solution.load(path)`` reads any of them back as the class that wrote it; the
loaded object evaluates every density and moment to the same bits as the saved one.
"""
from __future__ import annotations

import abc
import json
import os
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .io import atomic_write
from .model import VibroImpactSystem

__all__ = ["Solution", "MOMENT_KEYS"]

MOMENT_KEYS = ("E_H", "E_x2", "E_y2", "E_x4", "E_y4", "P_impact")
FORMAT_NAME = "fpk_vibro.solution"
FORMAT_VERSION = 1


class Solution(abc.ABC):
    """Stationary or transient response densities of a :class:`VibroImpactSystem`.

    All densities are vectorised over NumPy arrays (broadcasting ``x`` with ``y``)
    and are zero outside the strip ``left ≤ x ≤ right``.
    """

    kind: ClassVar[str] = ""
    _registry: ClassVar[dict[str, type["Solution"]]] = {}
    system: VibroImpactSystem

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.kind:
            Solution._registry[cls.kind] = cls

    # -- densities ----------------------------------------------------------------
    @abc.abstractmethod
    def pdf_energy(self, H: np.ndarray) -> np.ndarray:
        """Density of the energy H = y²/2 + G(x)."""

    @abc.abstractmethod
    def pdf_joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Joint density p(x, y) on the strip."""

    @abc.abstractmethod
    def pdf_x(self, x: np.ndarray) -> np.ndarray:
        """Marginal density of the displacement, p(x) = ∫ p(x, y) dy."""

    @abc.abstractmethod
    def pdf_y(self, y: np.ndarray) -> np.ndarray:
        """Marginal density of the velocity, p(y) = ∫ p(x, y) dx."""

    @abc.abstractmethod
    def moments(self) -> dict[str, float]:
        """E[H], E[x²], E[y²], E[x⁴], E[y⁴] and P_impact = P(H > G(Δ)).

        ``P_impact`` is absent when the system has no barrier.
        """

    # -- persistence --------------------------------------------------------------
    @abc.abstractmethod
    def _state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """(JSON-able scalar settings, arrays) that rebuild this object exactly."""

    @classmethod
    @abc.abstractmethod
    def _from_state(cls, system: VibroImpactSystem, meta: dict[str, Any],
                    arrays: dict[str, np.ndarray]) -> "Solution":
        """Inverse of :meth:`_state`."""

    def save(self, path: str | os.PathLike) -> Path:
        """Write this solution to ``path`` (``.npz``, see module docstring), atomically.

        Returns the path written (``.npz`` appended if missing).
        """
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        meta, arrays = self._state()
        reserved = {"format", "version", "kind", "system", "meta"}
        clash = reserved & set(arrays)
        if clash:
            raise RuntimeError(f"state arrays use reserved names {sorted(clash)}")
        payload = {
            "format": np.array(FORMAT_NAME),
            "version": np.array(FORMAT_VERSION),
            "kind": np.array(self.kind),
            "system": np.array(self.system.to_json()),
            "meta": np.array(json.dumps(meta, sort_keys=True)),
            **{k: np.asarray(v) for k, v in arrays.items()},
        }
        atomic_write(path, lambda fh: np.savez(fh, **payload))
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Solution":
        """Read a solution written by :meth:`save`, as the class that wrote it."""
        with np.load(path, allow_pickle=False) as data:
            if "format" not in data or str(data["format"]) != FORMAT_NAME:
                raise ValueError(f"{path}: not an fpk_vibro solution file")
            version = int(data["version"])
            if version > FORMAT_VERSION:
                raise ValueError(f"{path}: format version {version} is newer than this "
                                 f"fpk_vibro reads ({FORMAT_VERSION})")
            kind = str(data["kind"])
            system = VibroImpactSystem.from_dict(json.loads(str(data["system"])))
            meta = json.loads(str(data["meta"]))
            arrays = {k: data[k] for k in data.files
                      if k not in {"format", "version", "kind", "system", "meta"}}
        target = Solution._registry.get(kind)
        if target is None:
            raise ValueError(f"{path}: unknown solution kind {kind!r}; "
                             f"known: {sorted(Solution._registry)}")
        if cls is not Solution and not issubclass(target, cls):
            raise ValueError(f"{path}: holds a {target.__name__}, not a {cls.__name__}")
        return target._from_state(system, meta, arrays)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(system={self.system!r})"
