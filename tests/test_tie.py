"""Tied subdomains: operator consistency, patch test, conforming reference, MPI."""

from mpi4py import MPI

import dolfinx.fem as fem
import numpy as np
import pytest

from dd_contact import coupling, meshes, verify


def _spaces(volume_cell="hexahedron", surface_cell="quadrilateral"):
    vol = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 5, 5], volume_cell)
    surf = meshes.surface_from_boundary(
        vol, lambda x: np.isclose(x[0], 1.0), resolution=(7, 3), cell_type=surface_cell
    )
    return fem.functionspace(vol, ("Lagrange", 1)), fem.functionspace(surf, ("Lagrange", 1))


@pytest.mark.parametrize("volume_cell", ["hexahedron", "tetrahedron"])
@pytest.mark.parametrize("surface_cell", ["quadrilateral", "triangle"])
def test_tie_operators_consistent(volume_cell, surface_cell):
    V, S = _spaces(volume_cell, surface_cell)
    ops = coupling.tie_operators(V, S)
    one_v, one_s = np.ones(V.dofmap.index_map.size_local), np.ones(S.dofmap.index_map.size_local)
    # A rigid translation of both sides costs nothing: P1 1 = P2 1 exactly.
    assert np.abs(ops.P1 @ one_v - ops.P2 @ one_s).max() < 1e-14
    # Every operator integrates 1 over the whole unit face.
    assert one_v @ ops.P1 @ one_v == pytest.approx(1.0, abs=1e-13)
    assert one_s @ ops.P4 @ one_s == pytest.approx(1.0, abs=1e-13)
    assert ops.area == pytest.approx(1.0, abs=1e-13)
    # Exact over the facet intersections: int y z over the face, both fields linear.
    xv = V.tabulate_dof_coordinates()
    assert xv[:, 1] @ ops.P1 @ xv[:, 2] == pytest.approx(0.25, abs=1e-13)
    # Element height behind the tied facets: the hexahedra are 1/3 deep.
    if volume_cell == "hexahedron":
        assert ops.height == pytest.approx(1 / 3, rel=1e-12)


@pytest.mark.parametrize(
    "surface_cell,volume_cell",
    [("quadrilateral", "hexahedron"), ("triangle", "hexahedron"), ("triangle", "tetrahedron")],
)
def test_patch_test(surface_cell, volume_cell):
    assert verify.patch_test(1e6, surface_cell, volume_cell) < 1e-6


def test_patch_test_over_penalty_range():
    # Segment-based integration makes the tie exact for a patch: no O(1/kappa) error at all,
    # only round-off growing with kappa.
    errors = [verify.patch_test(kappa) for kappa in (1e2, 1e4, 1e6)]
    assert max(errors) < 1e-6
    assert errors[0] < 1e-11


def test_bent_bar_converges_like_one_over_kappa():
    kappas = np.array([1e2, 1e3, 1e4, 1e5])
    diffs = []
    for kappa in kappas:
        tied, single = verify.bent_bar(1, kappa, matching=True)
        diffs.append(abs(tied - single) / abs(single))
    slope = np.polyfit(np.log10(kappas), np.log10(diffs), 1)[0]
    assert slope == pytest.approx(-1.0, abs=0.05)
    tied, single = verify.bent_bar(1, 1e6, matching=True)
    assert abs(tied - single) / abs(single) < 1e-6


def test_bent_bar_non_matching_converges_with_mesh():
    diffs = []
    for r in (1, 2):
        tied, single = verify.bent_bar(r, 1e7, matching=False)
        diffs.append(abs(tied - single) / abs(single))
    assert diffs[0] < 0.05
    assert diffs[1] < 0.5 * diffs[0]


@pytest.mark.mpi
def test_patch_test_parallel():
    error = verify.patch_test(1e6)
    assert error < 1e-6
    # Every rank agrees on the result.
    assert MPI.COMM_WORLD.allreduce(error, op=MPI.MAX) == pytest.approx(error, rel=1e-12)
