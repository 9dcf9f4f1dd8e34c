"""Factorisations that count their work: MUMPS for sparse blocks, LAPACK for dense ones.

Every factorisation and solve is appended to a :class:`~dd_contact.solvers.worklog.WorkLog`
(kind, size, right-hand sides, wall time, flop count: MUMPS's own for sparse
factorisations, LAPACK's operation count for dense ones), so a run can report what it did
and compare it with the paper's counting (``dd_contact.paper.flops``).

The factorisations read the PETSc options under the active problem's prefix
(:mod:`dd_contact.solvers.petsc_options`).
"""

from __future__ import annotations

import ctypes
import functools
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.sparse as sp
import threadpoolctl
from dolfinx.fem.petsc import get_petsc_lib

from dd_contact.blocks import ContactRegion
from dd_contact.errors import SingularMatrixError
from dd_contact.parallel import allgathered, exchanged
from dd_contact.solvers.petsc_options import REQUIRED_ICNTL, _check_required_options, options_prefix
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "PatternedMatrix",
    "SingularMatrixError",
    "SparseCholesky",
    "SparseStatistics",
    "dense_threads",
    "petsc_matrix",
    "release_freed_memory",
    "sparse_statistics",
]

# MUMPS control parameters and statistics (MUMPS 5.8 Users' guide, sections 6.1 "Integer
# control parameters" and 7 "Information parameters"; ICNTL(k) is ``id.ICNTL(k)``).
ICNTL_SCHUR_SOLUTION = 26  # ICNTL(26): solution phase when a Schur complement was computed
SCHUR_SOLVE_INTERNAL = 0  # ... 0: solve the internal problem only (Schur variables ignored)
ICNTL_RHS_FORMAT = 20  # ICNTL(20): 0 dense right-hand sides, 1 sparse (sparsity exploited)
SPARSE_RHS = 1
#: MUMPS's controls whose solves read the matrix (iterative refinement, error analysis).
MATRIX_READERS = (10, 11)
INFOG_STATUS = 1  # INFOG(1): 0 success, < 0 error (-10: numerically singular matrix)
INFOG_FACTOR_ENTRIES_ESTIMATED = 20  # INFOG(20): entries of the factor, from the analysis
INFOG_NULL_PIVOTS = 28  # INFOG(28): null pivots found (with ICNTL(24) = 1)
INFOG_FACTOR_ENTRIES = 29  # INFOG(29): entries of the factor, after the factorisation
RINFOG_FLOPS_ESTIMATED = 1  # RINFOG(1): operations of the factorisation, from the analysis
RINFOG_FLOPS = 3  # RINFOG(3): operations of the factorisation, as done

# PETSc's MatFactorType (petsc4py has no enum for it): MAT_FACTOR_CHOLESKY.
MAT_FACTOR_CHOLESKY = 2


def petsc_matrix(
    comm: MPI.Comm,
    local_rows: int,
    global_size: int,
    rows: np.ndarray,
    cols: np.ndarray,
    values: np.ndarray,
) -> PETSc.Mat:
    """A distributed AIJ matrix from COO triplets in global numbering.

    Any rank may add to any row; duplicates are summed.
    """
    # petsc4py's stubs (here and below): comm as a PETSc.Comm (an mpi4py one is accepted),
    # arrays as Sequences (an ndarray is not), enum values as their classes (they are ints)
    A = PETSc.Mat().create(comm=comm)  # type: ignore[arg-type]
    A.setSizes(((local_rows, global_size), (local_rows, global_size)))
    A.setType(PETSc.Mat.Type.AIJ)
    A.setPreallocationCOO(rows.astype(PETSc.IntType), cols.astype(PETSc.IntType))  # type: ignore[arg-type]
    A.setValuesCOO(values.astype(PETSc.ScalarType), addv=PETSc.InsertMode.ADD_VALUES)  # type: ignore[arg-type]
    A.assemble()
    return A


@functools.cache
def _libpetsc() -> ctypes.CDLL:
    """The PETSc C library petsc4py is running on (for calls petsc4py does not wrap).

    Found by dolfinx's :func:`dolfinx.fem.petsc.get_petsc_lib` (the library of the
    installed PETSc: ``PETSC_DIR/PETSC_ARCH/lib`` from ``petsc4py.get_config()``, or the
    copy vendored in the dolfinx-solver wheel) and opened with ctypes; the process has it
    loaded already, so this is the very library petsc4py calls.
    """
    try:
        return ctypes.CDLL(str(get_petsc_lib()))
    except (RuntimeError, OSError) as error:
        raise RuntimeError(
            "cannot load the PETSc shared library through dolfinx.fem.petsc.get_petsc_lib() "
            f"({error}); it is needed for MUMPS's Schur complement and symbolic analysis: "
            "use condensation='multi-rhs' and an explicit algorithm"
        ) from error


@functools.cache
def _malloc_trim():
    """The C library's ``malloc_trim`` (glibc; ``None`` with another C library)."""
    try:
        function = ctypes.CDLL(None).malloc_trim
    except (AttributeError, OSError):
        return None
    function.argtypes, function.restype = [ctypes.c_size_t], ctypes.c_int
    return function


def release_freed_memory() -> None:
    """Hand the heap memory freed so far back to the OS (glibc's ``malloc_trim``).

    Building a solver frees many temporary arrays of a few MB each, which glibc keeps in
    the process's heap; without this they add to the peak memory of the factorisations
    that follow (docs/benchmarks.md, "Memory"). Without glibc it does nothing.
    """
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


#: Dense work on matrices of fewer rows than this runs on one BLAS thread (docs/solvers.md,
#: "Dense work on one thread"): numpy's and scipy's OpenBLAS start a thread per core, and on
#: a core another process uses, a small factorisation waits for its spinning partner thread
#: (v-w-u's 449 surface factorisations of the pin joint: 0.18 s on one thread, 2.2-37.6 s
#: on two of this shared 2-core machine).
DENSE_THREADED_ROWS = 2000


@functools.cache
def _blas_libraries() -> tuple:
    """The BLAS libraries loaded in this process (numpy's and scipy's are, by this module)."""
    return tuple(threadpoolctl.ThreadpoolController().select(user_api="blas").lib_controllers)


@contextmanager
def dense_threads(rows: int) -> Iterator[None]:
    """One BLAS thread inside, for dense work on fewer than DENSE_THREADED_ROWS rows.

    Larger work keeps the process's threads. A few microseconds: use it around a whole
    solve, not each small operation.
    """
    libraries = [] if rows >= DENSE_THREADED_ROWS else _blas_libraries()
    limited = [(lib, n) for lib in libraries if (n := lib.num_threads) > 1]
    for lib, _ in limited:
        lib.set_num_threads(1)
    try:
        yield
    finally:
        for lib, n in limited:
            lib.set_num_threads(n)


class SparseCholesky:
    """A MUMPS Cholesky factorisation of an SPD PETSc matrix.

    With ``schur = m``, the last m rows and columns are a Schur block: MUMPS factorises the
    leading block K only and returns ``S = A22 - A21 K^-1 A12`` (:attr:`schur_complement`);
    solves then act on K alone (MUMPS ICNTL(26) = 0; pass vectors of the full size).

    Args:
        A: The matrix (symmetric positive definite, or its leading block if ``schur``).
        log: Where to record the work.
        block: Name of the block, for the log.
        schur: Size of the trailing Schur block (0: none).
    """

    #: The factorisation: an unsymmetric matrix takes LU (``solvers.unsymmetric.SparseLU``).
    PC_TYPE, SYMMETRIC = PETSc.PC.Type.CHOLESKY, True

    def __init__(self, A: PETSc.Mat, log: WorkLog, block: str, schur: int = 0):
        _check_required_options()
        self.A, self.log, self.block, self.schur = A, log, block, schur
        self.schur_complement: np.ndarray | None = None
        self.entries = 0.0
        self._analysed = False
        # petsc4py's stubs: enum values typed as int, arrays as Sequences (see petsc_matrix)
        A.setOption(PETSc.Mat.Option.SYMMETRIC, self.SYMMETRIC)  # type: ignore[arg-type]
        A.setOption(PETSc.Mat.Option.SPD, self.SYMMETRIC)  # type: ignore[arg-type]
        self.ksp = PETSc.KSP().create(A.comm)
        self.ksp.setOptionsPrefix(options_prefix())  # the factor matrix inherits it
        self.ksp.setOperators(A)
        self._set_types()
        # The user's options (-dd_contact_pc_factor_*, ...) after the defaults they adjust;
        # -dd_contact_mat_mumps_* are read by MUMPS's analysis in setUp, under the same
        # prefix. The solver types are required: set again in case an option changed them.
        self.ksp.setFromOptions()
        self._set_types()
        pc = self.ksp.getPC()
        pc.setFactorSetUpSolverType()
        factor = pc.getFactorMatrix()
        for icntl, value in REQUIRED_ICNTL.items():  # detect null pivots: singular fails loudly
            factor.setMumpsIcntl(icntl, value)
        if schur:
            n = A.getSize()[0]
            self._schur_is = PETSc.IS().createStride(schur, n - schur, 1, comm=A.comm)
            _check(_libpetsc().MatFactorSetSchurIS(_ptr(factor), _ptr(self._schur_is)))
        self._factorise()

    def _set_types(self) -> None:
        self.ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = self.ksp.getPC()
        pc.setType(self.PC_TYPE)
        pc.setFactorSolverType("mumps")

    def refactorise(self) -> None:
        """Numeric re-factorisation after the matrix values changed (same pattern)."""
        self.ksp.setOperators(self.A)
        self._factorise()

    def _factorise(self) -> None:
        start = time.perf_counter()
        self.ksp.setUp()
        factor = self.ksp.getPC().getFactorMatrix()
        info = factor.getMumpsInfog(INFOG_STATUS)
        if info < 0:
            raise SingularMatrixError(
                f"MUMPS factorisation of block {self.block!r} failed (INFOG(1) = {info}); "
                "the matrix is singular or not positive definite"
            )
        null_pivots = factor.getMumpsInfog(INFOG_NULL_PIVOTS)
        if null_pivots > 0:
            raise SingularMatrixError(
                f"block {self.block!r} is singular ({null_pivots} null pivots): "
                "part of the model can move freely; check its supports, ties and contacts"
            )
        self.entries = float(_mumps_count(factor.getMumpsInfog(INFOG_FACTOR_ENTRIES)))
        self.log.add(
            self.block,
            "sparse_factor",
            self.A.getSize()[0] - self.schur,
            0,
            time.perf_counter() - start,
            factor.getMumpsRinfog(RINFOG_FLOPS),
            f"with a Schur complement of {self.schur}" if self.schur else "",
            self.entries,
            0 if self._analysed else int(self.A.getInfo()["nz_used"]),
        )
        self._analysed = True
        if self.schur:
            # solves: the internal problem K only (reset by PETSc)
            factor.setMumpsIcntl(ICNTL_SCHUR_SOLUTION, SCHUR_SOLVE_INTERNAL)
            start = time.perf_counter()
            self.schur_complement = _schur_complement(factor, self.schur)
            self.log.add(self.block, "schur", self.schur, 0, time.perf_counter() - start)

    def solve(self, b: PETSc.Vec, what: str = "") -> PETSc.Vec:
        """Forward/back substitution for one right-hand side."""
        x = b.duplicate()
        start = time.perf_counter()
        self.ksp.solve(b, x)
        seconds = time.perf_counter() - start
        self._log_solve(b.getSize(), 1, seconds, what)
        return x

    def solve_array(self, b: np.ndarray, what: str = "") -> np.ndarray:
        """:meth:`solve` for a serial factorisation, on numpy arrays."""
        vb = PETSc.Vec().createWithArray(
            np.ascontiguousarray(b, dtype=PETSc.ScalarType),  # type: ignore[arg-type]  # stub
            comm=self.A.comm,
        )
        x = self.solve(vb, what)
        out = x.getArray().copy()
        x.destroy(), vb.destroy()
        return out

    def solve_many(self, B: np.ndarray, what: str = "") -> np.ndarray:
        """Substitutions for the columns of a dense matrix at once (MUMPS multi-RHS)."""
        n, m = B.shape
        Bm = PETSc.Mat().createDense(
            (n, m),
            array=np.asfortranarray(B, PETSc.ScalarType),  # type: ignore[arg-type]  # stub
            comm=self.A.comm,
        )
        Xm = PETSc.Mat().createDense((n, m), comm=self.A.comm)
        Xm.setUp()
        start = time.perf_counter()
        self.ksp.getPC().getFactorMatrix().matSolve(Bm, Xm)
        self._log_solve(n, m, time.perf_counter() - start, what)
        X = Xm.getDenseArray().copy()
        Bm.destroy(), Xm.destroy()
        return X

    def _log_solve(self, n: int, nrhs: int, seconds: float, what: str) -> None:
        # forward and backward sweeps: one multiply-add per factor entry each
        flops = 4.0 * self.entries * nrhs
        self.log.add(self.block, "sparse_solve", n, nrhs, seconds, flops, what, self.entries)

    def destroy(self) -> None:
        """Free the factorisation."""
        self.ksp.destroy()
        if self.schur:
            self._schur_is.destroy()


@dataclass(frozen=True)
class SparseStatistics:
    """What MUMPS's symbolic analysis predicts for a Cholesky factorisation.

    Attributes:
        size: Rows factorised (without a Schur block).
        nnz: Stored entries of the matrix.
        flops: Operations of the numeric factorisation (RINFOG(1)).
        entries: Entries of the factor (INFOG(20)): what a substitution reads.
        schur: Size of the Schur block computed with the factorisation.
    """

    size: int
    nnz: int
    flops: float
    entries: float
    schur: int = 0


def _mumps_count(value: int) -> int:
    """MUMPS reports counts above 2^31 as minus millions."""
    return value if value >= 0 else -value * 1_000_000


def sparse_statistics(A: PETSc.Mat, schur: int = 0) -> SparseStatistics:
    """MUMPS's symbolic analysis of ``A`` (no numeric factorisation; collective).

    For an SPD matrix MUMPS does not pivot, so the analysis gives the flops and factor size
    of the factorisation exactly. ``schur`` trailing rows form a Schur block, as in
    :class:`SparseCholesky`; the options under the active prefix apply here too.
    """
    _check_required_options()
    lib = _libpetsc()
    integer = ctypes.c_int64 if np.dtype(PETSc.IntType).itemsize == 8 else ctypes.c_int32
    F = ctypes.c_void_p()
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)  # type: ignore[arg-type]  # stub: int
    A.setOption(PETSc.Mat.Option.SPD, True)  # type: ignore[arg-type]
    _check(lib.MatGetFactor(_ptr(A), b"mumps", MAT_FACTOR_CHOLESKY, ctypes.byref(F)))
    try:
        schur_is = None
        _check(lib.MatSetOptionsPrefix(F, options_prefix().encode()))  # as SparseCholesky's
        if schur:
            n = A.getSize()[0]
            schur_is = PETSc.IS().createStride(schur, n - schur, 1, comm=A.comm)
            _check(lib.MatFactorSetSchurIS(F, _ptr(schur_is)))
        _check(lib.MatCholeskyFactorSymbolic(F, _ptr(A), None, None))
        infog, rinfog = integer(), ctypes.c_double()
        _check(
            lib.MatMumpsGetInfog(F, integer(INFOG_FACTOR_ENTRIES_ESTIMATED), ctypes.byref(infog))
        )
        _check(lib.MatMumpsGetRinfog(F, integer(RINFOG_FLOPS_ESTIMATED), ctypes.byref(rinfog)))
    finally:
        _check(lib.MatDestroy(ctypes.byref(F)))
        if schur:
            assert schur_is is not None
            schur_is.destroy()
    return SparseStatistics(
        A.getSize()[0] - schur,
        int(A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]),  # type: ignore[arg-type]
        float(rinfog.value),
        float(_mumps_count(infog.value)),
        schur,
    )


def _ptr(obj) -> ctypes.c_void_p:
    return ctypes.c_void_p(obj.handle)


def _check(error: int) -> None:
    if error:
        raise RuntimeError(f"PETSc error {error} in a direct call (MUMPS Schur or analysis)")


def _schur_complement(factor: PETSc.Mat, m: int) -> np.ndarray:
    """The dense Schur complement MUMPS computed with the factorisation (a copy)."""
    lib = _libpetsc()
    S, status = ctypes.c_void_p(), ctypes.c_int()
    _check(lib.MatFactorCreateSchurComplement(_ptr(factor), ctypes.byref(S), ctypes.byref(status)))
    data = ctypes.POINTER(ctypes.c_double)()
    _check(lib.MatDenseGetArray(S, ctypes.byref(data)))
    out = np.ctypeslib.as_array(data, shape=(m * m,)).reshape(m, m, order="F").copy()
    _check(lib.MatDenseRestoreArray(S, ctypes.byref(data)))
    _check(lib.MatDestroy(ctypes.byref(S)))
    return out


class PatternedMatrix:
    """A symmetric matrix whose contact entries are reserved once and rewritten in place.

    The base entries (COO, global numbering) are fixed; each contact region adds the
    entries of its pattern at given rows/columns, zero until :meth:`set_contact`. A change
    of values marks the matrix dirty; :meth:`push` sends the values to PETSc.

    The PETSc matrix is built from its rows in CSR and keeps no COO map; :meth:`push`
    rewrites the contact entries alone (base value plus contact value, the sum the COO
    assembly made), so no copy of the base values is kept either.

    Args:
        comm: Communicator.
        local_rows: Rows owned by this rank.
        size: Global size.
        base: Base (rows, cols, values), both triangles, duplicates summed.
        contacts: The contact regions, their ``dofs`` in this matrix's numbering (rows
            owned by this rank).
        upper_coo: For a factorisation outside PETSc: keep the upper triangle only, in
            COO (:attr:`values`, with :meth:`take_indices`), and build no PETSc matrix
            (:attr:`A` is ``None``): half the values, none of PETSc's copies.
    """

    def __init__(
        self,
        comm,
        local_rows: int,
        size: int,
        base,
        contacts: Sequence[ContactRegion],
        upper_coo: bool = False,
    ):
        def kept(r, c):  # the entries stored: all, or the upper triangle
            return np.flatnonzero(r <= c) if upper_coo else slice(None)

        keep = kept(base[0], base[1])
        rows, cols, vals = [base[0][keep]], [base[1][keep]], [base[2][keep]]
        self._slices: dict[str, tuple[slice, np.ndarray, np.ndarray]] = {}
        position = len(vals[0])
        for region in contacts:
            r, c, _ = coo_of(region.pattern)
            keep = kept(region.dofs[r], region.dofs[c])
            r, c = r[keep], c[keep]
            rows.append(region.dofs[r])
            cols.append(region.dofs[c])
            vals.append(np.zeros(len(r)))
            self._slices[region.name] = (slice(position, position + len(r)), r, c)
            position += len(r)
        self.A = None
        self._indices = None
        self.dirty = True
        if upper_coo:
            self.values = np.concatenate(vals).astype(np.float64)
            self._indices = (np.concatenate(rows), np.concatenate(cols))
            return
        entries = [np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)]
        del rows, cols, vals, keep, base  # held by the caller at most: fewer copies at once
        self.A, local = _aij_from_coo(comm, local_rows, size, entries)
        # Each region's entries: global rows and columns, the base value there, the contact's.
        start = self.A.getOwnershipRange()[0]
        self._contacts: dict[str, list[np.ndarray]] = {}
        for region in contacts:
            _, r, c = self._slices[region.name]
            at_rows, at_cols = region.dofs[r], region.dofs[c]
            base_there = np.asarray(local[at_rows - start, at_cols], dtype=np.float64).ravel()
            self._contacts[region.name] = [at_rows, at_cols, base_there, np.zeros(len(r))]

    def take_indices(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of :attr:`values` (COO), handed over once and then forgotten."""
        indices, self._indices = self._indices, None
        if indices is None:
            raise RuntimeError("PatternedMatrix: indices kept only with upper_coo, once")
        return indices

    def set_contact(self, key: str, matrix: sp.csr_array) -> None:
        """Replace the contact matrix of region ``key`` (surface dof numbering)."""
        where, r, c = self._slices[key]
        values = np.asarray(matrix[r, c]).ravel()
        current = self.values[where] if self.A is None else self._contacts[key][3]
        if not np.array_equal(values, current):
            current[:] = values
            self.dirty = True

    def push(self) -> None:
        """Collective: send the contact values to PETSc (if it holds the matrix); clean."""
        if self.A is not None:
            insert = PETSc.InsertMode.INSERT_VALUES
            for rows, cols, base_there, contact in self._contacts.values():
                column = (-1, 1)
                self.A.setValuesRCV(
                    rows.astype(PETSc.IntType).reshape(column),
                    cols.astype(PETSc.IntType).reshape(column),
                    (base_there + contact).astype(PETSc.ScalarType).reshape(column),
                    insert,
                )
            self.A.assemble()
        self.dirty = False

    def destroy(self) -> None:
        """Free the PETSc matrix, if any."""
        if self.A is not None:
            self.A.destroy()


def _aij_from_coo(
    comm, local_rows: int, size: int, entries: list[np.ndarray]
) -> tuple[PETSc.Mat, sp.csr_array]:
    """Collective: an AIJ matrix from COO ``[rows, cols, values]`` (any rank, any row).

    ``entries`` is emptied: the triplets are freed as soon as they are in CSR.

    Entries of rows another rank owns are sent to it; each rank sums its rows' entries into
    CSR (explicit zeros kept: they reserve the contact pattern) and PETSc copies that CSR.
    Returns the matrix and this rank's rows as scipy CSR (local row numbering).
    """
    rows, cols, values = entries
    entries.clear()
    starts = np.concatenate([[0], np.cumsum(allgathered(comm, local_rows))])
    if comm.size > 1:
        owner = np.searchsorted(starts, rows, side="right") - 1
        sent = [tuple(a[owner == rank] for a in (rows, cols, values)) for rank in range(comm.size)]
        nbytes = sum(a.nbytes for part in sent for a in part)
        received = exchanged(comm, sent, nbytes)
        rows, cols, values = (np.concatenate([part[i] for part in received]) for i in range(3))
    start = starts[comm.rank]
    local = sp.csr_array((values, (rows - start, cols)), shape=(local_rows, size))
    del rows, cols, values
    local.sum_duplicates()
    csr = (
        local.indptr.astype(PETSc.IntType, copy=False),
        local.indices.astype(PETSc.IntType, copy=False),
        local.data.astype(PETSc.ScalarType, copy=False),
    )
    A = PETSc.Mat().createAIJ(((local_rows, size), (local_rows, size)), csr=csr, comm=comm)
    A.assemble()
    return A, local


def coo_of(matrix: sp.sparray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row, column and value arrays of a sparse matrix."""
    c = sp.coo_array(matrix)
    return c.row, c.col, c.data
