"""Bad input fails early with a message that names the problem and the fix."""

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest
import ufl

import dd_contact as dc
from dd_contact import meshes
from dd_contact.prescribed import Prescribed

STEEL = dc.Material(E=210e9, nu=0.3)


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _two_boxes():
    left = dc.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]), STEEL, "left")
    right = dc.Subdomain(meshes.box(MPI.COMM_SELF, [1, 0, 0], [2, 1, 1], [3, 2, 2]), STEEL, "right")
    left.fix(_on(0, 0.0))
    return left, right


def test_interface_far_from_boundary():
    left, right = _two_boxes()
    points = np.array([[1.5, 0, 0], [1.5, 1, 0], [1.5, 0, 1], [1.5, 1, 1]])  # inside "right"
    surface = meshes.surface_mesh(MPI.COMM_SELF, points, [[0, 1, 2, 3]], "quadrilateral")
    scene = dc.Scene(MPI.COMM_WORLD, [left, right], dc.Interface(surface, [left, right]))
    with pytest.raises(dc.InputError, match=r"does not touch subdomain 'left'.*move the surface"):
        dc.StaticProblem(scene)


def test_interface_partly_off_the_boundary():
    left, right = _two_boxes()
    points = np.array([[1, 0, 0], [1, 2, 0], [1, 0, 1], [1, 2, 1]])  # half of it hangs out
    surface = meshes.surface_mesh(MPI.COMM_SELF, points, [[0, 1, 2, 3]], "quadrilateral")
    scene = dc.Scene(MPI.COMM_WORLD, [left, right], dc.Interface(surface, [left, right]))
    with pytest.raises(dc.InputError, match=r"1 of its 1 cells do not lie on a subdomain.*50\.0%"):
        dc.StaticProblem(scene)


def test_two_dimensional_subdomain_mesh():
    square = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 2, 2)
    with pytest.raises(dc.InputError, match=r"needs a 3-D volume mesh.*dimension 2 in 2-D"):
        dc.Subdomain(square, STEEL, "flat")


def test_volume_mesh_as_interface():
    left, right = _two_boxes()
    with pytest.raises(dc.InputError, match=r"needs a surface mesh .*topological dimension 3"):
        dc.Interface(left.mesh, [left, right])


@pytest.mark.parametrize(
    "kappa,epsilon", [(0.0, None), (-1e6, None), (None, -1e-8), (np.nan, None)]
)
def test_non_positive_penalty(kappa, epsilon):
    left, right = _two_boxes()
    surface = meshes.surface_from_boundary(left.mesh, _on(0, 1.0), (2, 2))
    with pytest.raises(dc.InputError, match=r"must be a positive finite number"):
        dc.Interface(surface, [left, right], kappa=kappa, epsilon=epsilon)


def test_both_penalties():
    with pytest.raises(dc.InputError, match="kappa or epsilon, not both"):
        dc.Penalty(kappa=1e6, epsilon=1e-8)


def test_floating_subdomain_without_tie():
    lone = dc.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]), STEEL, "lone")
    lone.add_traction(_on(0, 1.0), (1.0, 0, 0))
    with pytest.raises(dc.InputError, match=r"'lone' can move as a rigid body \(6 free.*fix"):
        dc.StaticProblem(dc.Scene(MPI.COMM_WORLD, [lone]))


def test_underconstrained_tied_pair():
    left, right = _two_boxes()
    left.prescribed = Prescribed(left.V, "subdomain 'left'")  # drop _two_boxes' clamp
    left.fix(_on(0, 0.0), components=[0])  # only x fixed: the pair slides and spins
    iface = dc.Interface.from_boundary(left, _on(0, 1.0), [left, right], resolution=(2, 2))
    with pytest.raises(dc.InputError, match=r"'left', 'right' can move as a rigid body \(3 free"):
        dc.StaticProblem(dc.Scene(MPI.COMM_WORLD, [left, right], iface))


def test_subdomains_nothing_ties_are_separate_bodies_each_held_or_refused():
    """One rule for untied subdomains, with or without an interface beside them."""
    left, right = _two_boxes()  # left clamped, right held by nothing
    scene = dc.Scene(MPI.COMM_WORLD, [left, right])
    assert [[s.name for s in b.subdomains] for b in scene.bodies()] == [["left"], ["right"]]
    with pytest.raises(dc.InputError, match=r"'right' can move as a rigid body \(6 free"):
        dc.StaticProblem(scene)
    right.fix(_on(0, 2.0))
    with dc.StaticProblem(scene) as problem:  # both held: solved, each on its own
        problem.solve()
        assert np.allclose(problem.reactions["right"], 0.0)


def test_nan_traction_and_coordinates():
    left, _ = _two_boxes()
    with pytest.raises(dc.InputError, match="traction contains NaN"):
        left.add_traction(_on(0, 1.0), (np.nan, 0, 0))
    with pytest.raises(dc.InputError, match="prescribed displacement contains NaN"):
        left.fix(_on(0, 1.0), value=(0, np.inf, 0))
    bad = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [1, 1, 1])
    bad.geometry.x[0, 0] = np.nan
    with pytest.raises(dc.InputError, match="mesh coordinates contains NaN"):
        dc.Subdomain(bad, STEEL, "bad")


def test_empty_region_and_unknown_algorithm():
    left, _ = _two_boxes()
    with pytest.raises(dc.InputError, match="selects no facet"):
        left.fix(_on(0, 5.0))
    with pytest.raises(dc.InputError, match=r"unknown algorithm 'v-w-x'.*valid for it: FULL "):
        dc.StaticProblem(dc.Scene(MPI.COMM_WORLD, [left]), algorithm="v-w-x")


def test_bad_material():
    with pytest.raises(dc.InputError, match="Poisson's ratio"):
        dc.Material(E=1.0, nu=0.5)
    with pytest.raises(dc.InputError, match="Young's modulus"):
        dc.Material(E=-1.0, nu=0.3)


def test_remeshing_a_region_that_is_not_a_rectangle():
    box = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [4, 4, 4])
    # An L-shaped part of the face x = 1: remeshing its bounding square would add area.
    l_shape = lambda x: np.isclose(x[0], 1.0) & ((x[1] <= 0.5 + 1e-12) | (x[2] <= 0.5 + 1e-12))  # noqa: E731
    with pytest.raises(ValueError, match=r"area 0.75\b.*not the rectangle.*area 1\b"):
        meshes.surface_from_boundary(box, l_shape, resolution=(3, 3))
    square = meshes.surface_from_boundary(box, _on(0, 1.0), resolution=(3, 2))
    assert square.topology.index_map(2).size_local == 6


# ------------------------------------------ malformed arguments name the argument (arguments.py)


def _box():
    return dc.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]), STEEL, "b")


@pytest.mark.parametrize(
    "call,message",
    [
        (lambda b: b.add_traction(_on(0, 1.0), (1.0, 2.0)), r"'b' traction must be 3 real numbers"),
        (
            lambda b: b.add_traction(_on(0, 1.0), ufl.as_vector([1.0, 2.0])),
            r"'b' traction must be a UFL vector with 3 components, got shape \(2,\)",
        ),
        (lambda b: b.add_traction(_on(0, 1.0), lambda t: [t, 0.0]), r"returned \[.*\] at t = 0"),
        (lambda b: b.set_body_force("down"), r"'b' body force must be 3 real numbers"),
        (lambda b: b.fix(_on(0, 0.0), components=[3]), r"fix\(components=...\) must list .* 2"),
        (lambda b: b.fix(_on(0, 0.0), components=[0, 0]), r"lists a component twice"),
        (lambda b: b.fix(_on(0, 0.0), value=(0.0, 1.0)), r"prescribed displacement must be 3 real"),
        (lambda b: b.fix(_on(0, 0.0), value=lambda x: x[0]), r"must return a \(3, n\) array"),
        (lambda b: b.fix("left"), r"'b': where must be a locator x -> bool, facet indices"),
        (lambda b: b.fix(np.array([0, 10_000])), r"facet indices must lie in 0 \.\. 35, got 0"),
        (lambda b: b.fix(np.array([0.5])), r"where must be a locator"),
        (lambda b: b.fix(np.arange(36)), r"12 of its 36 facets are not on the mesh's boundary"),
    ],
)
def test_malformed_subdomain_arguments(call, message):
    with pytest.raises(dc.InputError, match=message):
        call(_box())


def test_malformed_meshtags():
    box, other = _box(), _box()
    cells = dolfinx.mesh.meshtags(box.mesh, 3, np.arange(8, dtype=np.int32), np.ones(8, np.int32))
    with pytest.raises(dc.InputError, match=r"tag entities of dimension 3, .* needs facets"):
        box.fix((cells, 1))
    facets = dolfinx.mesh.locate_entities_boundary(other.mesh, 2, _on(0, 0.0))
    foreign = dolfinx.mesh.meshtags(other.mesh, 2, facets, np.ones_like(facets))
    with pytest.raises(dc.InputError, match=r"MeshTags belong to another mesh"):
        box.fix(foreign)
    with pytest.raises(dc.InputError, match=r"needs a dolfinx MeshTags first, got ndarray"):
        box.fix((facets, 1))


@pytest.mark.parametrize(
    "make,message",
    [
        (lambda: dc.Material(E="210e9", nu=0.3), r"Material E must be a real number, got '210e9'"),
        (lambda: dc.Material(E=210e9, nu=None), r"Material nu must be a real number"),
        (lambda: dc.Material(E=210e9, nu=0.3, rho=[7800]), r"Material rho must be a real"),
        (lambda: dc.Penalty(kappa="1e6"), r"kappa must be a positive finite number, got '1e6'"),
        (lambda: dc.Subdomain(_box().mesh, STEEL, "x", degree=3), r"degree must be 1 or 2"),
        (lambda: dc.Subdomain(_box().mesh, STEEL, ""), r"Subdomain name must be a non-empty"),
        (lambda: dc.Subdomain(_box().mesh, {"E": 1}, "x"), r"'x': material: expected Material"),
        (lambda: dc.Subdomain(_box().mesh._cpp_object, STEEL, "x"), r"needs a dolfinx.mesh.Mesh"),
    ],
)
def test_malformed_material_and_subdomain(make, message):
    with pytest.raises(dc.InputError, match=message):
        make()


def test_malformed_interface_contact_and_scene_arguments():
    left, right = _two_boxes()
    cut = _on(0, 1.0)
    with pytest.raises(dc.InputError, match=r"resolution must be a positive integer, got 0"):
        dc.Interface.from_boundary(left, cut, [left, right], resolution=(0, 2))
    with pytest.raises(dc.InputError, match=r"resolution must be \(n1, n2\) cell counts"):
        dc.Interface.from_boundary(left, cut, [left, right], resolution=4)
    with pytest.raises(dc.InputError, match=r"cell_type must be 'quadrilateral' or 'triangle'"):
        dc.Interface.from_boundary(left, cut, [left, right], resolution=(2, 2), cell_type="hex")
    with pytest.raises(dc.InputError, match=r"give the list of subdomains it ties"):
        dc.Interface.from_boundary(left, cut, right)
    with pytest.raises(dc.InputError, match=r"tolerance must be a real number"):
        dc.Interface.from_boundary(left, cut, [left, right], tolerance="small")
    with pytest.raises(dc.InputError, match=r"subdomain: expected Subdomain, got Mesh"):
        dc.ContactInterface.from_boundary(left.mesh, cut, dc.Plane([2, 0, 0], [-1, 0, 0]))
    iface = dc.Interface.from_boundary(left, cut, [left, right], resolution=(2, 2))
    zone = dc.ContactBoundary(right, _on(0, 2.0), dc.Plane([2.1, 0, 0], [-1, 0, 0]))
    with pytest.raises(dc.InputError, match=r"Scene: comm: expected Comm, got NoneType"):
        dc.Scene(None, [left, right], iface)
    with pytest.raises(dc.InputError, match=r"contacts must be a list, e.g. contacts=\[zone\]"):
        dc.Scene(MPI.COMM_WORLD, [left, right], iface, contacts=zone)
    with pytest.raises(dc.InputError, match=r"Scene: subdomains: expected Subdomain, got Mesh"):
        dc.Scene(MPI.COMM_WORLD, [left, right.mesh], iface)
    with pytest.raises(dc.InputError, match=r"Scene: interface: expected Interface, got list"):
        dc.Scene(MPI.COMM_WORLD, [left, right], [iface])
