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
