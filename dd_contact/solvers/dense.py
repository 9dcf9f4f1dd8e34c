"""The Cholesky factorisation of a dense group of the surface system (LAPACK), counting its work.

A group's rows may be factorised in another order than the group's own (``order``): the
rows that contact points touch last, so that a point's column, eliminated forward from its
first non-zero row (:func:`~dd_contact.solvers.pointkernels.forward_columns`), starts
near the bottom of the factor (``PointwiseSurface._dense_factor``).
Every method takes and returns the group's own order; :meth:`half` 's forward half and
:meth:`into_order` are in the factor's, as the kept eliminations ``L^-1 V`` are.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from dd_contact.errors import SingularMatrixError
from dd_contact.solvers.worklog import WorkLog

__all__ = ["DenseBacked", "DenseCholesky"]


class DenseCholesky:
    """A LAPACK Cholesky factorisation (potrf) of a dense SPD matrix; solves with trtrs.

    Args:
        A: The matrix, its rows and columns the group's in ``order``; overwritten by the factor.
        log: Where to record the work.
        block: Name of the block, for the log.
        order: The group's rows in the order A has them (``None``: their own).

    Attributes:
        factor: ``cho_factor`` 's (the lower triangle L, row-major, of A in ``order``).
        place: Where each of the group's rows is in the factor (``None``: the same row).
    """

    order: np.ndarray | None = None
    place: np.ndarray | None = None

    def __init__(self, A: np.ndarray, log: WorkLog, block: str, order: np.ndarray | None = None):
        self.log, self.block, self.size = log, block, A.shape[0]
        if order is not None:
            self.order, self.place = order, np.argsort(order)
        start = time.perf_counter()
        try:
            self.factor = sla.cho_factor(A, lower=True, overwrite_a=True, check_finite=False)
        except np.linalg.LinAlgError:
            raise SingularMatrixError(
                f"dense block {block!r} is singular or not positive definite: part of the "
                "model can move freely; check its supports, ties and contacts"
            ) from None
        n = self.size
        log.add(block, "dense_factor", n, 0, time.perf_counter() - start, n**3 / 3.0)

    def into_order(self, B: np.ndarray) -> np.ndarray:
        """B's rows (the group's order) in the factor's order."""
        return B if self.order is None else B[self.order]

    def rows(self, local: np.ndarray) -> np.ndarray:
        """The factor's rows of the group's rows ``local``."""
        return local if self.place is None else self.place[local]

    def _out_of_order(self, X: np.ndarray) -> np.ndarray:
        return X if self.place is None else X[self.place]

    def half(self, b: np.ndarray, trans: int) -> np.ndarray:
        """``L^-1 b`` (``trans`` 1) or ``L^-T b`` (0); not logged.

        Forward, b is in the group's order and the result in the factor's; backward, the
        other way round.
        """
        if trans:
            b = self.into_order(b)
        out = sla.lapack.dtrtrs(self.factor[0].T, b, lower=0, trans=trans)[0]
        return out if trans else self._out_of_order(out)

    def congruence(self, B: np.ndarray, what: str = "") -> np.ndarray:
        """B^T A^-1 B, symmetric, from one forward substitution per column of B.

        W^T W for W = L^-1 B, A = L L^T (symmetric to the last bit), over B's trailing t
        rows: its leading zero rows are zero in W. Logged, size t: t^2 m and t m^2 flops.
        """
        B = self.into_order(B)
        start, nonzero = time.perf_counter(), np.any(B != 0.0, axis=1)
        lead = int(np.argmax(nonzero)) if nonzero.any() else len(B)
        L = self.factor[0][lead:, lead:]
        W = sla.solve_triangular(L, B[lead:], lower=True, check_finite=False)
        n, nrhs = len(L), B.shape[1]
        seconds = time.perf_counter() - start
        self.log.add(self.block, "dense_solve", n, nrhs, seconds, n * n * nrhs, what)
        start = time.perf_counter()
        out = W.T @ W
        seconds = time.perf_counter() - start
        self.log.add(self.block, "dense_product", n, nrhs, seconds, float(n * nrhs * nrhs), what)
        return out

    def product(self, B: np.ndarray, x: np.ndarray, what: str, transpose: bool) -> np.ndarray:
        """``B^T x`` (``transpose``) or ``B x`` for a coupling matrix B with this factor's rows.

        Logged as a ``"dense_product"`` with B's columns as right-hand sides: one pass over
        B, memory traffic like a substitution (2 n m flops).
        """
        start = time.perf_counter()
        out = B.T @ x if transpose else B @ x
        n, m = B.shape
        self.log.add(
            self.block, "dense_product", n, m, time.perf_counter() - start, 2.0 * n * m, what
        )
        return out

    def solve(self, B: np.ndarray, what: str = "") -> np.ndarray:
        """Forward/back substitution for a vector or the columns of a matrix."""
        start = time.perf_counter()
        X = self.substitute(B)
        nrhs, n, seconds = 1 if B.ndim == 1 else B.shape[1], self.size, time.perf_counter() - start
        self.log.add(self.block, "dense_solve", n, nrhs, seconds, 2.0 * n * n * nrhs, what)
        return X

    def substitute(self, B: np.ndarray) -> np.ndarray:
        """``A^-1 B``: trtrs twice on the factor's transpose, LAPACK's upper factor in place.

        Not logged (:meth:`solve` is).
        """
        return self.half(self.half(B, 1), 0)


class DenseBacked(sp.csr_array):
    """A CSR array of a small dense matrix whose products with numpy arrays are BLAS's.

    A reduced block's stiffness and mass are held so (on the dense arrays they were made
    from). scipy's CSR product reads an index per entry and gathers: a quiet step's products with
    a reduced block's stiffness and mass at 2,006 x 2,006 took 6.1 ms each, numpy's 2.0.
    A symmetric one (exactly: checked once) multiplies a vector by ``dsymv``, which reads one
    triangle: 0.93 ms against numpy's 1.65 at that size (``gemm`` with two columns took 6.1:
    a few columns go one by one). Everything else is the CSR array's; arrays made from it
    (slices, sums, transposes) are plain CSR. ``dense`` is shared, not copied: neither is to
    change in place.
    """

    #: Columns of a product taken one by one with ``dsymv`` (more: numpy's ``gemm``).
    SYMV_COLUMNS = 4

    def __init__(self, arg1=None, *args, dense: np.ndarray | None = None, **kwargs):
        super().__init__(dense if dense is not None else arg1, *args, **kwargs)
        self._dense = dense
        # its transpose is F-ordered: dsymv reads it in place
        self._symmetric = (
            dense is not None
            and dense.dtype == np.float64
            and dense.flags.c_contiguous
            and dense.shape[0] == dense.shape[1]
            and np.array_equal(dense, dense.T)
        )

    def _product(self, x: np.ndarray) -> np.ndarray:
        assert self._dense is not None  # only then
        if not self._symmetric or x.dtype != np.float64 or x.ndim > 2:
            return self._dense @ x
        if x.ndim == 1:
            return sla.blas.dsymv(1.0, self._dense.T, x, lower=0)
        if x.shape[1] > self.SYMV_COLUMNS:
            return self._dense @ x
        out = np.empty((self._dense.shape[0], x.shape[1]))
        for j in range(x.shape[1]):
            out[:, j] = sla.blas.dsymv(1.0, self._dense.T, x[:, j], lower=0)
        return out

    def __matmul__(self, other):
        if self._dense is not None and isinstance(other, np.ndarray):
            return self._product(other)
        return super().__matmul__(other)

    def __rmatmul__(self, other):
        if self._dense is not None and isinstance(other, np.ndarray):
            if self._symmetric and other.ndim == 1:  # x^T A = (A x)^T
                return self._product(other)
            return other @ self._dense
        return super().__rmatmul__(other)
