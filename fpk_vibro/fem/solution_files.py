"""An FE density in files: the state a solution file stores (meta data, arrays and
their schema, :mod:`fpk_vibro.solution_file`), and the mesh with the nodal density
for ParaView and the like (``FEMSolution.save_vtu``)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import skfem

from ..solution import Rule, Stored
from .mesh import ends_at_wall
from .options import Options

__all__ = ["state", "META_SCHEMA", "array_schema", "check_state", "state_mesh", "state_info",
           "write_mesh_file"]


def state(sol) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(meta, arrays) of ``sol`` as a solution file stores them: the scalar ``info``
    and the non-negative correction's record (``info["correction"]``, which its
    error estimate adds, :mod:`fpk_vibro.fem.nonnegative`)."""
    meta = {"degree": sol.degree, "cell": "quad" if isinstance(sol.mesh, skfem.MeshQuad1) else "tri",
            "residual": sol.residual, "tensor": sol._tensor is not None,
            "mass": sol.mass,
            "info": {k: v for k, v in sol.info.items()
                     if isinstance(v, (int, float, str, bool)) or v is None}}
    change = sol.info.get("correction")
    if isinstance(change, dict):
        meta["correction"] = {k: v for k, v in change.items()
                              if isinstance(v, (int, float, str, bool))}
    arrays = {"mesh_p": sol.mesh.p, "mesh_t": sol.mesh.t.astype(np.int64), "dofs": sol.dofs}
    if sol._tensor is not None:
        arrays["xnodes"], arrays["ynodes"] = sol._tensor
    return meta, arrays


#: The schema of the stored meta data.
META_SCHEMA = {"degree": Rule.of(Options.declared()["degree"]), "cell": Rule.choice("quad", "tri"),
               "residual": Rule.number(0.0, nan=True), "tensor": Rule.FLAG,
               "mass": Rule.number(0.0, lo_open=True, none=True).optional(),
               "info": Rule.mapping(Rule.SCALAR).optional(),
               "correction": Rule.mapping(Rule.SCALAR).optional()}


def array_schema(meta: dict[str, Any]) -> dict[str, Stored]:
    """Vertices (2, n), cells (corners, m) indexing them, DOF values; tensor nodes."""
    corners = 4 if meta["cell"] == "quad" else 3
    out = {"mesh_p": Stored((2, "vertices"), min_size=2 * corners),
           "mesh_t": Stored((corners, "cells"), dtype="int", min_size=corners,
                            below="vertices"),
           "dofs": Stored(("dofs",))}
    if meta["tensor"]:
        out["xnodes"] = Stored(("nx",), min_size=2, increasing=True)
        out["ynodes"] = Stored(("ny",), min_size=2, increasing=True)
    return out


def check_state(meta: dict[str, Any], arrays: dict[str, np.ndarray], system=None) -> None:
    """DOF count of the degree on this mesh (Q2: + edges + cells, P2: + edges); the
    walls of ``system`` at the mesh's x-extremes (as a solve requires them,
    :func:`fpk_vibro.fem.generator.mesh_domain`; the tensor x-nodes' ends too)."""
    t, n = arrays["mesh_t"], arrays["mesh_p"].shape[1]
    want = n
    if meta["degree"] > 2 and meta["tensor"]:    # Q3/Q4: (k nx + 1)(k ny + 1)
        k = meta["degree"]
        want = ((k * (arrays["xnodes"].size - 1) + 1)
                * (k * (arrays["ynodes"].size - 1) + 1))
    elif meta["degree"] == 2:
        u, v = t.ravel(), np.roll(t, -1, axis=0).ravel()          # the cells' edges
        key = np.sort(np.minimum(u, v) * n + np.maximum(u, v))
        edges = int(key.size > 0) + np.count_nonzero(np.diff(key))
        want += edges + (t.shape[1] if meta["cell"] == "quad" else 0)
    if arrays["dofs"].shape != (want,):
        raise ValueError(f"array 'dofs' has shape {arrays['dofs'].shape}, expected ({want},) "
                         f"for degree {meta['degree']} on this mesh")
    if meta["tensor"] and arrays["xnodes"].size * arrays["ynodes"].size != n:
        raise ValueError(f"arrays 'xnodes' ({arrays['xnodes'].size}) and 'ynodes' "
                         f"({arrays['ynodes'].size}) do not span the {n} mesh vertices")
    if system is not None:
        _check_walls(system, arrays)


def _check_walls(system, arrays: dict[str, np.ndarray]) -> None:
    """ValueError where a wall of the stored system is not the mesh's x-extreme on its
    side (to 1e-9 of the width, the tolerance of a solve)."""
    x = arrays["mesh_p"][0]
    ends = [("mesh", float(x.min()), float(x.max()))]
    if "xnodes" in arrays:
        ends.append(("tensor x-nodes", float(arrays["xnodes"][0]), float(arrays["xnodes"][-1])))
    for what, x0, x1 in ends:
        tol = 1e-9 * max(1.0, x1 - x0)
        for side, edge, wall in (("left", x0, system.left), ("right", x1, system.right)):
            if not ends_at_wall(system, side, edge, tol):     # (or a wall beyond the support)
                raise ValueError(f"the stored system's {side} wall x = {wall.position!r} "
                                 f"is not the {side} edge of the {what} (x = {edge!r}): "
                                 "the system and the mesh do not belong together")


def state_info(meta: dict[str, Any]) -> dict[str, Any]:
    """The ``info`` of a stored state, with the correction's record back in it."""
    info = dict(meta.get("info", {}))
    if "correction" in meta:
        info["correction"] = dict(meta["correction"])
    return info


def state_mesh(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> skfem.Mesh:
    """The mesh of a stored state."""
    kind = skfem.MeshQuad1 if meta["cell"] == "quad" else skfem.MeshTri1
    return kind(np.asarray(arrays["mesh_p"], float), np.asarray(arrays["mesh_t"]),
                sort_t=False)


def write_mesh_file(sol, path: str | Path) -> Path:
    """Write the mesh of ``sol`` with the nodal density ``p`` (vertex values) through meshio.

    Any extension meshio writes works (``.vtu`` for ParaView, ``.xdmf``, ...).
    The vertices are written as 3-D points (z = 0), which VTU, VTK, STL, ... need:
    given 2-D points meshio would print a warning on every write, even under
    ``--quiet``.
    """
    import meshio
    from .._checks import invalid
    if not isinstance(path, (str, Path)) or not str(path).strip():
        raise invalid("FEMSolution.save_vtu", "path", "a file path", path)
    path = Path(path)
    if path.suffix.lower() not in meshio.extension_to_filetypes:
        raise invalid("FEMSolution.save_vtu", "path", "a file name with an extension "
                      "meshio writes (.vtu, .xdmf, .vtk, ...)", str(path))
    from skfem.io.meshio import to_meshio
    vertex = (sol._eval(*sol.mesh.p) if sol.degree > 2
              else sol.dofs[sol.basis.nodal_dofs[0]])
    out = to_meshio(sol.mesh, point_data={"p": vertex})
    out.points = np.column_stack([out.points, np.zeros(len(out.points))])
    from ..io import atomic_files
    try:
        atomic_files(path, lambda p: meshio.write(     # .msh: gmsh, as skfem writes it
            str(p), out, **({"file_format": "gmsh"} if Path(p).suffix == ".msh" else {})))
    except (meshio.ReadError, meshio.WriteError, KeyError) as exc:
        raise invalid("FEMSolution.save_vtu", "path", "a file name with an extension "
                      "meshio writes", str(path), str(exc)) from None
    return path
