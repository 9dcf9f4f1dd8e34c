"""A reduced subdomain's interior block and factor (dd_contact/solvers/interior.py)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from dd_contact.solvers.interior import (
    InteriorCholesky,
    InteriorMatrix,
    PlainInterior,
    SchurInterior,
    interior_factor,
    multi_solve,
)
from dd_contact.solvers.worklog import WorkLog


def _spd(n: int = 300, seed: int = 3) -> sp.csr_array:
    """A sparse SPD matrix with both triangles stored (a stiffness-like pattern)."""
    rng = np.random.default_rng(seed)
    R = sp.random_array((n, n), density=0.02, rng=rng)
    return sp.csr_array(R + R.T + 10.0 * sp.eye_array(n))


@pytest.mark.parametrize("whole", [False, True])
def test_products_equal_the_whole_matrix(whole):
    A = _spd()
    X = np.random.default_rng(1).random((A.shape[0], 13))  # more than PRODUCT_COLUMNS
    M = InteriorMatrix(A, whole=whole)
    assert (M.half is None) == whole and (M.whole is None) != whole  # held one way only
    assert M.nnz == A.nnz  # both triangles counted, as the AIJ matrix stores them
    ref = A @ X
    assert np.abs(M @ X - ref).max() <= 1e-13 * np.abs(ref).max()
    assert (M @ X).flags.f_contiguous  # as MUMPS's solves take it
    assert np.abs(M @ X[:, 0] - ref[:, 0]).max() <= 1e-13 * np.abs(ref).max()
    assert np.abs(M.upper() - sp.triu(A)).max() <= 1e-15 * np.abs(A).max()
    # the PETSc copy, made when asked for, is the whole matrix's upper triangle
    assert M._mat is None
    assert M.mat.getType() == "seqsbaij"
    y = M.mat.createVecLeft()
    x = M.mat.createVecRight()
    x.array[:] = X[:, 0]
    M.mat.mult(x, y)
    assert np.abs(y.array - ref[:, 0]).max() <= 1e-13 * np.abs(ref).max()
    M.release()
    assert M._mat is None
    assert np.abs(M @ X - ref).max() <= 1e-13 * np.abs(ref).max()  # products go on


def test_a_dropped_factor_lets_the_petsc_copy_go():
    A = _spd()
    M = InteriorMatrix(A)
    factor = InteriorCholesky(M, WorkLog(), "interior")
    assert M._mat is not None  # factorised from it
    factor.drop_matrix()
    assert M._mat is None and factor._interior is None  # the triangle is its owner's alone
    factor.destroy()


def test_solves_after_the_matrix_is_dropped():
    A = _spd()
    B = np.random.default_rng(2).random((A.shape[0], 3))
    ref = spla.spsolve(sp.csc_array(A), B)
    log = WorkLog()
    factor = InteriorCholesky(InteriorMatrix(A), log, "interior")
    assert log.records[-1].nnz == A.nnz
    before = multi_solve(factor, B, "test")
    factor.drop_matrix()
    after = multi_solve(factor, B, "test")
    single = factor.solve_array(B[:, 0], "test")
    scale = np.abs(ref).max()
    assert np.abs(before - ref).max() <= 1e-12 * scale
    assert np.array_equal(after, before)  # the same factor, read the same way
    assert np.abs(single - ref[:, 0]).max() <= 1e-12 * scale
    assert factor.A is factor.factor_matrix  # the matrix and its KSP are gone
    with pytest.raises(RuntimeError, match="cannot re-factorise"):
        factor.refactorise()
    assert log.count("sparse_solve") == 3
    factor.destroy()


@pytest.mark.parametrize("icntl", [10, 11])
def test_the_matrix_is_kept_when_mumps_solves_read_it(icntl):
    """Iterative refinement and error analysis read A in every solve: it stays."""
    from petsc4py import PETSc

    from dd_contact.solvers.petsc_options import options_prefix

    A = _spd()
    B = np.random.default_rng(4).random((A.shape[0], 2))
    ref = spla.spsolve(sp.csc_array(A), B)
    option = f"{options_prefix()}mat_mumps_icntl_{icntl}"
    PETSc.Options()[option] = 1
    try:
        factor = InteriorCholesky(InteriorMatrix(A), WorkLog(), "interior")
    finally:
        PETSc.Options().delValue(option)
    assert factor.factor_matrix.getMumpsIcntl(icntl) == 1
    factor.drop_matrix()
    assert factor.A is not factor.factor_matrix  # kept, with its KSP
    assert np.abs(multi_solve(factor, B, "test") - ref).max() <= 1e-12 * np.abs(ref).max()
    factor.refactorise()  # still possible: nothing was dropped
    factor.destroy()


@pytest.mark.parametrize("kind", ["schur", "plain"])
def test_a_reductions_factor_answers_by_sweeps_as_by_dense_algebra(kind):
    """``A_ii^-1 B``, ``A_ii^-1 A_ib U`` and ``A_bi A_ii^-1 B``, one column and several."""
    A = _spd(360, seed=5).toarray()
    b = np.arange(300, 360)  # the boundary: the last rows
    i = np.arange(300)
    A_ii, A_ib = A[np.ix_(i, i)], A[np.ix_(i, b)]
    factory = SchurInterior if kind == "schur" else PlainInterior
    log = WorkLog()
    factor = factory(InteriorMatrix(sp.csr_array(A_ii)), sp.csr_array(A_ib), log, "interior")
    rng = np.random.default_rng(7)
    try:
        for columns in ((), (1,), (5,)):
            U = rng.standard_normal((b.size, *columns))
            B = rng.standard_normal((i.size, *columns))
            response = np.linalg.solve(A_ii, A_ib @ U)
            solved = np.linalg.solve(A_ii, B)
            condensed = A_ib.T @ solved
            got = (factor.response(U, "t"), factor.solve(B, "t"), factor.condensed(B, "t"))
            for value, want in zip(got, (response, solved, condensed), strict=True):
                assert value.shape == want.shape
                assert np.abs(value - want).max() <= 1e-12 * np.abs(want).max()
        # each operation is one record of the log; the Schur one's are single sweeps
        solves = [r.kind for r in log.records if r.kind not in ("sparse_factor", "schur")]
        if kind == "schur":
            assert set(solves) == {"sparse_backward", "sparse_solve", "sparse_forward"}
            assert factor._factor._a is None  # the matrix's copy went once factorised
            assert factor._factor._held is None  # no right-hand sides kept between calls
        else:
            assert set(solves) == {"sparse_solve"}
        assert len(solves) == 9
        # a workspace reused block after block gives the same (B in its first rows: no copy)
        work = factor.workspace(5)
        U, B = rng.standard_normal((b.size, 5)), rng.standard_normal((i.size, 5))
        want = (np.linalg.solve(A_ii, A_ib @ U), A_ib.T @ np.linalg.solve(A_ii, B))
        for _ in range(2):
            response = factor.response(U, "t", work).copy()
            inside = work[: i.size]
            inside[:] = B
            got = (response, factor.condensed(inside, "t", work))
            for value, expected in zip(got, want, strict=True):
                assert np.abs(value - expected).max() <= 1e-12 * np.abs(expected).max()
        if kind == "schur":
            assert np.shares_memory(factor.response(U, "t", work), work)  # the answer's rows
            with pytest.raises(ValueError, match="a workspace of 4 columns"):
                factor.response(U[:, :4], "t", work)
    finally:
        factor.destroy()


def test_an_expansion_without_its_reduction_is_refused():
    A = _spd(120, seed=2).toarray()
    i, b = np.arange(100), np.arange(100, 120)
    factor = SchurInterior(
        InteriorMatrix(sp.csr_array(A[np.ix_(i, i)])),
        sp.csr_array(A[np.ix_(i, b)]),
        WorkLog(),
        "interior",
    )
    try:
        factor.condensed(np.ones((100, 3)), "t")
        with pytest.raises(RuntimeError, match="as many columns"):
            factor._factor.expand(np.ones((20, 2)))  # reduced 3 columns, not 2
    finally:
        factor.destroy()


def test_an_interior_without_boundary_is_factorised_alone():
    """No tied dofs (nothing for a Schur block): the plain factor, the same solves."""
    A = _spd(80, seed=4)
    factor = interior_factor(InteriorMatrix(A), sp.csr_array((80, 0)), WorkLog(), "interior")
    try:
        assert isinstance(factor, PlainInterior)
        b = np.arange(80.0)
        want = np.linalg.solve(A.toarray(), b)
        assert np.abs(factor.solve(b, "t") - want).max() <= 1e-12 * np.abs(want).max()
    finally:
        factor.destroy()


@pytest.mark.parametrize("mirrored", [True, False])
def test_the_bordered_pattern_is_the_matrix_with_its_coupling_and_a_zero_schur_block(mirrored):
    """``bordered``: [[K, C], [C^T, 0]] from K's COO (both triangles), or its upper
    triangle from K's (``mirrored`` False); the Schur block's diagonal stored as zeros."""
    from dd_contact.solvers.mumps_schur import bordered

    K = _spd(40)
    C = sp.random_array((40, 7), density=0.1, rng=np.random.default_rng(5))
    given = sp.coo_array(K if mirrored else sp.triu(K))
    rows, cols, values = bordered((given.row, given.col, given.data), sp.coo_array(C), mirrored)
    made = sp.coo_array((values, (rows, cols)), shape=(47, 47)).toarray()
    whole = sp.block_array([[K, C], [C.T, sp.csr_array((7, 7))]]).toarray()
    np.testing.assert_array_equal(made, whole if mirrored else np.triu(whole))
    assert np.count_nonzero((rows == cols) & (rows >= 40)) == 7  # the zero diagonal, given
    assert rows.dtype == given.row.dtype
