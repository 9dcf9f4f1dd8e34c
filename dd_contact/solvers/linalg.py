"""Factorisations that count their work: MUMPS for sparse blocks.

Every factorisation and solve is appended to a :class:`WorkLog` (kind, size, right-hand
sides, wall time, MUMPS's flop count), so a run can report what it did.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.sparse as sp

__all__ = [
    "SingularMatrixError",
    "SparseCholesky",
    "WorkLog",
    "WorkRecord",
    "petsc_matrix",
]


class SingularMatrixError(RuntimeError):
    """A factorisation met a singular matrix: part of the model is not held."""


@dataclass
class WorkRecord:
    """One factorisation or solve."""

    block: str
    kind: str  # "sparse_factor", "sparse_solve", ...
    size: int
    nrhs: int
    seconds: float
    flops: float | None = None


@dataclass
class WorkLog:
    """All factorisations and solves of a run."""

    records: list[WorkRecord] = field(default_factory=list)

    def add(self, *args, **kwargs) -> None:
        """Append a :class:`WorkRecord`."""
        self.records.append(WorkRecord(*args, **kwargs))

    def count(self, kind: str, block: str | None = None) -> int:
        """Number of records of ``kind`` (for ``block``, if given)."""
        return sum(r.kind == kind and block in (None, r.block) for r in self.records)

    def summary(self) -> dict[str, dict[str, float]]:
        """Per kind: count, total seconds, total flops."""
        out: dict[str, dict[str, float]] = {}
        for r in self.records:
            s = out.setdefault(r.kind, {"count": 0, "seconds": 0.0, "flops": 0.0})
            s["count"] += 1
            s["seconds"] += r.seconds
            s["flops"] += r.flops or 0.0
        return out


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
    A = PETSc.Mat().create(comm=comm)
    A.setSizes(((local_rows, global_size), (local_rows, global_size)))
    A.setType(PETSc.Mat.Type.AIJ)
    A.setPreallocationCOO(rows.astype(PETSc.IntType), cols.astype(PETSc.IntType))
    A.setValuesCOO(values.astype(PETSc.ScalarType), addv=PETSc.InsertMode.ADD_VALUES)
    A.assemble()
    return A


class SparseCholesky:
    """A MUMPS Cholesky factorisation of an SPD PETSc matrix.

    Args:
        A: The matrix (symmetric positive definite).
        log: Where to record the work.
        block: Name of the block, for the log.
    """

    def __init__(self, A: PETSc.Mat, log: WorkLog, block: str):
        self.A, self.log, self.block = A, log, block
        A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        A.setOption(PETSc.Mat.Option.SPD, True)
        self.ksp = PETSc.KSP().create(A.comm)
        self.ksp.setOperators(A)
        self.ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = self.ksp.getPC()
        pc.setType(PETSc.PC.Type.CHOLESKY)
        pc.setFactorSolverType("mumps")
        pc.setFactorSetUpSolverType()
        pc.getFactorMatrix().setMumpsIcntl(24, 1)  # detect null pivots: singular fails loudly
        self._factorise()

    def refactorise(self) -> None:
        """Numeric re-factorisation after the matrix values changed (same pattern)."""
        self.ksp.setOperators(self.A)
        self._factorise()

    def _factorise(self) -> None:
        start = time.perf_counter()
        self.ksp.setUp()
        factor = self.ksp.getPC().getFactorMatrix()
        info = factor.getMumpsInfog(1)
        if info < 0:
            raise SingularMatrixError(
                f"MUMPS factorisation of block {self.block!r} failed (INFOG(1) = {info}); "
                "the matrix is singular or not positive definite"
            )
        if factor.getMumpsInfog(28) > 0:
            raise SingularMatrixError(
                f"block {self.block!r} is singular ({factor.getMumpsInfog(28)} null pivots): "
                "part of the model can move freely; check its supports, ties and contacts"
            )
        self.log.add(
            self.block,
            "sparse_factor",
            self.A.getSize()[0],
            0,
            time.perf_counter() - start,
            factor.getMumpsRinfog(3),
        )

    def solve(self, b: PETSc.Vec) -> PETSc.Vec:
        """Forward/back substitution for one right-hand side."""
        x = b.duplicate()
        start = time.perf_counter()
        self.ksp.solve(b, x)
        self.log.add(self.block, "sparse_solve", b.getSize(), 1, time.perf_counter() - start)
        return x

    def destroy(self) -> None:
        """Free the factorisation."""
        self.ksp.destroy()


def coo_of(matrix: sp.sparray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row, column and value arrays of a sparse matrix."""
    c = sp.coo_array(matrix)
    return c.row, c.col, c.data
