"""Meshes that differ between ranks are refused with a clear error, not an MPI abort."""

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import meshes


def _scene(comm, cells_along_x):
    left = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [cells_along_x, 2, 2]),
        dd.Material(1.0, 0.3),
        "left",
    )
    left.fix(lambda x: np.isclose(x[0], 0.0))
    return dd.Scene(comm, [left])


@pytest.mark.mpi
def test_a_mesh_that_differs_on_one_rank_is_refused_on_every_rank():
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        pytest.skip("two ranks")
    _scene(comm, 2)  # the same on both: accepted
    with pytest.raises(dd.InputError, match=r"the mesh of subdomain 'left' on rank .* differs"):
        _scene(comm, 2 + comm.rank)
