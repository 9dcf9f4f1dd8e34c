"""Contact pairs: two deformable bodies pressed on each other (dd_contact.ContactPair).

The contact patch test on non-matching surfaces against its closed form, every algorithm
against FULL on a pair whose contact state changes, a change re-factorising only the pair's
group, and the scenes refused with an InputError.
"""

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dc
from dd_contact import meshes

H_A, H_B, SIDE = 1.0, 0.8, 1.0
STEEL, ALUMINIUM = dc.Material(200e9, 0.3), dc.Material(70e9, 0.25)
PRESSURE = 1.0e6


def _at(axis: int, value: float):
    return lambda x: np.isclose(x[axis], value)


def _rollers(sub: dc.Subdomain) -> dc.Subdomain:
    """Hold a block's sides x = 0 and y = 0 in their normal directions (it may expand)."""
    return sub.fix(_at(0, 0.0), [0]).fix(_at(1, 0.0), [1])


def _blocks(cells_a, cells_b, split: bool, gap: float = 0.0, kappa: float | None = None):
    """Block A (steel, on rollers, its base held in z) under block B (aluminium) at H_A + gap.

    ``split``: A is two subdomains tied through an interface at H_A / 2. ``kappa``: the tie
    penalty of the interface and of the contact interfaces (default: the default).
    """
    (kind_a, n_a), (kind_b, n_b) = cells_a, cells_b
    if split:
        half = (n_a[0], n_a[1], max(n_a[2] // 2, 1))
        parts = [
            meshes.box(MPI.COMM_SELF, [0, 0, 0], [SIDE, SIDE, H_A / 2], half, kind_a),
            meshes.box(MPI.COMM_SELF, [0, 0, H_A / 2], [SIDE, SIDE, H_A], half, kind_a),
        ]
        lower, upper = (dc.Subdomain(m, STEEL, f"A{i}") for i, m in enumerate(parts))
    else:
        mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], [SIDE, SIDE, H_A], n_a, kind_a)
        lower = upper = dc.Subdomain(mesh, STEEL, "A")
    top = H_A + gap
    mesh_b = meshes.box(MPI.COMM_SELF, [0, 0, top], [SIDE, SIDE, top + H_B], n_b, kind_b)
    B = dc.Subdomain(mesh_b, ALUMINIUM, "B")
    _rollers(lower).fix(_at(2, 0.0), [2])
    if split:
        _rollers(upper)
    _rollers(B)
    a = dc.ContactInterface.from_boundary(upper, _at(2, H_A), None, name="top_of_A", kappa=kappa)
    b = dc.ContactInterface.from_boundary(B, _at(2, top), None, name="bottom_of_B", kappa=kappa)
    subdomains = [lower, upper, B] if split else [lower, B]
    interface = None
    if split:
        interface = dc.Interface.from_boundary(lower, _at(2, H_A / 2), [lower, upper], kappa=kappa)
    return subdomains, interface, a, b, B


def _patch_scene(cells_a, cells_b, split, **pair_options):
    subdomains, interface, a, b, B = _blocks(cells_a, cells_b, split)
    B.add_traction(_at(2, H_A + H_B), [0.0, 0.0, -PRESSURE])
    pair = dc.ContactPair(a, b, **pair_options)
    return dc.Scene(MPI.COMM_WORLD, subdomains, interface, [pair]), pair, B


def _pressed_block(problem, B: dc.Subdomain) -> np.ndarray:
    """The closed form of B's displacement: uniaxial stress, every penalty in series."""
    compliance = sum(problem.penalties.values())  # ties, interface and contact in series
    x = B.V.tabulate_dof_coordinates()
    u = np.zeros_like(x)
    E, nu = ALUMINIUM.E, ALUMINIUM.nu
    u[:, 2] = -PRESSURE * (H_A / STEEL.E + compliance + (x[:, 2] - H_A) / E)
    u[:, :2] = nu * PRESSURE * x[:, :2] / E
    return u.ravel()


PATCHES = [
    ((("hexahedron", (3, 3, 2)), ("hexahedron", (4, 4, 2))), {}),
    ((("tetrahedron", (3, 3, 2)), ("hexahedron", (4, 5, 2))), {}),
    ((("hexahedron", (4, 4, 2)), ("tetrahedron", (3, 3, 2))), {"points": "quadrature"}),
    ((("tetrahedron", (3, 3, 2)), ("tetrahedron", (5, 4, 2))), {"unbiased": True}),
]


@pytest.mark.mpi
@pytest.mark.parametrize(
    ("split", "algorithm"), [(False, "FULL"), (False, "w-u"), (True, "v-w-u"), (True, "w-v-u")]
)
@pytest.mark.parametrize(
    ("cells", "options"),
    PATCHES,
    ids=["hex-hex", "tet-hex", "hex-tet-quadrature", "tet-tet-unbiased"],
)
def test_the_contact_patch_test_holds_on_non_matching_surfaces(cells, options, split, algorithm):
    scene, pair, B = _patch_scene(*cells, split, **options)
    with dc.StaticProblem(scene, algorithm=algorithm) as problem:
        problem.solve()
        expected = _pressed_block(problem, B)
        error = np.abs(B.u.x.array - expected).max() / np.abs(expected).max()
        assert error < 1e-8
        if MPI.COMM_WORLD.rank == scene.contact_owner(pair):  # its fields land there
            for side in pair.sides:
                assert np.abs(side.pressure.x.array / PRESSURE - 1.0).max() < 1e-8
        force = problem.contact_forces()[pair.name]
        assert np.abs(force - [0.0, 0.0, -PRESSURE * SIDE**2]).max() < 1e-8 * PRESSURE
        assert problem.changes["gamma"] == 0  # touching from the start, pressed throughout


# -- every algorithm on a pair whose contact state changes ----------------------------------
GAP, TILT = 1.0e-4, 3.0e-4


def _tilted_scene(split: bool, tie_kappa: float | None = None, **pair_options):
    """B a gap above A, its top pressed down by TILT * x: the contact closes on one side."""
    cells = ("hexahedron", (4, 4, 2)), ("tetrahedron", (3, 3, 2))
    subdomains, interface, a, b, B = _blocks(*cells, split, gap=GAP, kappa=tie_kappa)
    B.fix(_at(2, H_A + GAP + H_B), [2], lambda x: np.stack([0 * x[0], 0 * x[0], -TILT * x[0]]))
    pair = dc.ContactPair(a, b, **pair_options)
    return dc.Scene(MPI.COMM_WORLD, subdomains, interface, [pair]), pair


def _solution(scene, algorithm):
    with dc.StaticProblem(scene, algorithm=algorithm) as problem:
        problem.solve()
        fields = [s.u.x.array.copy() for s in scene.subdomains]
        fields += [c.w.x.array.copy() for c in scene.contacts]
        records = [(r.block, r.kind) for r in problem.work.records]
        return fields, dict(problem.changes), records


@pytest.mark.parametrize(("split", "orders"), [(False, ["w-u"]), (True, ["v-w-u", "w-v-u"])])
def test_every_algorithm_agrees_with_full_on_a_pair_that_changes_state(split, orders):
    scene, pair = _tilted_scene(split)
    full, changes, _ = _solution(scene, "FULL")
    assert changes["gamma"] >= 2 and changes[pair.name] == changes["gamma"]
    size = max(np.abs(f).max() for f in full)
    for order in orders:
        fields, order_changes, records = _solution(_tilted_scene(split)[0], order)
        assert order_changes == changes
        assert max(np.abs(f - g).max() for f, g in zip(fields, full, strict=True)) < 1e-9 * size
        # a change re-factorises the pair's group (and what it is eliminated into) or
        # corrects for it (dd_contact/solvers/lowrank.py), never a subdomain: each
        # subdomain once, the pair's group once more per change unless corrected
        sparse = [b for b, kind in records if kind == "sparse_factor"]
        assert sorted(sparse) == sorted(s.block for s in scene.subdomains)
        group = "+".join(sorted(["w:bottom_of_B", "w:top_of_A"]))
        dense = [b for b, kind in records if kind == "dense_factor"]
        updates = [b for b, kind in records if kind == "dense_update"]
        assert dense.count(group) + len(updates) == 1 + changes["gamma"]
        if order == "w-v-u":  # the pair's group is the last level: nothing else again
            assert dense.count("v:interface") == 1


# -- scenes refused ----------------------------------------------------------------------
CELLS = ("hexahedron", (2, 2, 2)), ("hexahedron", (3, 3, 2))


def test_self_contact_is_refused_and_said_to_be_out_of_scope():
    subdomains, _, a, _, _ = _blocks(*CELLS, split=False)
    bottom = dc.ContactInterface.from_boundary(subdomains[0], _at(2, 0.0), None, name="base")
    for other in (a, bottom):
        with pytest.raises(dc.InputError, match=r"self-contact .* is not supported"):
            dc.ContactPair(a, other)


def test_a_pair_side_must_be_a_contact_interface_without_an_obstacle():
    subdomains, _, a, _, _ = _blocks(*CELLS, split=False)
    wall = dc.ContactInterface.from_boundary(
        subdomains[1], _at(2, H_A + H_B), dc.Plane([0, 0, 2], [0, 0, -1]), name="lid"
    )
    with pytest.raises(dc.InputError, match="without an obstacle, got ContactInterface"):
        dc.ContactPair(a, wall)
    with pytest.raises(dc.InputError, match="'top_of_A' has no obstacle and is in no ContactPair"):
        dc.Scene(MPI.COMM_WORLD, subdomains, None, [a])


def test_surfaces_that_do_not_face_each_other_are_refused():
    subdomains, _, a, _, B = _blocks(*CELLS, split=False)
    lid = dc.ContactInterface.from_boundary(B, _at(2, H_A + H_B), None, name="lid")
    scene = dc.Scene(MPI.COMM_WORLD, subdomains, None, [dc.ContactPair(a, lid)])
    with pytest.raises(dc.InputError, match="'top_of_A' and 'lid' do not face each other"):
        dc.StaticProblem(scene)


def test_surfaces_that_overlap_at_the_start_are_refused():
    subdomains, _, a, b, _ = _blocks(*CELLS, split=False, gap=-0.01)
    scene = dc.Scene(MPI.COMM_WORLD, subdomains, None, [dc.ContactPair(a, b)])
    with pytest.raises(dc.InputError, match=r"overlap by 0\.01 .* at most touch at the start"):
        dc.StaticProblem(scene)


# -- two bars striking end to end ----------------------------------------------------------
def _bar(x0: float, name: str, velocity: float) -> dc.Subdomain:
    bar = dc.Subdomain(
        meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x0 + 1.0, 0.1, 0.1], [20, 1, 1]),
        dc.Material(1.0, 0.0, 1.0),
        name,
    )
    bar.fix(_at(1, 0.0), [1]).fix(_at(2, 0.0), [2])  # lateral faces on rollers
    bar.velocity.interpolate(
        lambda x: np.vstack([np.full(x.shape[1], velocity), 0 * x[0], 0 * x[0]])
    )
    return bar


@pytest.mark.parametrize("algorithm", ["FULL", "w-u"])
def test_two_bars_striking_never_create_energy_and_exchange_velocities(algorithm):
    gap, speed, length = 0.001, 0.01, 1.0  # c = 1: contact lasts 2 L / c = 2
    left, right = _bar(0.0, "left", speed), _bar(length + gap, "right", -speed)
    a = dc.ContactInterface.from_boundary(left, _at(0, length), None, name="left_end")
    b = dc.ContactInterface.from_boundary(right, _at(0, length + gap), None, name="right_end")
    pair = dc.ContactPair(a, b)
    scene = dc.Scene(MPI.COMM_WORLD, [left, right], None, [pair])
    dt = 1.0 / 20 / 4
    with dc.TransientProblem(scene, dt, algorithm=algorithm) as problem:
        start = problem.energy()["total"]
        energies, touching = [], []
        for _ in range(int((gap / (2 * speed) + 2.3) / dt)):
            record = problem.advance()
            energies.append(problem.energy()["total"] / start)
            touching.append(record["active"][pair.name] > 0)
        assert max(energies) < 1 + 1e-9  # never created
        assert energies[-1] > 0.999
        duration = dt * np.count_nonzero(touching)
        assert abs(duration - 2.0 * length) < 0.01
        assert problem.changes["gamma"] <= 4
    for bar, sign in ((left, -1.0), (right, 1.0)):  # the velocities exchanged
        assert abs(bar.velocity.x.array.reshape(-1, 3)[:, 0].mean() / (sign * speed) - 1) < 0.02


@pytest.mark.mpi
def test_an_energy_safe_pair_across_ranks_is_refused_and_says_what_to_do():
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("two ranks: the bars' subdomains land on different ranks")
    left, right = _bar(0.0, "left", 0.01), _bar(1.001, "right", -0.01)
    a = dc.ContactInterface.from_boundary(left, _at(0, 1.0), None, name="left_end")
    b = dc.ContactInterface.from_boundary(right, _at(0, 1.001), None, name="right_end")
    scene = dc.Scene(MPI.COMM_WORLD, [left, right], None, [dc.ContactPair(a, b)])
    with pytest.raises(NotImplementedError, match=r"ranks \[0, 1\].*energy_safe_contact=False"):
        dc.TransientProblem(scene, 0.0125)


# -- Hertz between two spheres (coarse; the fine case is `dd-contact verify --case pair-spheres`)
def test_two_spheres_of_unequal_radii_and_materials_follow_hertz_on_a_coarse_mesh():
    from dd_contact.paper import verify

    r = verify.two_spheres(h_contact=0.04, ratio=0.67, comm=MPI.COMM_SELF)
    assert r["a_over_h"] > 4.0  # a coarse mesh: 4.4 cells across the contact radius
    assert abs(r["a"] / r["a_ref"] - 1) < 0.09  # -7.8 % here; -2.4 % at a / h = 8.8
    for peak in r["p_side_max"]:  # +1.4 %, +2.0 % here
        assert abs(peak / r["p0_ref"] - 1) < 0.03
    assert 0 < r["changes"] <= 10
