"""MUMPS through dd_contact.solvers.linalg and .mumps_schur: the PETSc library, the options
prefix, the counts, the Schur phases."""

from __future__ import annotations

import ctypes

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
import scipy.sparse as sp

import dd_contact as dd
from dd_contact import analysis
from dd_contact.blocks import Block, ContactRegion
from dd_contact.errors import InputError
from dd_contact.paper import verify
from dd_contact.solvers import linalg
from dd_contact.solvers.linalg import (
    SparseCholesky,
    petsc_matrix,
    sparse_statistics,
)
from dd_contact.solvers.memory import small_pages
from dd_contact.solvers.mumps_schur import SchurFactorisation
from dd_contact.solvers.petsc_options import OPTIONS_PREFIX
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


# -- MUMPS's Schur phases through its C interface (one substitution per right-hand side) ----
def _augmented(singular: bool = False):
    """[[K, C], [C^T, 0]] in COO (both triangles) for the Laplacian K and a random C."""
    A = _laplacian(MPI.COMM_SELF)
    ip, jj, vv = A.getValuesCSR()
    A.destroy()
    n, m = N**3, 20
    K = sp.csr_array((vv, jj, ip), shape=(n, n))
    if singular:  # dof 7 free: its row and column zero (the diagonal stored, as assembled)
        K = sp.lil_array(K)
        K[7, :], K[:, 7] = 0.0, 0.0
        K = sp.csr_array(K)
        K.data[(K.indptr[7] <= np.arange(K.nnz)) & (np.arange(K.nnz) < K.indptr[8])] = 0.0
    C = sp.random_array((n, m), density=0.05, random_state=np.random.default_rng(3))
    A = sp.coo_array(sp.block_array([[K, C], [C.T, sp.diags_array(np.zeros(m))]]))
    return K.toarray(), C.toarray(), A, n, m


def test_reduction_and_expansion_give_the_two_solves_in_one_substitution():
    K, C, A, n, m = _augmented()
    log = WorkLog()
    factor = SchurFactorisation(A.row, A.col, n + m, m, log, "u:x")
    S = factor.factorise(A.data)
    Z = C.T @ np.linalg.solve(K, C)
    np.testing.assert_allclose(S, -Z, rtol=0, atol=1e-12 * abs(Z).max())
    np.testing.assert_array_equal(S, S.T)  # mirrored exactly
    rng = np.random.default_rng(0)
    for _ in range(2):  # a new right-hand side each "step"
        b, xs = rng.standard_normal(n), rng.standard_normal(m)
        g = factor.reduce(b)
        expected = -C.T @ np.linalg.solve(K, b)
        assert np.abs(g - expected).max() < 1e-12 * np.abs(expected).max()
        u = factor.expand(xs)
        expected = np.linalg.solve(K, b - C @ xs)
        assert np.abs(u - expected).max() < 1e-12 * np.abs(expected).max()
    kinds = [r.kind for r in log.records]
    assert kinds == ["sparse_factor", "schur"] + ["sparse_forward", "sparse_backward"] * 2
    sweep = log.records[-1]
    assert sweep.flops == 2.0 * factor.entries and sweep.entries > n  # one pass over the factor
    assert log.per_block()["u:x"]["substitutions"] == 2  # a forward and a backward sweep each
    # MUMPS releases the forward sweep after an expansion: a second one needs a new reduction
    with pytest.raises(RuntimeError, match="needs a reduce"):
        factor.expand(xs)
    # same values again: a numeric re-factorisation only (no analysis in the log)
    factor.factorise(A.data)
    assert log.records[-2].kind == "sparse_factor" and log.records[-2].nnz == 0
    factor.destroy()
    factor.destroy()  # idempotent


def test_a_zero_pivot_behaves_as_in_petscs_schur_factorisation():
    """MUMPS reports no null pivot of K with a Schur block (INFOG(28) = 0), through PETSc as
    through its C interface, and both give the same complement (the package's scene checks,
    e.g. bodies held only by contact, come before any factorisation)."""
    K, _, A, n, m = _augmented(singular=True)
    assert not K[7].any()
    mine = SchurFactorisation(A.row, A.col, n + m, m, WorkLog(), "u:free")
    S = mine.factorise(A.data)
    M = petsc_matrix(MPI.COMM_SELF, n + m, n + m, A.row, A.col, A.data)
    petsc = SparseCholesky(M, WorkLog(), "u:free", m)
    assert petsc.ksp.getPC().getFactorMatrix().getMumpsInfog(28) == 0
    np.testing.assert_array_equal(S, petsc.schur_complement)
    mine.destroy(), petsc.destroy(), M.destroy()


def test_the_upper_triangle_alone_is_factorised_in_place_after_one_analysis():
    """The engine's form: upper-triangle COO, MUMPS reading the caller's values (no copy),
    the analysis done once and logged with the first factorisation, as PETSc's path does."""
    _, _, A, n, m = _augmented()
    M = petsc_matrix(MPI.COMM_SELF, n + m, n + m, A.row, A.col, A.data)
    petsc_log = WorkLog()
    petsc = SparseCholesky(M, petsc_log, "u", m)
    stats = sparse_statistics(M, m)
    upper = A.row <= A.col
    values = A.data[upper].copy()
    log = WorkLog()
    factor = SchurFactorisation(A.row[upper], A.col[upper], n + m, m, log, "u")
    assert factor.analyse(values) == stats  # MUMPS's analysis, as PETSc reports it
    assert factor.analyse(values) is factor.statistics  # once
    S = factor.factorise(values)
    assert factor._a is values  # read in place
    np.testing.assert_array_equal(S, petsc.schur_complement)
    mine, theirs = log.records[0], petsc_log.records[0]
    assert (mine.nnz, mine.flops, mine.entries) == (theirs.nnz, theirs.flops, theirs.entries)
    assert mine.nnz == stats.nnz > 0 and mine.seconds > 0
    factor.factorise(values)  # numeric only: no analysis in the log
    assert [r.nnz for r in log.records if r.kind == "sparse_factor"] == [stats.nnz, 0]
    factor.destroy(), petsc.destroy(), M.destroy()


def test_options_under_the_prefix_reach_the_schur_factorisation(options):
    _, _, A, n, m = _augmented()
    options(f"{OPTIONS_PREFIX}mat_mumps_icntl_14", 50)
    factor = SchurFactorisation(A.row, A.col, n + m, m, WorkLog(), "u")
    assert (factor.icntl(14), factor.icntl(24), factor.icntl(19)) == (50, 1, 1)
    factor.destroy()
    options(f"{OPTIONS_PREFIX}mat_mumps_icntl_19", 3)  # the Schur layout is the package's
    with pytest.raises(InputError, match="mat_mumps_icntl_19 = 3: dd_contact sets MUMPS"):
        SchurFactorisation(A.row, A.col, n + m, m, WorkLog(), "u")
    options(f"{OPTIONS_PREFIX}mat_mumps_icntl_24", 0)
    with pytest.raises(InputError, match="-dd_contact_mat_mumps_icntl_24 must be 1"):
        SchurFactorisation(A.row, A.col, n + m, m, WorkLog(), "u")


def test_another_mumps_falls_back_to_two_substitutions_with_a_warning(monkeypatch):
    # The C layout is MUMPS 5.8.x's; with another MUMPS the Schur route is not used.
    assert analysis.layout_known()  # this environment's PETSc links MUMPS 5.8.x
    monkeypatch.setattr(analysis, "layout_known", lambda: False)
    scene = verify.order_scene("single", False, 1e4)
    with pytest.warns(RuntimeWarning, match="'multi-rhs' is used instead"):
        problem = dd.StaticProblem(scene, algorithm="w-u")
    assert problem.condensation == "multi-rhs"
    problem.close()


def test_a_schur_subdomain_keeps_one_copy_of_its_matrix_and_of_its_complement():
    """Memory (issue 14): no PETSc matrix next to MUMPS's COO, one dense complement."""
    problem = dd.StaticProblem(verify.order_scene("interface", False, 1e4), "w-v-u")
    problem.solve()
    solver = problem.solver
    for block, sub in solver.subdomains.items():
        assert sub.matrix.A is None  # the upper triangle's COO only
        assert sub.factor._a is sub.matrix.values  # read by MUMPS in place
        assert np.all(sub.factor._irn <= sub.factor._jcn)  # one triangle (1-based, int32)
        assert sub.factor._irn.dtype == np.int32
        assert sub.Z is None  # sent to the surface, which built its pairs from it
    surface = solver.surface
    assert surface.condensed == {}  # no contact on a subdomain's boundary: no Z changes
    # S holds what they were
    assert surface.schur_pairs and not set(surface.base) & set(surface.schur_pairs)
    problem.close()


@pytest.mark.skipif(linalg._malloc_trim() is None, reason="glibc's malloc_trim only")
def test_release_freed_memory_returns_a_freed_heap_to_the_os():
    def resident_mb() -> float:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * 4096 / 2**20

    del_large = np.ones(3_000_000)  # 24 MB, mmapped; freeing it raises glibc's mmap threshold
    del del_large
    chunks = [np.ones(100_000) for _ in range(1000)]  # 800 kB each: now on the heap
    del chunks[:-1]  # the last one pins the top of the heap: free() alone cannot trim it
    before = resident_mb()
    linalg.release_freed_memory()
    assert before - resident_mb() > 400  # of the ~800 MB freed


@pytest.mark.parametrize("before", [True, False])
def test_small_pages_turns_numpy_huge_pages_off_and_restores_them(before):
    switch = np._core.multiarray._set_madvise_hugepage  # returns the setting it replaces
    kept = switch(before)
    try:
        with small_pages():
            assert switch(False) is False  # off inside
        assert switch(kept) is before  # restored after
    finally:
        switch(kept)


def _dense(A: PETSc.Mat) -> np.ndarray:
    """A dense copy of a sequential PETSc matrix (A itself is left sparse)."""
    out = A.convert(PETSc.Mat.Type.DENSE, PETSc.Mat())
    values = out.getDenseArray().copy()
    out.destroy()
    return values


def test_patterned_matrix_holds_base_plus_contact_exactly():
    """The PETSc matrix is the base's sum plus the contact's values, bit for bit, after
    each change; the contact pattern is reserved (zero) before any contact, and the matrix
    keeps no copy of its values besides PETSc's."""
    n = 6
    rng = np.random.default_rng(4)
    base = sp.random_array((n, n), density=0.2, rng=rng) + sp.eye_array(n)
    base = sp.coo_array(base + base.T)
    # a duplicate entry in the base, summed as the COO assembly did
    rows = np.concatenate([base.row, [0]]).astype(np.int64)
    cols = np.concatenate([base.col, [0]]).astype(np.int64)
    vals = np.concatenate([base.data, [0.1]])
    pattern = sp.csr_array(np.ones((2, 2)))
    region = ContactRegion("pad", Block("w", "pad"), np.array([1, 4]), pattern)
    matrix = linalg.PatternedMatrix(MPI.COMM_SELF, n, n, (rows, cols, vals), [region])
    assert not hasattr(matrix, "values")
    expected = sp.csr_array((vals, (rows, cols)), shape=(n, n)).toarray()
    matrix.push()
    assert np.array_equal(_dense(matrix.A), expected)
    reserved = set(zip(rows.tolist(), cols.tolist(), strict=True))
    reserved |= {(i, j) for i in (1, 4) for j in (1, 4)}
    assert matrix.A.getInfo()["nz_used"] == len(reserved)
    for contact in (np.array([[2.0, -1.0], [-1.0, 2.0]]), np.array([[0.5, 0.0], [0.0, 0.25]])):
        matrix.set_contact("pad", sp.csr_array(contact))
        assert matrix.dirty
        matrix.push()
        want = expected.copy()
        want[np.ix_([1, 4], [1, 4])] += contact
        assert np.array_equal(_dense(matrix.A), want)
    matrix.set_contact("pad", sp.csr_array(contact))  # the same values: nothing to push
    assert not matrix.dirty
    matrix.destroy()
