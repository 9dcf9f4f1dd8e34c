"""What the ranks exchange in a time step of w-v-u, counted by the problem (its traffic)."""

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact.paper import examples
from dd_contact.parallel import ROOT
from dd_contact.solvers import engine

STEPS = 8


def _run(comm, monkeypatch):
    """The small bar pressed on the wall: per step its record, this rank's traffic, and the
    number of solves in which some rank sent a changed matrix to rank 0."""
    sent = []
    gather = engine.gather_to_root

    def spy(comm, payload, nbytes=0):
        parts = gather(comm, payload, nbytes)
        if parts is not None and isinstance(payload, tuple):  # a solve's, not the set-up's
            sent.append(any(changed["Z"] or changed["contact"] for _, changed in parts))
        return parts

    monkeypatch.setattr(engine, "gather_to_root", spy)
    scene = examples.parallelepiped("w-v-u", (12, 4, 2), comm=comm)
    problem = dd.TransientProblem(scene, 1e-6, algorithm="w-v-u", track_energy=False)
    steps = []
    for _ in range(STEPS):
        problem.traffic.reset()
        sent.clear()
        record = problem.advance()
        steps.append((record, problem.traffic.snapshot(), sum(sent)))
    u = {s.name: s.u.x.array.copy() for s in scene.subdomains}
    return problem, steps, u


@pytest.mark.mpi
def test_a_step_sends_surface_vectors_and_each_subdomain_once(monkeypatch):
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("counts for two ranks")
    problem, steps, _ = _run(comm, monkeypatch)
    m = sum(problem.solver.schedule.surface.values())  # surface dofs
    own_u = sum(problem.solver.system.sizes[b] for b in problem.solver.subdomains)
    quiet = [counts for r, counts, _ in steps[1:] if r["iterations"] == 1 and r["changes"] == 0]
    assert len(quiet) >= 3
    for counts in quiet:
        # One solve: each rank's part of the surface right-hand side to rank 0, the surface
        # solution broadcast after the solve and after v's back-substitution (w-v-u solves w
        # last); each subdomain's u sent once, by its owner, to publish it; the results
        # agreed (gathered) and the loads' and prescribed values' checks (collective). The
        # contact iteration: the active sets' digest at its start (allgathered), whether a
        # release is unsettled (any_rank), the changed regions counted after the solve (a
        # step without a change has no pressed-back check) and the residual check's probe
        # sums (sum_over_ranks).
        root = comm.rank == ROOT
        assert counts == {
            "gather_to_root": 1,
            "bcast_array": 2,
            "allgather_blocks": 1,
            "gathered": 1,
            "collective": 2,
            "allgathered": 1,
            "any_rank": 1,
            "sum_over_ranks": 2,
            "bytes": 8 * (m + 2 * m * root + own_u),
        }
    for record, counts, with_matrices in steps[1:]:
        # every contact iteration meets once before the surface solve; a changed contact
        # matrix travels only in the solves after a change
        assert counts["gather_to_root"] == record["iterations"]
        if comm.rank == ROOT:
            assert with_matrices == record["changes"]


@pytest.mark.mpi
def test_two_ranks_give_the_serial_results(monkeypatch):
    _, parallel, u_parallel = _run(MPI.COMM_WORLD, monkeypatch)
    _, serial, u_serial = _run(MPI.COMM_SELF, monkeypatch)
    for (p, _, _), (s, _, _) in zip(parallel, serial, strict=True):
        assert (p["iterations"], p["changes"], p["active"]) == (
            s["iterations"],
            s["changes"],
            s["active"],
        )
        for name, force in s["force"].items():
            scale = np.linalg.norm(force) or 1.0
            assert np.linalg.norm(np.subtract(p["force"][name], force)) <= 1e-9 * scale
    for name, u in u_serial.items():
        assert np.linalg.norm(u_parallel[name] - u) <= 1e-9 * np.linalg.norm(u)


@pytest.mark.mpi
def test_each_problem_counts_only_its_own_traffic():
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("counts for two ranks")
    problems = [
        dd.TransientProblem(
            examples.parallelepiped("w-v-u", (12, 4, 2), comm=comm),
            1e-6,
            algorithm="w-v-u",
            track_energy=False,
        )
        for _ in range(2)
    ]
    first, second = problems
    first.advance()
    second.traffic.reset()
    before = first.traffic.snapshot()
    second.advance()
    assert first.traffic.snapshot() == before  # the second's step is not the first's
    record = second.history[-1]
    assert second.traffic.snapshot()["gather_to_root"] == record["iterations"]
    for problem in problems:
        problem.close()
