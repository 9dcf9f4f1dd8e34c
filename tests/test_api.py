"""dolfinx objects where a dolfinx user has them: DirichletBCs, facet indices, MeshTags.

Each route is compared with the locator route: the same dofs and values, the same facets,
the same surface mesh, the same solution.
"""

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import pytest

import dd_contact as dc
from dd_contact import meshes

STEEL = dc.Material(E=210e9, nu=0.3)
LEFT_END = 0.0
CUT = 1.0


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _box(name="left", lower=(0, 0, 0), upper=(1, 1, 1), cells=(2, 2, 2)):
    return dc.Subdomain(meshes.box(MPI.COMM_SELF, lower, upper, cells), STEEL, name)


def _facets(sub, locator):
    sub.mesh.topology.create_connectivity(2, 3)  # dolfinx's locate_dofs_topological needs it
    return dolfinx.mesh.locate_entities_boundary(sub.mesh, 2, locator)


def _tags(sub, locator, value=7):
    """Facet tags: ``value`` on the located facets, 3 on every other boundary facet."""
    sub.mesh.topology.create_connectivity(2, 3)
    boundary = dolfinx.mesh.exterior_facet_indices(sub.mesh.topology)
    values = np.where(np.isin(boundary, _facets(sub, locator)), value, 3).astype(np.int32)
    return dolfinx.mesh.meshtags(sub.mesh, 2, boundary, values)


def _only(sub, locator):
    """MeshTags holding only the located facets."""
    facets = _facets(sub, locator)
    return dolfinx.mesh.meshtags(sub.mesh, 2, facets, np.ones_like(facets))


def test_fix_regions_select_the_locators_dofs():
    reference = _box().fix(_on(0, LEFT_END), value=(1e-3, 2e-3, 3e-3))
    dofs, values = reference.dirichlet
    assert dofs.size == 9 * 3  # 3 x 3 nodes on the face, 3 components
    for where in ("indices", "meshtags", "pair"):
        sub = _box()
        region = {
            "indices": _facets(sub, _on(0, LEFT_END)),
            "meshtags": _only(sub, _on(0, LEFT_END)),
            "pair": (_tags(sub, _on(0, LEFT_END)), 7),
        }[where]
        sub.fix(region, value=(1e-3, 2e-3, 3e-3))
        np.testing.assert_array_equal(sub.dirichlet[0], dofs, err_msg=where)
        np.testing.assert_array_equal(sub.dirichlet[1], values, err_msg=where)


def test_fix_takes_dirichletbcs_whole_and_per_component():
    sub = _box()
    facets = _facets(sub, _on(0, LEFT_END))
    whole = fem.dirichletbc(
        np.array([1e-3, 2e-3, 3e-3]), fem.locate_dofs_topological(sub.V, 2, facets), sub.V
    )
    sub.fix(whole)
    reference = _box().fix(_on(0, LEFT_END), value=(1e-3, 2e-3, 3e-3))
    np.testing.assert_array_equal(sub.dirichlet[0], reference.dirichlet[0])
    np.testing.assert_array_equal(sub.dirichlet[1], reference.dirichlet[1])

    # one component on a sub-space, with a Constant and with a Function as value
    sub = _box()
    facets = _facets(sub, _on(0, LEFT_END))
    Vx = sub.V.sub(0)
    g = fem.Function(Vx.collapse()[0])
    g.x.array[:] = -4e-3
    dofs_x = fem.locate_dofs_topological(Vx, 2, facets)
    dofs_z = fem.locate_dofs_topological(sub.V.sub(2), 2, facets)
    sub.fix(
        [
            fem.dirichletbc(g, fem.locate_dofs_topological((Vx, g.function_space), 2, facets), Vx),
            fem.dirichletbc(fem.Constant(sub.mesh, 5e-3), dofs_z, sub.V.sub(2)),
        ]
    )
    assert dofs_x.size == 9
    reference = _box().fix(_on(0, LEFT_END), components=[0], value=(-4e-3, 0, 0))
    reference.fix(_on(0, LEFT_END), components=[2], value=(0, 0, 5e-3))
    np.testing.assert_array_equal(sub.dirichlet[0], reference.dirichlet[0])
    np.testing.assert_array_equal(sub.dirichlet[1], reference.dirichlet[1])


def test_fix_refuses_a_dirichletbc_of_another_space():
    sub, other = _box(), _box()
    facets = _facets(other, _on(0, LEFT_END))
    bc = fem.dirichletbc(np.zeros(3), fem.locate_dofs_topological(other.V, 2, facets), other.V)
    with pytest.raises(dc.InputError, match=r"fix DirichletBC 0 is built on another function"):
        sub.fix(bc)


def _surface_nodes(mesh):
    x = mesh.geometry.x
    return x[np.lexsort(x.T)]


@pytest.mark.parametrize("resolution", [None, (3, 2)])
def test_interface_from_boundary_takes_facets_and_meshtags(resolution):
    left, right = _box(), _box("right", (1, 0, 0), (2, 1, 1), (3, 2, 2))
    reference = dc.Interface.from_boundary(left, _on(0, CUT), [left, right], resolution)
    regions = [_facets(left, _on(0, CUT)), _only(left, _on(0, CUT)), (_tags(left, _on(0, CUT)), 7)]
    for region in regions:
        iface = dc.Interface.from_boundary(left, region, [left, right], resolution)
        assert iface.mesh.topology.index_map(2).size_local == (4 if resolution is None else 6)
        np.testing.assert_array_equal(_surface_nodes(iface.mesh), _surface_nodes(reference.mesh))


def test_contact_interface_from_meshtags_with_a_resolution():
    sub = _box()
    plane = dc.Plane([0, 0, -0.1], [0, 0, 1])
    reference = dc.ContactInterface.from_boundary(sub, _on(2, 0.0), plane, resolution=(4, 4))
    cap = dc.ContactInterface.from_boundary(
        sub, (_tags(sub, _on(2, 0.0), 11), 11), plane, resolution=(4, 4)
    )
    assert cap.mesh.topology.index_map(2).size_local == 16
    np.testing.assert_array_equal(_surface_nodes(cap.mesh), _surface_nodes(reference.mesh))


def _solve_tied_pair(dolfinx_route: bool) -> tuple[np.ndarray, np.ndarray]:
    left, right = _box(), _box("right", (1, 0, 0), (2, 1, 1), (3, 2, 2))
    if dolfinx_route:
        facets = _facets(left, _on(0, LEFT_END))
        left.fix(
            fem.dirichletbc(np.zeros(3), fem.locate_dofs_topological(left.V, 2, facets), left.V)
        )
        right.add_traction((_tags(right, _on(0, 2.0), 5), 5), (0.0, 0.0, -1e6))
        iface = dc.Interface.from_boundary(left, _only(left, _on(0, CUT)), [left, right], (2, 2))
    else:
        left.fix(_on(0, LEFT_END))
        right.add_traction(_on(0, 2.0), (0.0, 0.0, -1e6))
        iface = dc.Interface.from_boundary(left, _on(0, CUT), [left, right], (2, 2))
    problem = dc.StaticProblem(dc.Scene(MPI.COMM_WORLD, [left, right], iface))
    problem.solve()
    problem.close()
    return left.u.x.array.copy(), right.u.x.array.copy()


def test_dolfinx_objects_give_the_locator_solution():
    by_locator = _solve_tied_pair(dolfinx_route=False)
    by_dolfinx = _solve_tied_pair(dolfinx_route=True)
    assert np.abs(by_locator[1]).max() > 1e-6  # the tip moves: the comparison means something
    for a, b in zip(by_locator, by_dolfinx):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12 * np.abs(a).max())
