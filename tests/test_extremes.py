"""The penalty sweep (verify.extremes): records, coverage of the algorithms, the scenes."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from dd_contact.paper import verify
from dd_contact.solvers.schedule import fitting_algorithms

# Algorithms that fit each scene kind of verify.pressed_scene (exact, by hand).
ALGORITHMS = {
    "interface": {"FULL", "v-w-u", "w-v-u"},
    "boundary": {"FULL", "v-u"},
    "single": {"FULL", "w-u"},
}

# One case per scene kind, over both swept penalties, both volume cells, both surface cells
# and a distorted surface; from the softest verified penalty to the stiffest, split ties
# (kappa > KAPPA_SPLIT, carried by the augmented-Lagrangian iteration) included.
CASES = [
    "tie-interface-hex-quad",
    "tie-boundary-tet-tri-distorted",
    "contact-tie-single-tet-quad-distorted",
    "contact-tie-interface-hex-tri-distorted",
]
KAPPAS = (1e0, 1e4, 1e10, 1e14)


@pytest.fixture(scope="module")
def records():
    return verify.extremes(kappas=KAPPAS, cases=CASES)


@pytest.mark.mpi
def test_moderate_penalties_pass(records):
    assert len(records) > 0
    for r in records:
        assert r.tolerance == verify.PENALTY_FLOOR
        assert r.rel_error <= r.tolerance, r
        assert r.rel_error == max(r.stress_error, r.force_error)
        assert r.passed and r.note == "", r
    # Every rank measured the same errors.
    worst = max(r.rel_error for r in records)
    assert MPI.COMM_WORLD.allreduce(worst, op=MPI.MAX) == worst


def test_records_cover_every_fitting_algorithm(records):
    expected = sum(len(ALGORITHMS[verify.EXTREME_CASES[c].kind]) for c in CASES) * len(KAPPAS)
    assert len(records) == expected == 40
    keys = {(r.case, r.algorithm, r.kappa) for r in records}
    assert len(keys) == len(records)  # one record per (case, algorithm, kappa)
    for case in CASES:
        kind = verify.EXTREME_CASES[case].kind
        fit = fitting_algorithms(kind != "single", kind != "boundary")
        assert set(fit) == ALGORITHMS[kind]
        for kappa in KAPPAS:
            assert {r.algorithm for r in records if r.case == case and r.kappa == kappa} == set(fit)


def test_case_registry():
    # 2 swept penalties x 2 scene kinds x 4 cell pairs x (plain, distorted).
    assert len(verify.EXTREME_CASES) == 32
    assert "tie-interface-hex-quad-distorted" in verify.EXTREME_CASES
    assert verify.CASES["extremes"] is verify.extremes
    assert verify.EXTREME_KAPPAS == tuple(10.0**k for k in range(15))
    assert verify.penalty_tolerance(0.0) == 1e-8
    assert verify.penalty_tolerance(1e-6) == pytest.approx(1e-5)
    with pytest.raises(ValueError, match="unknown extremes case"):
        verify.extremes(cases=["nope"])


@pytest.mark.parametrize("cells", ["hex-quad", "tet-tri"])
def test_distorted_surfaces_stay_in_their_plane(cells):
    plain = verify.pressed_scene("interface", cells=cells, comm=MPI.COMM_SELF)
    bent = verify.pressed_scene("interface", cells=cells, distorted=True, comm=MPI.COMM_SELF)
    surfaces = [
        (plain.interface.mesh, bent.interface.mesh, 1.0),
        (plain.contacts[0].mesh, bent.contacts[0].mesh, 0.0),
    ]
    for before, after, plane in surfaces:
        x0, x1 = before.geometry.x, after.geometry.x
        assert np.abs(x1[:, 0] - plane).max() < 1e-15  # in-plane
        moved = np.linalg.norm(x1 - x0, axis=1)
        on_edge = np.isclose(x0[:, 1] % 1.0, 0.0) | np.isclose(x0[:, 2] % 1.0, 0.0)
        assert moved[on_edge].max() == 0.0  # the outline stays
        # 4 x 5 cells: 3 x 4 interior nodes, each moved by at most 0.2 * sqrt(2) edges.
        assert np.count_nonzero(moved) == 12
        assert moved.max() <= verify.DISTORTION * np.sqrt(2) * 0.2 + 1e-15
