"""Regenerate the strip meshes shipped in ``meshes/`` (run from the repository root:
``python meshes/make_meshes.py``).

Each mesh covers the strip (docs/theory.md, §FPK on the strip) for the paper's parameters
(``VibroImpactSystem.paper()``: Δ = 0.6, default y_max rule of
``fpk_vibro.fem.mesh``), with y = 0 a mesh line, and is written with meshio
(Gmsh 4.1 format) through ``skfem.Mesh.save``.  Load one with
``fpk_vibro.fem.stationary(system, mesh="meshes/<name>.msh")``.
"""
from __future__ import annotations

from pathlib import Path

from fpk_vibro import VibroImpactSystem
from fpk_vibro.fem import domain, structured_mesh

HERE = Path(__file__).resolve().parent

MESHES = {
    # name: (system, nx, ny, kind, grading)
    "paper_d0.6_quad_32x96": (VibroImpactSystem.paper(), 32, 96, "quad", 0.0),
    "paper_d0.6_tri_32x96": (VibroImpactSystem.paper(), 32, 96, "tri", 0.0),
    "paper_d0.6_tri_graded_32x96": (VibroImpactSystem.paper(), 32, 96, "tri", 1.5),
    "paper_d1.0_quad_40x96": (VibroImpactSystem.paper(delta=1.0), 40, 96, "quad", 0.0),
}


def main() -> None:
    for name, (system, nx, ny, kind, grading) in MESHES.items():
        mesh, _, _ = structured_mesh(domain(system), nx, ny, kind=kind, grading=grading)
        path = HERE / f"{name}.msh"
        mesh.save(str(path))
        print(f"{path.name}: {mesh.p.shape[1]} nodes, {mesh.t.shape[1]} cells")


if __name__ == "__main__":
    main()
