"""FE fields written for ParaView through meshio (VTU and XDMF) read back equal."""
import meshio
import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem, fem


@pytest.fixture(scope="module")
def solution():
    return fem.stationary(VibroImpactSystem.paper(r=0.92), nx=16, ny=32)


@pytest.mark.parametrize("suffix", [".vtu", ".xdmf"])
def test_field_round_trip(tmp_path, solution, suffix):
    path = solution.save_vtu(tmp_path / f"field{suffix}")
    m = meshio.read(path)
    assert m.points.shape[0] == solution.mesh.p.shape[1]
    (name, values), = m.point_data.items()
    # nodal values of the density at the mesh vertices, in mesh order
    expect = solution.pdf_joint(solution.mesh.p[0], solution.mesh.p[1])
    assert np.allclose(np.asarray(values).ravel(), expect, rtol=1e-12, atol=1e-14)
