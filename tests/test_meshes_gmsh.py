"""The Gmsh hemisphere of a Hertz contact test: volume, areas and facet tags."""

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from dd_contact import meshes

pytest.importorskip("gmsh")


def test_quarter_hemisphere():
    R = 2.0
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, 0.3, h_contact=0.1, h_far=0.4)
    assert mesh.topology.cell_type == dolfinx.mesh.CellType.tetrahedron
    x = mesh.geometry.x
    centre = np.array([0.0, 0.0, R])

    volume = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh)))
    assert volume == pytest.approx(np.pi * R**3 / 6, rel=1e-2)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    top = fem.assemble_scalar(fem.form(1.0 * ds(meshes.HEMISPHERE_TOP)))
    assert top == pytest.approx(np.pi * R**2 / 4, rel=1e-2)

    def nodes(tag):
        facets = tags.find(tag)
        assert facets.size > 0, f"no facet tagged {tag}"
        return x[np.unique(dolfinx.mesh.entities_to_geometry(mesh, 2, facets))]

    curved = nodes(meshes.HEMISPHERE_CURVED)
    assert np.abs(np.linalg.norm(curved - centre, axis=1) - R).max() < 1e-9
    assert np.abs(nodes(meshes.HEMISPHERE_TOP)[:, 2] - R).max() < 1e-12
    assert np.abs(nodes(meshes.HEMISPHERE_SYMMETRY_X)[:, 0]).max() < 1e-12
    assert np.abs(nodes(meshes.HEMISPHERE_SYMMETRY_Y)[:, 1]).max() < 1e-12
    # Every boundary facet is tagged, and the contact pole is a node.
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    boundary = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    assert np.array_equal(np.sort(tags.indices), boundary)
    assert np.linalg.norm(x, axis=1).min() < 1e-12
    assert x.min(axis=0) == pytest.approx([0, 0, 0], abs=1e-12)
    assert x.max(axis=0) == pytest.approx([R, R, R], abs=1e-12)


@pytest.mark.parametrize("quarter", [True, False], ids=["quarter", "full"])
@pytest.mark.parametrize("R", [1e-3, 5e-2, 1.0, 10.0])
def test_hemisphere_si_radii(R, quarter):
    """Any radius in SI units (1 mm to 10 m) meshes, with every length scaled by ``R``."""
    mesh, tags = meshes.hemisphere(
        MPI.COMM_SELF, R, 0.15 * R, h_contact=0.05 * R, h_far=0.2 * R, quarter=quarter
    )
    x = mesh.geometry.x
    # No inverted (or degenerate) cell: positive Jacobians of the (affine) tetrahedra.
    corners = x[mesh.geometry.dofmaps[0][:, :4]]
    det = np.linalg.det(corners[:, 1:] - corners[:, :1])
    assert det.min() > 1e-8 * R**3
    reference = 2 * np.pi * R**3 / 3 / (4 if quarter else 1)
    volume = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh)))
    assert volume == pytest.approx(reference, rel=2e-2)
    assert det.sum() / 6 == pytest.approx(volume, rel=1e-12)

    expected = {meshes.HEMISPHERE_CURVED, meshes.HEMISPHERE_TOP}
    if quarter:
        expected |= {meshes.HEMISPHERE_SYMMETRY_X, meshes.HEMISPHERE_SYMMETRY_Y}
    assert set(np.unique(tags.values)) == expected
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    boundary = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    assert np.array_equal(np.sort(tags.indices), boundary)

    def nodes(tag):
        return x[np.unique(dolfinx.mesh.entities_to_geometry(mesh, 2, tags.find(tag)))]

    curved = nodes(meshes.HEMISPHERE_CURVED)
    assert np.abs(np.linalg.norm(curved - [0.0, 0.0, R], axis=1) - R).max() < 1e-9 * R
    assert np.abs(nodes(meshes.HEMISPHERE_TOP)[:, 2] - R).max() < 1e-12 * R
    if quarter:
        assert np.abs(nodes(meshes.HEMISPHERE_SYMMETRY_X)[:, 0]).max() < 1e-12 * R
        assert np.abs(nodes(meshes.HEMISPHERE_SYMMETRY_Y)[:, 1]).max() < 1e-12 * R
    # The pole (0, 0, 0) is a node and the lowest point; the flat face is z = R.
    assert np.linalg.norm(x, axis=1).min() < 1e-12 * R
    assert x[:, 2].min() == pytest.approx(0.0, abs=1e-12 * R)
    assert x[:, 2].max() == pytest.approx(R, rel=1e-12)
