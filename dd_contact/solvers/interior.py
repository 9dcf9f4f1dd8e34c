"""A reduced subdomain's interior block and its factor, held as lightly as they can be.

The reduction (:mod:`dd_contact.solvers.reduced`) factorises the interior block ``A_ii``
once and reads the factor until the run ends; ``A_ii`` itself only until the reduced
matrices are formed, ``M_ii`` for the whole run. docs/solvers.md, "Reduced subdomains"
(memory).

What the reduction asks of the factor (:func:`interior_factor`): ``A_ii^-1 B``, the
interior's response to boundary values ``A_ii^-1 A_ib U`` and the condensed
``A_bi A_ii^-1 B``. :class:`SchurInterior` factorises ``[[A_ii, A_ib], [A_bi, 0]]`` with the
boundary as MUMPS's Schur block, so that the last two are one sweep of the factor each
(expansion, reduction), not two; :class:`PlainInterior`, a factor of ``A_ii`` alone, is
used where the Schur phases cannot be driven (another MUMPS version).
"""

from __future__ import annotations

import time

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.sparse as sp

from dd_contact.solvers.linalg import MATRIX_READERS, SparseCholesky
from dd_contact.solvers.mumps_schur import SchurFactorisation, bordered, layout_known
from dd_contact.solvers.petsc_options import options_prefix, petsc_options
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "InteriorCholesky",
    "InteriorMatrix",
    "PlainInterior",
    "SchurInterior",
    "interior_factor",
]

#: The option that keeps a MUMPS factor out of core (on disk): ICNTL(22) = 1.
OUT_OF_CORE = "mat_mumps_icntl_22"

#: Right-hand sides MUMPS takes in one pass over a factor on disk (ICNTL(27); MUMPS's own
#: bound is 32): each pass reads the whole factor back (2.4 GB at a quarter of the paper's
#: bar, 12 GB at its size, 0.6 s of a pass at 1/4), and out of core the memory is there.
OUT_OF_CORE_COLUMNS = 128
PASS_COLUMNS = "mat_mumps_icntl_27"

#: Columns an :class:`InteriorMatrix` product takes at once: scipy's products copy them
#: (C-ordered) and return as many, so the block bounds those temporaries; each block reads
#: the triangle twice.
PRODUCT_COLUMNS = 8


def _dense(X: np.ndarray, comm) -> PETSc.Mat:
    """A PETSc dense matrix on X's array (Fortran-ordered: shared, not copied)."""
    return PETSc.Mat().createDense(X.shape, array=X, comm=comm)  # type: ignore[arg-type]  # stub


class InteriorMatrix:
    """A symmetric interior block held once: by its upper triangle, or whole (scipy CSR).

    By the triangle (the stiffness: MUMPS and one congruence read it), with half its
    diagonal (``H = triu(A, 1) + D / 2``, halving is exact), so that a product is
    ``H X + H^T X``; whole (``whole=True``: the mass, whose products are most of a
    reduction's after its solves), a product reads it once by rows. At 1/4 of the paper's
    bar (335k interior dofs, the mass's 8.4M entries) the triangle's products took 11-15 ms a
    column, the whole matrix's 5-6 (the transposed half scatters), for 50 MB more. Both are
    scipy's, which read the matrix once for all of a block's columns, where PETSc's SBAIJ
    product with a dense matrix reads it once per column (57 ms a column of the stiffness,
    against 17-29). :attr:`mat`, the PETSc SBAIJ copy MUMPS factorises (it reads an SBAIJ
    matrix's values in place; of an AIJ one it copies the upper triangle) and SLEPc reads, is
    made when first asked for and freed by :meth:`release`.
    """

    def __init__(self, A: sp.sparray, whole: bool = False):
        if whole:
            self.whole: sp.csr_array | None = sp.csr_array(A)  # A's arrays, not a copy
            self.whole.sort_indices()
            self.half: sp.csr_array | None = None
            #: Stored entries of both triangles (as an AIJ matrix's), for the work log.
            self.nnz = self.whole.nnz
        else:
            U = sp.triu(sp.csr_array(A), format="csr")
            U.sort_indices()
            diagonal = U.diagonal()
            self.half = sp.csr_array(U - sp.diags_array(diagonal / 2.0, format="csr"))
            self.half.sort_indices()
            del U
            self.whole = None
            self.nnz = 2 * self.half.nnz - np.count_nonzero(diagonal)
        self._mat: PETSc.Mat | None = None

    def upper(self) -> sp.csr_array:
        """The upper triangle with the whole diagonal (a new CSR array, sorted)."""
        if self.whole is not None:
            U = sp.triu(self.whole, format="csr")
        else:
            assert self.half is not None  # held by its triangle
            U = sp.csr_array(self.half + sp.diags_array(self.half.diagonal(), format="csr"))
        U.sort_indices()
        return U

    @property
    def mat(self) -> PETSc.Mat:
        """The PETSc SBAIJ copy (made on first use)."""
        if self._mat is None:
            U, index = self.upper(), PETSc.IntType
            self._mat = PETSc.Mat().createSBAIJ(
                U.shape[0],
                1,
                csr=(U.indptr.astype(index), U.indices.astype(index), U.data),
                comm=MPI.COMM_SELF,  # type: ignore[arg-type]  # stub
            )
        return self._mat

    def release(self) -> None:
        """Free the PETSc copy (idempotent; products go on)."""
        if self._mat is not None:
            self._mat.destroy()
            self._mat = None

    def __matmul__(self, X: np.ndarray) -> np.ndarray:
        return self.times(X)

    def times(self, X: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``A X``, into ``out`` if given (X's shape; else a new Fortran-ordered array)."""
        X = np.asarray(X, dtype=float)
        if X.ndim == 1:
            return self._product(X)
        if out is None:
            out = np.empty(X.shape, order="F")  # as MUMPS's solves take them: no copy there
        for j0 in range(0, X.shape[1], PRODUCT_COLUMNS):
            j1 = j0 + PRODUCT_COLUMNS
            out[:, j0:j1] = self._product(np.ascontiguousarray(X[:, j0:j1]))
        return out

    def _product(self, X: np.ndarray) -> np.ndarray:
        if self.whole is not None:
            return self.whole @ X
        assert self.half is not None  # held by its triangle
        out = self.half @ X
        out += self.half.T @ X
        return out


class InteriorCholesky(SparseCholesky):
    """:class:`SparseCholesky` of an :class:`InteriorMatrix` that can drop the matrix.

    After :meth:`drop_matrix` only the factor is held: solves go to MUMPS directly (the
    factor matrix's solve, which reads the factor alone), the KSP and ``A``'s PETSc copy
    are freed (``A`` itself, the scipy triangle, is its owner's), and it cannot be
    re-factorised.
    """

    def __init__(self, A: InteriorMatrix, log, block: str):
        super().__init__(A.mat, log, block)
        self.log.records[-1].nnz = A.nnz  # the SBAIJ stores one triangle: count both
        self._factor: PETSc.Mat | None = None
        self._interior: InteriorMatrix | None = A

    @property
    def factor_matrix(self) -> PETSc.Mat:
        """MUMPS's factor (a PETSc factor matrix)."""
        if self._factor is not None:
            return self._factor
        return self.ksp.getPC().getFactorMatrix()

    def drop_matrix(self) -> None:
        """Free the KSP and the matrix, keeping the factor (MUMPS's solves never read A).

        Kept when the user's options ask MUMPS for iterative refinement or error analysis
        (ICNTL(10), ICNTL(11)): then its solves read the matrix's values, held in place.
        """
        factor = self.ksp.getPC().getFactorMatrix() if self._factor is None else None
        if factor is not None and not any(factor.getMumpsIcntl(k) for k in MATRIX_READERS):
            self._factor = factor  # a reference: outlives the KSP
            self.ksp.destroy()
            assert self._interior is not None  # held until the matrix is dropped
            self._interior.release()
            self._interior = None  # its triangle is its owner's to free
            self.A = self._factor  # its comm and size for solve_array: nothing else reads A

    def refactorise(self) -> None:
        """Numeric re-factorisation (not once the matrix is dropped)."""
        if self._factor is not None:
            raise RuntimeError(f"{self.block!r}: its matrix was dropped; it cannot re-factorise")
        super().refactorise()

    def solve(self, b: PETSc.Vec, what: str = "") -> PETSc.Vec:
        """Forward/back substitution for one right-hand side."""
        if self._factor is None:
            return super().solve(b, what)
        x = b.duplicate()
        start = time.perf_counter()
        self._factor.solve(b, x)
        self._log_solve(b.getSize(), 1, time.perf_counter() - start, what)
        return x

    def destroy(self) -> None:
        """Free the factorisation (and the matrix)."""
        if self._factor is None:
            super().destroy()
            assert self._interior is not None  # held until the matrix is dropped
            self._interior.release()  # A
        else:
            self.A.destroy()  # the factor matrix


def multi_solve(factor: InteriorCholesky, B: np.ndarray, what: str | None) -> np.ndarray:
    """``A^-1 B`` (MUMPS multi-RHS), B's array and the answer's shared with PETSc's matrices.

    ``solve_many`` copies both: four n x columns arrays at its peak, not two. ``what``
    ``None``: not logged.
    """
    B = np.asfortranarray(B, dtype=PETSc.ScalarType)
    X = np.empty_like(B, order="F")
    comm = factor.factor_matrix.comm
    Bm, Xm = _dense(B, comm), _dense(X, comm)
    start = time.perf_counter()
    factor.factor_matrix.matSolve(Bm, Xm)
    seconds = time.perf_counter() - start
    Bm.destroy(), Xm.destroy()
    if what is None:
        return X
    flops = 4.0 * factor.entries * B.shape[1]
    factor.log.add(
        factor.block, "sparse_solve", B.shape[0], B.shape[1], seconds, flops, what, factor.entries
    )
    return X


class SchurInterior:
    """``A_ii``'s factor with the boundary b as MUMPS's Schur block (:func:`interior_factor`).

    Factorises ``[[A_ii, A_ib], [A_bi, 0]]`` (b last); MUMPS's reduction phase gives
    ``-A_bi A_ii^-1 B`` with one forward sweep, its expansion ``A_ii^-1 A_ib U`` with one
    backward sweep (:meth:`~dd_contact.solvers.mumps_schur.SchurFactorisation.response`),
    and its internal solve ``A_ii^-1 B``. The matrix's copy goes once factorised.
    """

    #: Columns a pass over the factor takes (out of core), ``None``: the caller's blocks.
    pass_columns: int | None = None

    def __init__(self, A: InteriorMatrix, A_ib: sp.sparray, log: WorkLog, block: str):
        self.log, self.block = log, block
        ni, nb = A_ib.shape
        U = sp.coo_array(A.upper())
        upper = (U.row, U.col, U.data)
        del U
        rows, cols, values = bordered(upper, sp.coo_array(A_ib), mirrored=False)
        del upper
        rows, cols = rows.astype(np.int32, copy=False), cols.astype(np.int32, copy=False)
        self._factor = SchurFactorisation(rows, cols, ni + nb, nb, log, block)
        del rows, cols
        self._factor.factorise(values)  # S = -A_bi A_ii^-1 A_ib: the reduction forms its own
        self._factor.release_matrix()
        self.entries = self._factor.entries

    def solve(self, B: np.ndarray, what: str | None) -> np.ndarray:
        """``A_ii^-1 B`` (``what`` ``None``: not logged)."""
        return self._factor.solve_interior(B, what)

    def response(self, U: np.ndarray, what: str, into: np.ndarray | None = None) -> np.ndarray:
        """``A_ii^-1 A_ib U``: the interior held by boundary values U (one backward sweep).

        ``into``: a :meth:`workspace` of U's columns, whose first rows are then the answer.
        """
        return self._factor.response(U, what, into)

    def condensed(self, B: np.ndarray, what: str, into: np.ndarray | None = None) -> np.ndarray:
        """``A_bi A_ii^-1 B`` (one forward sweep); B may be ``into`` 's first rows."""
        return -self._factor.reduce(B, what, into)

    def workspace(self, k: int) -> np.ndarray:
        """An array for k columns to pass as ``into`` call after call (touched only once)."""
        return self._factor.workspace(k)

    def destroy(self) -> None:
        """Free MUMPS's memory."""
        self._factor.destroy()


class PlainInterior:
    """``A_ii``'s factor alone, with :class:`SchurInterior`'s operations by whole solves."""

    #: Columns a pass over the factor takes (out of core), ``None``: the caller's blocks.
    pass_columns: int | None = None

    def __init__(self, A: InteriorMatrix, A_ib: sp.sparray, log: WorkLog, block: str):
        self.log, self.block = log, block
        self._A_ib = sp.csr_array(A_ib)
        self._cholesky = InteriorCholesky(A, log, block)
        self._cholesky.drop_matrix()
        self.entries = self._cholesky.entries

    def solve(self, B: np.ndarray, what: str | None) -> np.ndarray:
        """``A_ii^-1 B`` (``what`` ``None``: not logged)."""
        if B.ndim == 2:
            return multi_solve(self._cholesky, B, what)
        return multi_solve(self._cholesky, B[:, None], what)[:, 0]

    def response(self, U: np.ndarray, what: str, into: np.ndarray | None = None) -> np.ndarray:
        """``A_ii^-1 A_ib U`` (``into`` is not used: the whole solve makes its own)."""
        B = self._A_ib @ U
        return self.solve(np.asfortranarray(B) if B.ndim == 2 else B, what)

    def condensed(self, B: np.ndarray, what: str, into: np.ndarray | None = None) -> np.ndarray:
        """``A_bi A_ii^-1 B`` (``into``: not used)."""
        return self._A_ib.T @ self.solve(B, what)

    def workspace(self, k: int) -> np.ndarray:
        """An interior block of k columns (:meth:`SchurInterior.workspace`'s role)."""
        return np.empty((self._A_ib.shape[0], k), order="F")

    def destroy(self) -> None:
        """Free the factorisation."""
        self._cholesky.destroy()


def interior_factor(
    A: InteriorMatrix, A_ib: sp.sparray, log: WorkLog, block: str, out_of_core: bool = False
) -> SchurInterior | PlainInterior:
    """``A_ii``'s factor for a reduction (``out_of_core``: MUMPS keeps it on disk).

    :class:`SchurInterior` where MUMPS's Schur phases can be driven (its C layout is
    known) and there is a boundary to be its Schur block, :class:`PlainInterior` otherwise.
    Out of core is MUMPS's ICNTL(22) = 1, with :data:`OUT_OF_CORE_COLUMNS` right-hand sides
    a pass (ICNTL(27)), put under the active options prefix while the factor is made (both
    kinds read their options there).
    """
    options = {OUT_OF_CORE: 1, PASS_COLUMNS: OUT_OF_CORE_COLUMNS} if out_of_core else None
    with petsc_options(options, options_prefix()):
        if A_ib.shape[1] and layout_known():
            factor: SchurInterior | PlainInterior = SchurInterior(A, A_ib, log, block)
        else:
            factor = PlainInterior(A, A_ib, log, block)
    factor.pass_columns = OUT_OF_CORE_COLUMNS if out_of_core else None
    return factor
