"""MUMPS through dd_contact.solvers.linalg: the PETSc library, the options prefix, the counts."""

from __future__ import annotations

import ctypes

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest

from dd_contact.errors import InputError
from dd_contact.solvers import linalg
from dd_contact.solvers.linalg import (
    OPTIONS_PREFIX,
    SparseCholesky,
    petsc_matrix,
    sparse_statistics,
)
from dd_contact.solvers.worklog import WorkLog

N = 8  # the 7-point Laplacian on an N x N x N grid: N^3 rows


def _laplacian(comm: MPI.Comm) -> PETSc.Mat:
    """The 7-point Laplacian on the grid (diagonal 6: SPD), rows split over the ranks."""
    size = N**3
    lo, hi = size * comm.rank // comm.size, size * (comm.rank + 1) // comm.size
    rows, cols, vals = [], [], []
    ijk = np.stack(np.unravel_index(np.arange(lo, hi), (N, N, N)), axis=1)
    for axis in range(3):
        for step in (-1, 1):
            nb = ijk.copy()
            nb[:, axis] += step
            inside = (nb[:, axis] >= 0) & (nb[:, axis] < N)
            rows.append(np.arange(lo, hi)[inside])
            cols.append(np.ravel_multi_index(tuple(nb[inside].T), (N, N, N)))
            vals.append(np.full(inside.sum(), -1.0))
    rows.append(np.arange(lo, hi)), cols.append(np.arange(lo, hi))
    vals.append(np.full(hi - lo, 6.0))
    return petsc_matrix(
        comm, hi - lo, size, np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    )


@pytest.fixture
def options():
    """The PETSc options database; the options a test sets are removed afterwards."""
    database, names = PETSc.Options(), []

    def set_option(name: str, value) -> None:
        database[name] = value
        names.append(name)

    yield set_option
    for name in names:
        database.delValue(name)


def test_the_petsc_library_is_the_one_petsc4py_runs_on():
    """A second copy of PETSc in the process would not be initialised."""
    initialised = ctypes.c_int(0)
    assert linalg._libpetsc().PetscInitialized(ctypes.byref(initialised)) == 0
    assert initialised.value == 1


@pytest.mark.mpi
def test_an_option_under_the_prefix_reaches_mumps(options):
    options(f"{OPTIONS_PREFIX}mat_mumps_icntl_14", 50)  # working space increase, percent
    A = _laplacian(MPI.COMM_WORLD)
    factor = SparseCholesky(A, WorkLog(), "u")
    mumps = factor.ksp.getPC().getFactorMatrix()
    assert mumps.getOptionsPrefix() == OPTIONS_PREFIX
    assert mumps.getMumpsIcntl(14) == 50
    assert mumps.getMumpsIcntl(24) == 1  # the package's null pivot detection holds
    factor.destroy(), A.destroy()


def test_the_required_null_pivot_detection_cannot_be_switched_off(options):
    options(f"{OPTIONS_PREFIX}mat_mumps_icntl_24", 0)
    A = _laplacian(MPI.COMM_SELF)
    with pytest.raises(InputError, match="-dd_contact_mat_mumps_icntl_24 must be 1"):
        SparseCholesky(A, WorkLog(), "u")
    with pytest.raises(InputError, match="-dd_contact_mat_mumps_icntl_24 must be 1"):
        sparse_statistics(A)
    A.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("ordering", [None, 0])  # MUMPS's choice; ICNTL(7) = 0: AMD
def test_the_analysis_predicts_the_factorisation_without_a_schur_block(options, ordering):
    """Flops and factor entries exactly (test_timing checks a Schur block), also with an
    ordering chosen through the prefix: the analysis reads the same options."""
    if ordering is not None:
        options(f"{OPTIONS_PREFIX}mat_mumps_icntl_7", ordering)
    A = _laplacian(MPI.COMM_WORLD)
    stats = sparse_statistics(A)
    log = WorkLog()
    factor = SparseCholesky(A, log, "u")
    (record,) = log.records
    assert (stats.size, stats.nnz, stats.schur) == (N**3, N**3 + 6 * N**2 * (N - 1), 0)
    assert (record.size, record.nnz) == (N**3, stats.nnz)
    assert (stats.flops, stats.entries) == (record.flops, record.entries)
    assert stats.flops > 0 and stats.entries > 0
    if ordering is not None:
        assert factor.ksp.getPC().getFactorMatrix().getMumpsIcntl(7) == ordering
    factor.destroy(), A.destroy()
