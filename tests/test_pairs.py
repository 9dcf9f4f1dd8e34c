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


def _blocks(cells_a, cells_b, split: bool, gap: float = 0.0):
    """Block A (steel, on rollers, its base held in z) under block B (aluminium) at H_A + gap.

    ``split``: A is two subdomains tied through an interface at H_A / 2.
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
    a = dc.ContactInterface.from_boundary(upper, _at(2, H_A), None, name="top_of_A")
    b = dc.ContactInterface.from_boundary(B, _at(2, top), None, name="bottom_of_B")
    subdomains = [lower, upper, B] if split else [lower, B]
    interface = None
    if split:
        interface = dc.Interface.from_boundary(lower, _at(2, H_A / 2), [lower, upper])
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
        for side in pair.sides:
            assert np.abs(side.pressure.x.array / PRESSURE - 1.0).max() < 1e-8
        force = problem.contact_forces()[pair.name]
        assert np.abs(force - [0.0, 0.0, -PRESSURE * SIDE**2]).max() < 1e-8 * PRESSURE
        assert problem.changes["gamma"] == 0  # touching from the start, pressed throughout
