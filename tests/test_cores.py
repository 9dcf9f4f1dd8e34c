"""Ranks that share a node share its cores: each rank's BLAS threads limited to its share."""

import os

from mpi4py import MPI

import pytest
from threadpoolctl import threadpool_info

from dd_contact import parallel


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_one_rank_keeps_its_blas_threads(monkeypatch):
    monkeypatch.setattr(parallel, "_cores_shared", False)
    before = _blas_threads()
    assert parallel.share_cores(MPI.COMM_SELF) is None
    assert _blas_threads() == before


@pytest.mark.mpi
def test_two_ranks_on_a_node_split_its_cores(monkeypatch):
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("two ranks")
    monkeypatch.setattr(parallel, "_cores_shared", False)
    for name in parallel.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    threads = parallel.share_cores(comm)
    share = max(1, len(os.sched_getaffinity(0)) // 2)  # both ranks run on this machine
    assert threads == share
    assert _blas_threads() and all(n <= share for n in _blas_threads())
    monkeypatch.setattr(parallel, "_cores_shared", False)
    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # the user's setting is left as it is
    assert parallel.share_cores(comm) is None


def test_small_dense_work_runs_on_one_blas_thread_and_the_threads_come_back():
    from threadpoolctl import threadpool_limits

    from dd_contact.solvers.linalg import DENSE_THREADED_ROWS, dense_threads

    with threadpool_limits(limits=2, user_api="blas"):  # as numpy's OpenBLAS on 2 cores
        before = _blas_threads()
        with dense_threads(DENSE_THREADED_ROWS - 1):
            assert set(_blas_threads()) == {1}
        assert _blas_threads() == before
        with dense_threads(DENSE_THREADED_ROWS):  # large work keeps the process's threads
            assert _blas_threads() == before


def test_the_surface_solves_with_one_blas_thread(monkeypatch):
    """The engine's dense surface work of a small scene sees one BLAS thread."""
    from threadpoolctl import threadpool_limits

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped
    from dd_contact.solvers import surface

    seen = []
    factorise = surface.Surface.factorise

    def spy(self):
        seen.append(max(_blas_threads()))
        return factorise(self)

    monkeypatch.setattr(surface.Surface, "factorise", spy)
    with threadpool_limits(limits=2, user_api="blas"):
        problem = dd.TransientProblem(parallelepiped("v-w-u", (8, 3, 2)), 1e-6, "v-w-u")
        problem.run(2, progress=False, summary=False)
        assert max(_blas_threads()) == 2
    assert seen and set(seen) == {1}
