"""decompose: one dolfinx mesh in, a scene out; its results back on the one mesh."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from scipy.spatial import cKDTree

import dd_contact as dd
from dd_contact import forms, meshes, partition
from dd_contact.decomposition import UnreachableObstacleWarning
from dd_contact.paper.models import pin_joint, pin_joint_one_mesh
from dd_contact.parallel import max_over_ranks

STEEL = dd.Material(E=210e9, nu=0.3, rho=7850.0)
LENGTH, LOAD = 10.0, (0.0, 0.0, -1e5)


def _at(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _one_mesh_solve(mesh):
    """The clamped bar under a tip shear, solved by plain dolfinx on the one mesh."""
    V = fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    u, du = ufl.TrialFunction(V), ufl.TestFunction(V)
    mesh.topology.create_connectivity(2, 3)
    clamp = fem.locate_dofs_topological(
        V, 2, dolfinx.mesh.locate_entities_boundary(mesh, 2, _at(0, 0.0))
    )
    tip = dolfinx.mesh.locate_entities_boundary(mesh, 2, _at(0, LENGTH))
    tags = dolfinx.mesh.meshtags(mesh, 2, tip, np.ones_like(tip))
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    load = fem.Constant(mesh, np.array(LOAD))
    return dolfinx.fem.petsc.LinearProblem(
        ufl.inner(forms.stress(u, STEEL), forms.strain(du)) * ufl.dx,
        ufl.inner(load, du) * ds(1),
        bcs=[fem.dirichletbc(np.zeros(3), clamp, V)],
        petsc_options_prefix="one_mesh_",
        petsc_options={
            "ksp_type": "preonly",
            "pc_type": "lu",
            "pc_factor_mat_solver_type": "mumps",
        },
    ).solve()


def _von_mises(mesh, u):
    T = fem.functionspace(mesh, ("DG", 0))
    s = forms.stress(u, STEEL)
    dev = s - ufl.tr(s) * ufl.Identity(3) / 3
    out = fem.Function(T)
    out.interpolate(
        fem.Expression(ufl.sqrt(1.5 * ufl.inner(dev, dev)), T.element.interpolation_points)
    )
    return out


# Measured (serial; 2 ranks in docs/decompose.md; max norm relative to max |u|): at kappa 1e6,
# 1.6e-7 (hex, 2 parts), 4.5e-7 (hex, 4), 8.6e-8 (tet, 2), 5.4e-7 (tet, 4); at kappa 1e8,
# 8.4e-10, 2.6e-9, 9.5e-10, 5.2e-9; at 1e12 (issue 26's 1e-8), 6.3e-12, 1.6e-10, 3.5e-10,
# 1.3e-10 (2 ranks: at most 4.1e-10). Von Mises (cellwise, relative to its max): the same order.
@pytest.mark.mpi
@pytest.mark.parametrize("cell_type", ["hexahedron", "tetrahedron"])
@pytest.mark.parametrize("parts", [2, 4])
@pytest.mark.parametrize(("kappa", "tolerance"), [(None, 1e-6), (1e8, 1e-7), (1e12, 1e-8)])
def test_a_decomposed_bar_equals_the_one_mesh_solve(cell_type, parts, kappa, tolerance):
    comm = MPI.COMM_WORLD
    mesh = meshes.box(comm, [0, 0, 0], [LENGTH, 1, 1], [20, 4, 4], cell_type)
    scene = dd.decompose(mesh, STEEL, parts=parts, kappa=kappa)
    assert len(scene.subdomains) == parts
    assert scene.decomposition.interface_facets == (parts - 1) * 16 * (
        1 if cell_type[0] == "h" else 2
    )
    scene.fix(_at(0, 0.0)).add_traction(_at(0, LENGTH), LOAD)
    with dd.StaticProblem(scene) as problem:
        problem.solve()
    fields = dd.fields_on_mesh(scene)
    reference = _one_mesh_solve(mesh)
    scale = max_over_ranks(comm, float(np.abs(reference.x.array).max()))
    error = max_over_ranks(comm, float(np.abs(fields.u.x.array - reference.x.array).max()))
    assert error / scale < tolerance
    mises = _von_mises(mesh, reference)
    n = mesh.topology.index_map(3).size_local
    top = max_over_ranks(comm, float(mises.x.array[:n].max()))
    spread = float(np.abs(fields.von_mises.x.array[:n] - mises.x.array[:n]).max())
    assert max_over_ranks(comm, spread) / top < 20 * tolerance


def test_parts_by_cell_tags_and_by_planes_have_the_cells_asked_for():
    cube = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [4, 4, 4])
    mid = cube.geometry.x[cube.geometry.dofmaps[0]].mean(axis=1)
    cells = np.arange(len(mid), dtype=np.int32)
    tags = dolfinx.mesh.meshtags(cube, 3, cells, np.where(mid[:, 0] < 0.25, 7, 9).astype(np.int32))
    scene = dd.decompose(cube, STEEL, parts=tags, comm=MPI.COMM_SELF)
    assert [s.name for s in scene.subdomains] == ["part7", "part9"]
    assert [len(scene.decomposition.cells[n]) for n in ("part7", "part9")] == [16, 48]
    assert scene.decomposition.interface_facets == 16
    planes = [((0.5, 0, 0), (1, 0, 0)), ((0, 0.5, 0), (0, 1, 0))]
    scene = dd.decompose(cube, STEEL, parts=planes, comm=MPI.COMM_SELF)
    assert [len(c) for c in scene.decomposition.cells.values()] == [16, 16, 16, 16]
    assert scene.decomposition.interface_facets == 32
    assert scene.interface is not None and len(scene.interface.subdomains) == 4


def test_bisection_cuts_between_layers():
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [LENGTH, 1, 1], [20, 4, 4])
    scene = dd.decompose(bar, STEEL, parts=3, comm=MPI.COMM_SELF)
    # 320 cells in layers of 16: 107 asked -> 7 layers; 208 left in two -> 7 and 6 layers
    assert [len(c) for c in scene.decomposition.cells.values()] == [112, 112, 96]
    assert scene.decomposition.interface_facets == 32
    assert scene.decomposition.method == "bisection"  # SCOTCH cuts no fewer facets here


def _block_with_candidates(times, margin=1e-3):
    """A 0.1 m bar: its ends and its top may touch three walls; only some come near."""
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [0.1, 0.02, 0.02], [20, 4, 4])
    near = dd.Plane([-1e-5, 0, 0], [1, 0, 0])  # 10 um from the end x = 0
    far = dd.Plane([0.15, 0, 0], [-1, 0, 0])  # 50 mm beyond the end x = 0.1
    lid = dd.Plane([0, 0, 0.03], [0, 0, -1], motion=lambda t: (0.0, 0.0, -t))  # 10 mm above
    candidates = [
        dd.ContactCandidate(_at(0, 0.0), near, name="end"),
        dd.ContactCandidate(_at(0, 0.1), far, name="other"),
        dd.ContactCandidate(_at(2, 0.02), lid, name="top"),
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = dd.decompose(
            bar, STEEL, parts=1, contacts=candidates, margin=margin, times=times, comm=MPI.COMM_SELF
        )
    return scene, [str(w.message) for w in caught if w.category is UnreachableObstacleWarning]


def test_contact_interfaces_only_where_an_obstacle_comes_within_reach():
    scene, warned = _block_with_candidates(times=[0.0])
    d = scene.decomposition
    assert d.contacts == [("end", "part0", 16)]  # 4 x 4 end facets
    assert [(o.name, o.facets, o.of) for o in d.left_out] == [("other", 16, 16), ("top", 80, 80)]
    assert d.left_out[0].nearest == pytest.approx(0.05)
    assert d.left_out[1].nearest == pytest.approx(0.01)
    assert len(warned) == 2 and "['other']" in warned[0] and "['top']" in warned[1]
    # The lid comes down 9.5 mm by t = 0.0095: within the 1 mm margin of the whole top
    scene, warned = _block_with_candidates(times=np.linspace(0.0, 0.0095, 20))
    assert scene.decomposition.contacts == [("end", "part0", 16), ("top", "part0", 80)]
    assert len(warned) == 1 and len(scene.contacts) == 2


def test_a_candidate_partly_in_reach_keeps_only_the_facets_in_reach():
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [0.1, 0.02, 0.02], [20, 4, 4])
    tilted = dd.Plane([0.05, 0, -1e-4], [0, 0, 1])  # under the bottom; a sphere would do
    ball = dd.Sphere([0.05, 0.01, -0.01], 0.0095)  # 0.5 mm below the bottom's middle
    candidate = dd.ContactCandidate(_at(2, 0.0), ball, name="bottom")
    scene = dd.decompose(bar, STEEL, parts=1, contacts=[candidate], margin=1e-3, comm=MPI.COMM_SELF)
    (name, _, facets), (left,) = scene.decomposition.contacts[0], scene.decomposition.left_out
    assert name == "bottom" and facets + left.facets == 80 and 0 < facets < 80
    x = scene.contacts[0].mesh.geometry.x
    assert ball.gap_normal(x)[0].min() == pytest.approx(5e-4)
    del tilted


def _bar_towards_a_wall():
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [0.1, 0.02, 0.02], [20, 4, 4])
    wall = dd.Plane([-1e-5, 0, 0], [1, 0, 0])
    candidate = dd.ContactCandidate(_at(0, 0.0), wall, name="end")
    return dd.decompose(bar, STEEL, contacts=[candidate], margin=1e-3, comm=MPI.COMM_SELF)


@pytest.mark.filterwarnings("ignore::dd_contact.CoarseTimeStepWarning")
def test_the_auto_cut_puts_contact_in_a_small_part_factorised_once():
    scene = _bar_towards_a_wall()
    d = scene.decomposition
    assert d.method == "auto" and d.description == "contact part x < 0.01: 32 of 320 cells"
    assert [len(c) for c in d.cells.values()] == [32, 288]  # the paper's 1:9
    for sub in scene.subdomains:
        sub.velocity.interpolate(lambda x: np.vstack([-np.ones(x.shape[1]), 0 * x[0], 0 * x[0]]))
    with dd.TransientProblem(scene, dt=2e-6, algorithm="auto", expected_steps=40) as problem:
        problem.run(40)
        changes = problem.changes["end"]
        work = problem.work_summary()
        assert problem.algorithm == "w-v-u"
    assert changes >= 3  # it touches, and leaves the wall again (0.1 m of steel: 40 us)
    assert work["u:part0"]["decompositions"] == 1 and work["u:part1"]["decompositions"] == 1
    assert work["w:end"]["decompositions"] == 1 + changes


def test_without_a_candidate_in_reach_auto_is_one_part_and_no_interface():
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2])
    scene = dd.decompose(bar, STEEL, comm=MPI.COMM_SELF)
    assert len(scene.subdomains) == 1 and scene.interface is None
    assert scene.decomposition.description == "one part (no candidate surface in reach)"


def test_velocity_and_displacement_on_the_one_mesh_agree_with_one_part():
    def run(parts):
        bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [LENGTH, 1, 1], [10, 2, 2])
        scene = dd.decompose(bar, STEEL, parts=parts, kappa=1e8, comm=MPI.COMM_SELF)
        scene.fix(_at(0, 0.0)).add_traction(_at(0, LENGTH), LOAD)
        with dd.TransientProblem(scene, dt=1e-4) as problem:
            problem.run(5)
        return dd.fields_on_mesh(scene)

    one, three = run(1), run(3)
    for field in ("u", "velocity"):
        a, b = getattr(one, field).x.array, getattr(three, field).x.array
        assert np.abs(a - b).max() < 1e-6 * np.abs(a).max(), field
    assert np.abs(one.velocity.x.array).max() > 0


def _inner(mesh):
    """Two facets inside the mesh."""
    count = mesh.topology.index_map(2).size_local
    return np.setdiff1d(np.arange(count), dolfinx.mesh.exterior_facet_indices(mesh.topology))[:2]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda m, t: dd.decompose(m, STEEL, parts=5000), "ask for at most 64 parts"),
        (
            lambda m, t: dd.decompose(m, STEEL, parts=[((5, 0, 0), (1, 0, 0))]),
            "leaves every cell on one side",
        ),
        (lambda m, t: dd.decompose(m, STEEL, parts=t), "must tag cells"),
        (lambda m, t: dd.decompose(m, STEEL, parts="metis"), "parts must be 'auto'"),
        (
            lambda m, t: dd.decompose(m, STEEL, parts=2, partitioner="metis"),
            "partitioner must be one of",
        ),
        (
            lambda m, t: dd.decompose(m, STEEL, parts=65, partitioner="scotch"),
            "ask for at most 64 parts",
        ),
        (
            lambda m, t: dd.decompose(
                m, STEEL, contacts=[dd.ContactCandidate((t, 99), dd.Plane([0, 0, 0], [1, 0, 0]))]
            ),
            "selects no facet of the boundary",
        ),
        (
            lambda m, t: dd.decompose(
                m, STEEL, contacts=[dd.ContactCandidate(_inner(m), dd.Plane([0, 0, 0], [1, 0, 0]))]
            ),
            "are not on the mesh's boundary",
        ),
        (lambda m, t: dd.decompose(m, STEEL, parts=2).fix((t, 42)), "selects no facet"),
        (
            lambda m, t: dd.decompose(m, STEEL, parts=2).add_traction(
                _at(0, 1), ufl.as_vector([1, 0, 0])
            ),
            "a UFL expression belongs to one mesh",
        ),
        (
            lambda m, t: dd.decompose(m, STEEL).set_body_force(ufl.as_vector([0, 0, -1])),
            "a UFL expression belongs to one mesh",
        ),
        (
            lambda m, t: dd.fields_on_mesh(dd.Scene(MPI.COMM_SELF, [dd.Subdomain(m, STEEL, "a")])),
            "no one mesh",
        ),
    ],
)
def test_bad_input_is_named(call, message):
    cube = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [4, 4, 4])
    cube.topology.create_connectivity(2, 3)
    facets = dolfinx.mesh.exterior_facet_indices(cube.topology)
    tags = dolfinx.mesh.meshtags(cube, 2, facets, np.ones_like(facets))
    with pytest.raises(dd.InputError, match=message):
        call(cube, tags)


def test_untagged_cells_and_a_dirichletbc_are_refused():
    cube = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2])
    half = dolfinx.mesh.meshtags(cube, 3, np.arange(4, dtype=np.int32), np.ones(4, np.int32))
    with pytest.raises(dd.InputError, match="4 of 8 cells carry no cell tag"):
        dd.decompose(cube, STEEL, parts=half)
    scene = dd.decompose(cube, STEEL, parts=2)
    V = scene.subdomains[0].V
    bc = fem.dirichletbc(np.zeros(3), np.array([0], dtype=np.int32), V)
    with pytest.raises(dd.InputError, match="give the region"):
        scene.fix(bc)


def _gmsh_bar(comm):
    """A 10 x 1 x 1 bar of two gmsh volumes (tags 1, 2), ends tagged 11 (x = 0), 12 (x = 10)."""
    gmsh = pytest.importorskip("gmsh")
    import dolfinx.io.gmsh

    if comm.rank == 0:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.35)
        gmsh.model.add("bar")
        a = gmsh.model.occ.addBox(0, 0, 0, 3, 1, 1)
        b = gmsh.model.occ.addBox(3, 0, 0, 7, 1, 1)
        gmsh.model.occ.fragment([(3, a)], [(3, b)])
        gmsh.model.occ.synchronize()
        for tag, (_, volume) in zip((1, 2), gmsh.model.getEntities(3), strict=True):
            x = gmsh.model.occ.getCenterOfMass(3, volume)[0]
            gmsh.model.addPhysicalGroup(3, [volume], 1 if x < 3 else 2)
        for _, surface in gmsh.model.getEntities(2):
            x = gmsh.model.occ.getCenterOfMass(2, surface)[0]
            if np.isclose(x, 0.0) or np.isclose(x, LENGTH):
                gmsh.model.addPhysicalGroup(2, [surface], 11 if x < 1 else 12)
        gmsh.model.mesh.generate(3)
        data = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3)
        gmsh.finalize()
    else:
        data = dolfinx.io.gmsh.model_to_mesh(None, comm, 0, gdim=3)
    return data.mesh, data.cell_tags, data.facet_tags


@pytest.mark.mpi
def test_a_gmsh_mesh_with_physical_groups_decomposed_by_its_tags():
    comm = MPI.COMM_WORLD
    mesh, cells, facets = _gmsh_bar(comm)
    scene = dd.decompose(mesh, STEEL, parts=cells, kappa=1e8)
    assert [s.name for s in scene.subdomains] == ["part1", "part2"]
    total = sum(len(c) for c in scene.decomposition.cells.values())
    assert total == max_over_ranks(comm, mesh.topology.index_map(3).size_global)
    scene.fix((facets, 11)).add_traction((facets, 12), LOAD)
    with dd.StaticProblem(scene) as problem:
        problem.solve()
    fields = dd.fields_on_mesh(scene)
    reference = _one_mesh_solve(mesh)
    scale = max_over_ranks(comm, float(np.abs(reference.x.array).max()))
    error = max_over_ranks(comm, float(np.abs(fields.u.x.array - reference.x.array).max()))
    assert error / scale < 1e-7


def _plate_with_holes(comm):
    """A 1 x 0.2 x 0.05 plate with three holes of radius 0.06, gmsh tetrahedra of 0.02."""
    gmsh = pytest.importorskip("gmsh")
    import dolfinx.io.gmsh

    if comm.rank != 0:
        return dolfinx.io.gmsh.model_to_mesh(None, comm, 0, gdim=3).mesh
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.02)
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 0.2, 0.05)
    holes = [(3, gmsh.model.occ.addCylinder(x, 0.1, 0, 0, 0, 0.05, 0.06)) for x in (0.2, 0.5, 0.8)]
    (body,), _ = gmsh.model.occ.cut([(3, box)], holes)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [body[1]], 1)
    gmsh.model.mesh.generate(3)
    mesh = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3).mesh
    gmsh.finalize()
    return mesh


@pytest.mark.mpi
def test_a_number_of_parts_of_a_mesh_with_holes_is_cut_by_scotch():
    """Bisection by coordinates cuts through the holes' ligaments (parts in pieces, 346
    facets on the cuts); SCOTCH on the cells' dual graph cuts 234, its parts in one piece."""
    mesh = _plate_with_holes(MPI.COMM_WORLD)
    cut = {p: dd.decompose(mesh, STEEL, parts=8, partitioner=p) for p in ("auto", "bisection")}
    chosen, coordinates = cut["auto"].decomposition, cut["bisection"].decomposition
    assert chosen.method == "scotch" and coordinates.method == "bisection"
    assert chosen.interface_facets < 0.8 * coordinates.interface_facets
    pieces = {
        p: [int(partition.bodies(s.mesh).max()) + 1 for s in c.subdomains] for p, c in cut.items()
    }
    assert pieces["auto"] == [1] * 8 and max(pieces["bisection"]) > 1
    counts = np.array([len(c) for c in chosen.cells.values()])
    assert counts.sum() == max_over_ranks(MPI.COMM_WORLD, mesh.topology.index_map(3).size_global)
    assert np.ptp(counts) < 0.05 * counts.mean()  # SCOTCH's imbalance: 2.5 % by default


@pytest.mark.parametrize(("parts", "facets"), [(4, 32), (8, 48)])
def test_parts_meeting_at_an_edge_or_a_corner_tie_exactly(parts, facets):
    # A cube bisected into 4 columns (meeting along a line) or 8 octants (at a point): the
    # interface is one surface with edges shared by 4 of its cells.
    cube = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [4, 4, 4])
    scene = dd.decompose(cube, STEEL, parts=parts, kappa=1e8, comm=MPI.COMM_SELF)
    assert scene.decomposition.interface_facets == facets
    assert [len(c) for c in scene.decomposition.cells.values()] == [64 // parts] * parts
    scene.fix(_at(2, 0.0)).add_traction(_at(2, 1.0), (1e6, 0.0, -1e6))
    with dd.StaticProblem(scene) as problem:
        problem.solve()
    u = dd.fields_on_mesh(scene).u.x.array
    one = dd.decompose(cube, STEEL, parts=1, comm=MPI.COMM_SELF)
    one.fix(_at(2, 0.0)).add_traction(_at(2, 1.0), (1e6, 0.0, -1e6))
    with dd.StaticProblem(one) as problem:
        problem.solve()
    reference = dd.fields_on_mesh(one).u.x.array
    assert np.abs(u - reference).max() < 1e-7 * np.abs(reference).max()


def test_a_part_that_touches_no_other_part_and_has_no_support_is_refused():
    # One mesh of two separate blocks: bisection cuts between them, no facet is shared.
    a = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2])
    points = np.vstack([a.geometry.x, a.geometry.x + np.array([2.0, 0.0, 0.0])])
    cells = a.geometry.dofmaps[0]
    cells = np.vstack([cells, cells + len(a.geometry.x)]).astype(np.int64)
    two = dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells, a.ufl_domain(), points)
    scene = dd.decompose(two, STEEL, parts=2)
    assert scene.interface is None and scene.decomposition.interface_facets == 0
    scene.fix(_at(0, 0.0))  # only the first block is held
    with pytest.raises(dd.InputError, match="'part1' can move as a rigid body"):
        dd.StaticProblem(scene)


def _stacked_blocks(gap):
    """One mesh of two 1 x 1 x 1 blocks, the upper one ``gap`` above the lower (z)."""
    a = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 3, 2])
    b = meshes.box(MPI.COMM_SELF, [0, 0, 1 + gap], [1, 1, 2 + gap], [3, 3, 2])
    points = np.vstack([a.geometry.x, b.geometry.x])
    cells = np.vstack([a.geometry.dofmaps[0], b.geometry.dofmaps[0] + len(a.geometry.x)])
    return dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells.astype(np.int64), a.ufl_domain(), points)


@pytest.mark.parametrize("algorithm", ["FULL", "w-u"])
def test_a_pair_between_two_bodies_of_one_mesh_carries_the_load(algorithm):
    # The blocks touch at z = 1 (coincident nodes of two bodies); the upper one is pressed
    # down and held in z by contact only: the pair carries the whole load.
    mesh = _stacked_blocks(0.0)
    mesh.topology.create_connectivity(2, 3)
    f2c = mesh.topology.connectivity(2, 3)
    facets = dolfinx.mesh.locate_entities_boundary(mesh, 2, _at(2, 1.0))
    below = np.array(
        [mesh.geometry.x[mesh.geometry.dofmaps[0][f2c.links(f)[0]], 2].mean() < 1 for f in facets]
    )
    pair = dd.ContactCandidate(facets[below], name="joint", partner=facets[~below])
    with pytest.raises(dd.InputError, match="share facets"):
        dd.decompose(mesh, STEEL, contacts=[dd.ContactCandidate(_at(2, 1), partner=_at(2, 1))])
    scene = dd.decompose(mesh, STEEL, contacts=[pair], comm=MPI.COMM_SELF)
    d = scene.decomposition
    assert d.method == "bodies" and [len(c) for c in d.cells.values()] == [18, 18]
    assert d.contacts == [("joint_a", "part0", 9), ("joint_b", "part1", 9)]
    scene.fix(_at(0, 0.0), [0]).fix(_at(1, 0.0), [1]).fix(_at(2, 0.0), [2])
    scene.add_traction(_at(2, 2.0), (0.0, 0.0, -1e6))
    with dd.StaticProblem(scene, algorithm=algorithm) as problem:
        problem.solve()
        force = problem.contact_forces()["joint"]
    assert np.abs(force - [0.0, 0.0, -1e6]).max() < 1e-8 * 1e6
    fields = dd.fields_on_mesh(scene)  # the two bodies' coincident nodes told apart
    top = fields.u.function_space.tabulate_dof_coordinates()[:, 2] > 1.5
    uz = fields.u.x.array.reshape(-1, 3)[:, 2]
    assert uz[top].max() < 0 and np.abs(fields.von_mises.x.array).max() > 0


def test_a_pair_candidate_out_of_reach_and_one_inside_a_body():
    mesh = _stacked_blocks(0.5)  # 0.5 apart: beyond a margin of 0.1
    pair = dd.ContactCandidate(_at(2, 1.0), name="joint", partner=_at(2, 1.5))
    scene = dd.decompose(mesh, STEEL, contacts=[pair], margin=0.1, comm=MPI.COMM_SELF)
    assert scene.contacts == [] and scene.pairs == []
    assert [(o.name, o.facets) for o in scene.decomposition.left_out] == [
        ("joint_a", 9),
        ("joint_b", 9),
    ]
    bottom_and_side = dd.ContactCandidate(_at(2, 0.0), name="self", partner=_at(0, 0.0))
    with pytest.raises(dd.InputError, match="self-contact is not supported"):
        dd.decompose(mesh, STEEL, contacts=[bottom_and_side], margin=2.0, comm=MPI.COMM_SELF)
    with pytest.raises(dd.InputError, match="an obstacle or a partner surface"):
        dd.ContactCandidate(_at(2, 0.0))


def _dof_matched(a, b):
    """The largest difference of two Functions on the same nodes (matched by position)."""
    xa = a.function_space.tabulate_dof_coordinates()
    xb = b.function_space.tabulate_dof_coordinates()
    distance, index = cKDTree(xb).query(xa)
    assert distance.max() < 1e-12  # the same nodes
    return np.abs(a.x.array.reshape(-1, 3) - b.x.array.reshape(-1, 3)[index]).max()


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_the_pin_joints_plates_as_one_mesh_agree_with_the_hand_built_model():
    """The same cells, ties and wall facets: the two agree to round-off step by step; the
    hand-built model's own FULL and w-v-u differ by as much (docs/decompose.md)."""
    one = pin_joint_one_mesh("tiny", comm=MPI.COMM_SELF)
    hand = pin_joint("tiny", walls="facets", comm=MPI.COMM_SELF)
    assert sorted(c.name for c in one.contacts) == sorted(c.name for c in hand.contacts)
    pairs = [(h, one.subdomains[k]) for k, h in enumerate(hand.subdomains)]  # part k: k-th
    assert all(len(h.mesh.geometry.x) == len(o.mesh.geometry.x) for h, o in pairs)
    dt = 2e-3 / 40
    with dd.TransientProblem(hand, dt) as a, dd.TransientProblem(one, dt) as b:
        for step in range(1, 10):
            a.run(step, summary=False, progress=False)
            b.run(step, summary=False, progress=False)
            scale = max(np.abs(h.u.x.array).max() for h, _ in pairs)
            error = max(_dof_matched(h.u, o.u) for h, o in pairs) / scale
            assert error < 1e-8, (step, error)  # 3e-9 to 9e-9
            assert a.history[-1]["active"] == b.history[-1]["active"]
    in_contact = [sum(r["active"].values()) for r in a.history]
    assert in_contact[:6] == [0] * 6 and min(in_contact[6:]) > 0  # the pins bear from step 7
