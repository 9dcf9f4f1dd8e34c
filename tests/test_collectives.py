"""Which parts of the problem API communicate: rank-local ones answer on one rank alone.

Properties and the methods listed here never communicate (docs/output.md, "Collective or
rank-local"); each is called on one rank while the others wait at a barrier. A hidden
collective would block that rank forever: faulthandler then ends the process after 60 s,
so a regression fails the MPI run instead of hanging CI.
"""

from __future__ import annotations

import faulthandler

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact.paper import verify

#: Every rank-local part of the public problem API (StaticProblem has ``iterations``,
#: TransientProblem ``history``, ``step``, ``t`` and ``dt``).
RANK_LOCAL = {
    "changes": lambda p: p.changes,
    "penalties": lambda p: p.penalties,
    "contact_forces": lambda p: p.contact_forces(),
    "reactions": lambda p: p.reactions,
    "results": lambda p: p.results,
    "active_sets": lambda p: p.active_sets,
    "algorithm": lambda p: p.algorithm,
    "choice": lambda p: p.choice,
    "work.count": lambda p: p.work.count("sparse_factor"),
    "work.per_block": lambda p: p.work.per_block(),
}
TRANSIENT = {
    "history": lambda p: p.history,
    "step": lambda p: p.step,
    "t": lambda p: p.t,
    "dt": lambda p: p.dt,
}
STATIC = {"iterations": lambda p: p.iterations}
#: Values every rank agrees on (active_sets and the work log are each rank's own).
AGREED = ["changes", "penalties", "contact_forces", "reactions", "results", "history", "step"]


def _on_one_rank(problem, getters: dict, rank: int) -> dict:
    """Call every getter on ``rank`` only; the other ranks wait at a barrier."""
    comm = MPI.COMM_WORLD
    values = {}
    faulthandler.dump_traceback_later(60, exit=True)
    try:
        if comm.rank == rank:
            values = {name: get(problem) for name, get in getters.items()}
        comm.Barrier()
    finally:
        faulthandler.cancel_dump_traceback_later()
    return values


def _plain(value):
    """Comparable form: arrays as lists, dicts recursively."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


@pytest.mark.mpi
@pytest.mark.parametrize("kind", ["static", "transient"])
def test_rank_local_api_answers_on_one_rank_and_agrees(kind):
    comm = MPI.COMM_WORLD
    if kind == "static":
        problem = dd.StaticProblem(verify.order_scene("interface", False, 1e4), "v-w-u")
        problem.solve()
        getters = RANK_LOCAL | STATIC
    else:
        problem = dd.TransientProblem(verify.order_scene("interface", True, 1e4), 0.01, "v-w-u")
        problem.run(6, progress=False, summary=False)
        getters = RANK_LOCAL | TRANSIENT
    assert problem.changes["gamma"] >= 1  # a contact state changed: the counts matter
    for rank in range(comm.size):
        values = _on_one_rank(problem, getters, rank)
        assert set(values) == (set(getters) if comm.rank == rank else set())
    # Agreed values are the same on every rank.
    mine = {name: _plain(getters[name](problem)) for name in AGREED if name in getters}
    for theirs in comm.allgather(mine):
        assert theirs == mine
    assert problem.changes["end"] == problem.changes["gamma"]  # one contact region


@pytest.mark.mpi
def test_changes_read_on_rank_0_alone_after_a_run():
    # The case that hung: problem.changes inside ``if comm.rank == 0`` under mpiexec.
    problem = dd.TransientProblem(verify.order_scene("interface", True, 1e4), 0.01, "FULL")
    problem.run(6, progress=False, summary=False)
    expected = sum(r["changes"] for r in problem.history)
    seen = _on_one_rank(problem, {"changes": lambda p: p.changes}, 0)
    if MPI.COMM_WORLD.rank == 0:
        assert seen["changes"] == {"gamma": expected, "end": expected}
