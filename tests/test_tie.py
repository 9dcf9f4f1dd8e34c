"""Tied subdomains: operator consistency, patch test, conforming reference, MPI."""

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from dd_contact import coupling, meshes
from dd_contact.paper import verify
from dd_contact.post import cell_stress
from dd_contact.problem import StaticProblem
from dd_contact.scene import Interface, Scene
from dd_contact.subdomains import Material, Subdomain


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


@pytest.mark.parametrize("volume_cell", ["hexahedron", "tetrahedron"])
@pytest.mark.parametrize("surface_cell", ["quadrilateral", "triangle"])
def test_tie_operators_leave_nodes_off_a_flat_face_out(volume_cell, surface_cell):
    """A node off the tied face has a shape function that vanishes on it: no entry of the
    ties touches it (their round-off there, 1e-17 to 1e-15 of the largest, is dropped)."""
    V, S = _spaces(volume_cell, surface_cell)
    ops = coupling.tie_operators(V, S)
    on_face = np.flatnonzero(np.isclose(V.tabulate_dof_coordinates()[:, 0], 1.0))
    for P in (ops.P1, ops.P2):
        np.testing.assert_array_equal(np.unique(P.tocoo().row), on_face)
    np.testing.assert_array_equal(np.unique(ops.P1.tocoo().col), on_face)


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


# -- quadrilaterals of any shape -------------------------------------------------------------
def _general_quads(n1=4, n2=6, amp=0.3, seed=0, x0=1.0):
    """An n1 x n2 quadrilateral mesh of the unit square on the plane x = x0 whose interior
    nodes are moved randomly in the plane by up to ``amp`` cell sizes: general convex quads,
    none a parallelogram."""
    origin, ey, ez = np.array([x0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([0, 0, 1.0])
    points, cells = meshes.rectangle_grid(origin, ey, ez, n1, n2, "quadrilateral")
    i, j = np.meshgrid(np.arange(n1 + 1), np.arange(n2 + 1), indexing="ij")
    inner = ((i > 0) & (i < n1) & (j > 0) & (j < n2)).ravel()
    move = np.random.default_rng(seed).uniform(-amp, amp, (inner.sum(), 2))
    points[inner, 1] += move[:, 0] / n1
    points[inner, 2] += move[:, 1] / n2
    return meshes.surface_mesh(MPI.COMM_SELF, points, cells, "quadrilateral")


def _distort_inside(mesh, amp=0.3, h=0.2, seed=5):
    """Move a box mesh's nodes off its faces y, z = 0, 1 and x = 0 randomly in y and z: its
    facets on x = 1 become general quadrilaterals."""
    x = mesh.geometry.x
    inner = np.all((x[:, 1:] > 1e-9) & (x[:, 1:] < 1 - 1e-9), axis=1) & (x[:, 0] > 1e-9)
    x[inner, 1:] += np.random.default_rng(seed).uniform(-amp, amp, (inner.sum(), 2)) * h
    return mesh


def _exact_mass(space):
    """The mass matrix of a (planar-celled) mesh, integrated in its reference cells."""
    u, v = ufl.TrialFunction(space), ufl.TestFunction(space)
    form = fem.form(u * v * ufl.dx(metadata={"quadrature_degree": 8}))
    return fem.assemble_matrix(form).to_dense()


@pytest.mark.parametrize(
    "volume_cell,surface",
    [
        ("hexahedron", "general quadrilateral"),
        ("tetrahedron", "general quadrilateral"),
        ("hexahedron", "triangle"),
        ("tetrahedron", "triangle"),
        ("general hexahedron", "general quadrilateral"),
    ],
)
def test_tie_operators_reproduce_linear_fields(volume_cell, surface):
    # u and v interpolating one linear field: P1 u = P2 v and P4 v = P2^T u, so the tie
    # transmits no force for it (a rigid translation is the constant case).
    vol = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 5, 5], volume_cell.split()[-1])
    if volume_cell.startswith("general"):
        _distort_inside(vol)
    if surface == "triangle":
        surf = meshes.surface_from_boundary(
            vol, lambda x: np.isclose(x[0], 1.0), resolution=(7, 3), cell_type="triangle"
        )
    else:
        surf = _general_quads()
    V, S = fem.functionspace(vol, ("Lagrange", 1)), fem.functionspace(surf, ("Lagrange", 1))
    ops = coupling.tie_operators(V, S)
    xv, xs = V.tabulate_dof_coordinates(), S.tabulate_dof_coordinates()
    for a in ([0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, -1.2, 0.7]):
        u, v = xv @ a + 0.4, xs @ a + 0.4
        r1 = np.abs(ops.P1 @ u - ops.P2 @ v).max()
        r4 = np.abs(ops.P4 @ v - ops.P2.T @ u).max()
        norm = max(abs(ops.P1).sum(axis=1).max(), abs(ops.P4).sum(axis=1).max())
        assert r1 / (norm * np.abs(u).max()) < 1e-12
        assert r4 / (norm * np.abs(v).max()) < 1e-12


def test_tie_operators_exact_on_general_quadrilaterals():
    # The cause of the penalty-dependent patch test on general quadrilaterals: their bilinear
    # basis is rational in physical coordinates, and a low-degree rule on the intersections
    # integrated it differently for each subdomain (1e-7 relative). Now P4, whichever volume
    # mesh cuts the cells, is the surface mesh's exact mass matrix.
    S = fem.functionspace(_general_quads(amp=0.45, seed=3, x0=0.0), ("Lagrange", 1))
    exact = _exact_mass(S)
    scale = np.abs(exact).max()
    boxes = [
        ([3, 5, 5], "hexahedron"),
        ([4, 7, 3], "hexahedron"),
        ([2, 3, 4], "tetrahedron"),
    ]
    for n, cell in boxes:
        vol = meshes.box(MPI.COMM_SELF, [-1, 0, 0], [0, 1, 1], n, cell)
        ops = coupling.tie_operators(fem.functionspace(vol, ("Lagrange", 1)), S)
        assert np.abs(ops.P4.toarray() - exact).max() < 1e-14 * scale
    # The volume side too: facets that are general quadrilaterals integrate their basis
    # exactly (int H_D over the tied face, against dolfinx's facet integral).
    vol = _distort_inside(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 5, 5]))
    V = fem.functionspace(vol, ("Lagrange", 1))
    ops = coupling.tie_operators(V, fem.functionspace(_general_quads(), ("Lagrange", 1)))
    face = dolfinx.mesh.locate_entities_boundary(vol, 2, lambda x: np.isclose(x[0], 1.0))
    tags = dolfinx.mesh.meshtags(vol, 2, face, np.ones_like(face))
    ds = ufl.Measure("ds", vol, subdomain_data=tags, metadata={"quadrature_degree": 8})
    load = fem.assemble_vector(fem.form(ufl.TestFunction(V) * ds(1))).array
    ones = np.ones(V.dofmap.index_map.size_local)
    assert np.abs(ops.P1 @ ones - load).max() < 1e-14 * np.abs(load).max()


def _general_patch_test(kappa, traction=1.0e6, distort_volume=False):
    """verify.patch_test with a general-quadrilateral interface (and optionally general
    quadrilateral facets on the left box's tied face)."""
    steel = Material(E=210e9, nu=0.3)
    left_mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 5, 5])
    if distort_volume:
        _distort_inside(left_mesh)
    left = Subdomain(left_mesh, steel, "left")
    right = Subdomain(meshes.box(MPI.COMM_SELF, [1, 0, 0], [2, 1, 1], [4, 7, 3]), steel, "right")
    for axis in range(3):
        for sub in (left, right):
            if not (sub is right and axis == 0):
                sub.fix(lambda x, axis=axis: np.isclose(x[axis], 0.0), components=[axis])
    right.add_traction(lambda x: np.isclose(x[0], 2.0), (traction, 0.0, 0.0))
    interface = Interface(_general_quads(), [left, right], kappa=kappa)
    StaticProblem(Scene(MPI.COMM_SELF, [left, right], interface)).solve()
    exact = np.zeros((3, 3))
    exact[0, 0] = traction
    return max(float(np.abs(cell_stress(s) - exact).max()) / traction for s in (left, right))


@pytest.mark.parametrize("distort_volume", [False, True])
@pytest.mark.parametrize("kappa", [1e2, 1e6])
def test_patch_test_general_quadrilaterals(kappa, distort_volume):
    # No O(1/kappa) error (it was 7.6e-8 at kappa = 1e2 with a degree-6 rule). What remains
    # is round-off growing like kappa: u - v = eps * sigma is carried by displacements about
    # 1e6 times larger at kappa = 1e6, so about 1e-16 * 1e6 of the stress is lost there, as
    # for rectangular cells (about 1e-9 in the patch-hex-quad case).
    error = _general_patch_test(kappa, distort_volume=distort_volume)
    assert error < (1e-10 if kappa <= 1e4 else 1e-8)
