"""The dense kernels of the point-by-point corrections (:mod:`~dd_contact.solvers.pointwise`).

A first flip's points are eliminated forward through a last-level group's Cholesky factor
beside the corrected solve's own right-hand side (:func:`forward_columns`); the correction
whose columns are the points' rows (:class:`PointCorrection`) factorises its capacitance
matrix, of points beside other columns equilibrated (:func:`equilibrated`).
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import cython_blas

from dd_contact.blocks import Block
from dd_contact.solvers.lowrank import Correction, capacitance

__all__ = ["PointCorrection", "equilibrated", "forward_columns", "local_rows", "point_columns"]


def _cython_blas(name: str, *argtypes):
    """SciPy's own BLAS routine ``name`` (:mod:`scipy.linalg.cython_blas`) callable by ctypes.

    Its Python wrappers (:mod:`scipy.linalg.blas`) take no leading dimension: a trailing
    sub-triangle of a factor would be copied whole on every call.
    """
    capsule = cython_blas.__pyx_capi__[name]
    signature = ctypes.pythonapi.PyCapsule_GetName
    signature.restype, signature.argtypes = ctypes.c_char_p, [ctypes.py_object]
    pointer = ctypes.pythonapi.PyCapsule_GetPointer
    pointer.restype, pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
    return ctypes.CFUNCTYPE(None, *argtypes)(pointer(capsule, signature(capsule)))


_INT = ctypes.POINTER(ctypes.c_int)
#: dtrsv(uplo, trans, diag, n, a, lda, x, incx)
_DTRSV = _cython_blas(
    "dtrsv", *3 * [ctypes.c_char_p], _INT, ctypes.c_void_p, _INT, ctypes.c_void_p, _INT
)


#: Rows up to which :func:`forward_columns` solves column by column (its factor's triangle
#: stays in the cache between columns: 4.9 MB at 1,107 rows); beyond, block by block, the
#: triangle read once for all the columns (7,200 rows, the pin joint's all-walls group: 207
#: MB a reading), in blocks of :data:`BLOCK` rows.
PER_COLUMN_ROWS, BLOCK = 1500, 256


def forward_columns(L: np.ndarray, B: np.ndarray, per_column_rows: int = PER_COLUMN_ROWS) -> float:
    """``B <- L^-1 B``, each column from its first non-zero row on; returns the flops.

    L: a Cholesky factor's lower triangle, row-major (``cho_factor`` 's, lower; its upper
    triangle is not read), B Fortran-ordered. A column starting at row l costs a solve
    with the trailing triangle ``L[l:, l:]`` (``(n - l)^2`` flops), in place, a BLAS
    ``trsv`` each: a substitution of a few columns is bound by the factor's reading, and
    OpenBLAS's ``trsm`` packs the whole triangle first for 2 columns as for 20. On the 306k
    bar's 1,107-row group, its cache flushed, a dense column and random points' (2, 4, 8,
    19 columns): 0.24, 0.37, 0.44, 0.65 ms against 0.49, 0.51, 0.61, 1.01 in one ``trtrs``.
    """
    n = len(B)
    ok = L.flags.c_contiguous and B.flags.f_contiguous and L.shape == (n, n)
    if not (ok and L.dtype == B.dtype == np.float64):
        raise ValueError(
            "forward_columns takes a row-major n x n factor, B Fortran-ordered (float64)"
        )
    lead = np.argmax(B != 0.0, axis=0)
    if n > per_column_rows:
        return _blocked(L, B, lead)
    lda, one, flops = ctypes.c_int(n), ctypes.c_int(1), 0.0
    for j, first in enumerate(lead.tolist()):
        if B[first, j] == 0.0:
            continue  # a zero column
        size = ctypes.c_int(n - first)
        at, x = L.ctypes.data + 8 * (first * n + first), B.ctypes.data + 8 * (j * n + first)
        # row-major lower L is column-major upper U = L^T: solve U^T x = b
        _DTRSV(b"U", b"T", b"N", ctypes.byref(size), at, ctypes.byref(lda), x, ctypes.byref(one))
        flops += float((n - first) ** 2)
    return flops


def equilibrated(C: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], float, tuple]:
    """LU factors of ``C`` equilibrated, their reciprocal condition number, the scaling.

    Rows then columns scaled by powers of two (exact; :attr:`Correction.scale`). A
    correction of points (coupled by +-1) beside other columns (coupled by about the
    penalty) has rows and columns of scales 1e9 apart: unscaled, the LU and its condition
    estimate read their ratio (1e17 where the scaled matrix has 1e9).
    """
    rows = _powers(np.abs(C).max(axis=1))
    cols = _powers(np.abs(rows[:, None] * C).max(axis=0))
    C = rows[:, None] * C * cols
    factors = sla.lu_factor(C, check_finite=False)
    rcond, _ = sla.lapack.dgecon(factors[0], np.abs(C).sum(axis=0).max(), norm="1")
    return factors, float(rcond), (rows, cols)


def _powers(largest: np.ndarray) -> np.ndarray:
    """Powers of two that bring ``largest`` into [0.5, 1)."""
    return np.ldexp(1.0, -np.frexp(largest)[1])


def _blocked(L: np.ndarray, B: np.ndarray, lead: np.ndarray) -> float:
    """:func:`forward_columns` block by block, the triangle read once for every column.

    The columns in order of their first row: a block's rows are solved for the columns
    started by then and subtracted from the rows below (one product), ``(n - first row)^2``
    flops a column.
    """
    n = len(B)
    order = np.argsort(lead, kind="stable")
    X, started, flops = np.asfortranarray(B[:, order]), lead[order] // BLOCK, 0.0
    for k, top in enumerate(range(0, n, BLOCK)):
        end, a = min(top + BLOCK, n), int(np.searchsorted(started, k, "right"))
        if not a:
            continue
        diagonal = L[top:end, top:end].T  # its upper factor's block (copied: small)
        X[top:end, :a] = sla.lapack.dtrtrs(diagonal, X[top:end, :a], lower=0, trans=1)[0]
        X[end:, :a] -= L[end:, top:end] @ X[top:end, :a]
        flops += float((n - top) * (end - top) * a)
    B[:, order] = X
    return flops


def local_rows(blocks, sizes: dict, rows: np.ndarray, at: dict) -> np.ndarray:
    """Rows of the joined numbering (sorted; ``at``: each block's slice of it) as a group's.

    The group's rows are its ``blocks`` one after the other; -1: a row not in them.
    """
    local, offset = np.full(len(rows), -1), 0
    for block in blocks:
        if block in at:
            lo, hi = np.searchsorted(rows, (at[block].start, at[block].stop))
            local[lo:hi] = rows[lo:hi] - at[block].start + offset
        offset += sizes[block]
    return local


def point_columns(
    V: sp.csc_array, at: list[tuple[Block, slice]]
) -> tuple[dict[Block, np.ndarray], np.ndarray]:
    """Points' columns V as a correction's piece: the dofs they touch per block, and U."""
    V = sp.csr_array(V)
    nonzero = np.unique(sp.coo_array(V).row)
    dofs = {}
    for b, rows in at:
        J = nonzero[(nonzero >= rows.start) & (nonzero < rows.stop)] - rows.start
        if len(J):
            dofs[b] = J
    return dofs, V[nonzero].toarray()


@dataclass
class PointCorrection(Correction):
    """A Woodbury correction whose columns are contact points' rows (sparse).

    Attributes:
        rows: The rows where the points' columns are non-zero (over the surface blocks
            ``at`` holds, one after the other), sorted.
        values: The columns on those rows (dense: a point's row has a node's few dofs).
        at: Each of those blocks and its rows.
        last: Per last-level group, the columns that reach it (a mask) and their forward
            elimination ``L^-1 V``, when no column reaches an earlier level: a corrected
            solve is then one pass (:meth:`PointwiseSurface.solve`). None: two passes.
    """

    rows: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    values: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    at: list[tuple[Block, slice]] = field(default_factory=list)
    cholesky: tuple[np.ndarray, bool] | None = None
    last: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
    slots: np.ndarray | None = None  # its columns in the cache, G made at the first solve

    def factorise(self) -> None:
        """Factors of ``I + D G``: Cholesky if every point changed the same way, else LU.

        With one sign s, ``I + s G`` is symmetric and positive definite (s = -1: G of
        points the factorised matrix holds is below the identity), and Cholesky is half
        an LU's work; a release loses digits to round-off, which the refinement gives back.
        """
        if len(self.D) and np.all(self.D == self.D[0]):
            C = np.eye(self.rank) + self.D[0] * self.G
            factor, info = sla.lapack.dpotrf(C, lower=1, clean=0)  # no wrapper's copies
            if info == 0:  # else not positive definite in round-off: LU
                norm = np.abs(C).sum(axis=0).max()
                rcond, _ = sla.lapack.dpocon(factor, norm, uplo="L")
                self.cholesky = (factor, True)
                self.capacitance = (factor, np.zeros(0))  # marks it factorised
                self.conditioned = float(rcond)
                return
        if not self.pieces:
            self.capacitance, self.conditioned = capacitance(self.D, self.G)
            return
        C = np.eye(self.rank) + self.D[:, None] * self.G
        self.capacitance, self.conditioned, self.scale = equilibrated(C)

    def solve(self, y: np.ndarray) -> np.ndarray:
        """``(I + D G)^-1 y``."""
        if self.cholesky is not None:
            return sla.lapack.dpotrs(self.cholesky[0], y, lower=1)[0]
        return super().solve(y)

    def points_of(self, x: dict[str, np.ndarray]) -> np.ndarray:
        """``V^T x``."""
        return self.values.T @ np.concatenate([x[b] for b, _ in self.at])[self.rows]

    def projected(self, x: dict[str, np.ndarray]) -> np.ndarray:
        """``D V^T x``, then the pieces' ``D U^T x_J`` (other regions' changes) if any."""
        points = self.points_of(x)
        if not self.pieces:
            return self.D * points
        p = len(points)
        rest = Correction(self.pieces, self.D[p:]).projected(x)
        return np.concatenate([self.D[:p] * points, rest])

    def shifted(self, g: dict[str, np.ndarray], z: np.ndarray) -> dict[str, np.ndarray]:
        """``g - V z``, and ``- E U z`` for the pieces if any."""
        out = {b: v.copy() for b, v in g.items()}
        p = self.values.shape[1]
        Vz = np.zeros(self.at[-1][1].stop if self.at else 0)
        Vz[self.rows] = self.values @ z[:p]
        for b, rows in self.at:
            out[b] -= Vz[rows]
        return Correction(self.pieces).shifted(out, z[p:]) if self.pieces else out
