"""Every rank reads every subdomain's velocity and acceleration as its owner has them."""

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact.paper import examples
from dd_contact.paper.verify.bar import _impact_bar
from dd_contact.paper.verify.models import locator

STEPS = 6


def _owners_fields(problem) -> list[tuple[str, str, np.ndarray]]:
    """(subdomain, field, the owner's values) of every subdomain, on every rank."""
    comm, scene = problem.comm, problem.scene
    mine = [
        (s.name, name, getattr(s, name).x.array.copy())
        for k, s in enumerate(scene.subdomains)
        if scene.owner(k) == comm.rank
        for name in ("u", "velocity", "acceleration")
    ]
    return [item for part in comm.allgather(mine) for item in part]


def _assert_every_rank_reads_the_owners(problem):
    fields = {s.name: s for s in problem.scene.subdomains}
    for name, field, owners in _owners_fields(problem):
        np.testing.assert_array_equal(getattr(fields[name], field).x.array, owners)


@pytest.mark.mpi
@pytest.mark.parametrize("scheme", ["trapezoidal", "generalized-alpha"])
def test_every_rank_reads_the_owners_velocity_and_acceleration(scheme, tmp_path):
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("two ranks, each owning one subdomain")
    out = comm.bcast(str(tmp_path) if comm.rank == 0 else None)
    options = {"algorithm": "w-v-u", "track_energy": False, "scheme": scheme}

    def problem():
        scene = examples.parallelepiped("w-v-u", (12, 4, 2), comm=comm)
        return dd.TransientProblem(scene, 1e-6, **options)

    whole = problem()
    whole.start()
    _assert_every_rank_reads_the_owners(whole)  # the initial acceleration included
    accelerating = 0
    for _ in range(STEPS):
        whole.advance()
        _assert_every_rank_reads_the_owners(whole)
        accelerating += any(np.any(s.acceleration.x.array) for s in whole.scene.subdomains)
    assert accelerating == STEPS
    first = problem()
    first.run(3, output=out, checkpoint_every=3, summary=False)
    resumed = problem()
    resumed.run(STEPS, output=out, resume=True, summary=False)
    _assert_every_rank_reads_the_owners(resumed)
    for mine, theirs in zip(resumed.scene.subdomains, whole.scene.subdomains, strict=True):
        np.testing.assert_array_equal(mine.velocity.x.array, theirs.velocity.x.array)
    for p in (whole, first, resumed):
        p.close()


@pytest.mark.mpi
def test_every_rank_reads_the_massless_face_as_its_owner():
    """A bar on rank 0 only; its massless end face's rates on rank 1 too."""
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("two ranks, one owning the bar")
    parts, _ = _impact_bar(20, False, dd.Material(1.0, 0.0, 1.0))
    wall = dd.Plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    end = dd.ContactBoundary(parts[0], locator(0, 0.0), wall, name="end")
    problem = dd.TransientProblem(dd.Scene(comm, parts, contacts=[end]), 0.5 / 20)
    bar = parts[0]
    face = 3 * np.flatnonzero(np.isclose(bar.V.tabulate_dof_coordinates()[:, 0], 0.0))
    for _ in range(100):  # past the release at 2 L / c = 80 steps
        problem.advance()
        _assert_every_rank_reads_the_owners(problem)
    assert problem.changes["end"] == 1
    assert np.allclose(bar.velocity.x.array[face], 0.01, rtol=0.05)  # with the bar, at +v0
    problem.close()
