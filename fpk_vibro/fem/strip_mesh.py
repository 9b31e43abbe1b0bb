"""A mesh given by the user (a skfem.Mesh or a file), checked to be a mesh of the strip."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import skfem

from .._checks import invalid
from ..model import VibroImpactSystem
from .generator import element_for, mesh_domain

__all__ = ["load_strip_mesh"]


def load_strip_mesh(system: VibroImpactSystem, mesh: Any, where: str = "fem"):
    """``mesh`` (a skfem.Mesh or a file) checked to be a mesh of the strip of ``system``.

    Raises :class:`InputError` naming ``mesh`` when the file cannot be read as a
    linear quadrilateral or triangle mesh, or when it is not a strip: walls at its
    x-extremes where the system has barriers, symmetric in y, no cell across y = 0.
    """
    if not isinstance(mesh, skfem.Mesh):
        path = Path(mesh)
        if not path.is_file():
            raise invalid(where, "mesh", "an existing mesh file", str(mesh))
        if path.stat().st_size > 2 ** 30:
            raise invalid(where, "mesh", "a mesh file below 1 GiB", str(mesh))
        try:
            mesh = skfem.Mesh.load(str(path))
        except Exception as exc:  # meshio raises many kinds on foreign files
            reason = " ".join(str(exc).split())[:120] or type(exc).__name__
            raise invalid(where, "mesh", "a mesh file meshio can read", str(path),
                          reason) from None
    try:
        element_for(mesh, 1)
        mesh_domain(system, mesh)
    except ValueError as exc:
        raise invalid(where, "mesh", "a linear quad or triangle mesh of the strip",
                      getattr(mesh, "__class__").__name__, str(exc)) from None
    y = mesh.p[1][mesh.t]
    scale = max(float(np.abs(mesh.p[1]).max()), 1e-300)
    crosses = (y.min(axis=0) < -1e-12 * scale) & (y.max(axis=0) > 1e-12 * scale)
    if np.any(crosses):
        raise invalid(where, "mesh", "a mesh with y = 0 a mesh line (no cell across it)",
                      f"{int(crosses.sum())} cells across y = 0")
    return mesh
