"""FULL: the block system (14) assembled into one matrix and factorised as a whole.

This is the classical approach and the baseline the decomposition orders are measured
against: every change of the contact state re-factorises the whole matrix. It is also the
reference for the orders' correctness: the monolithic solution.
"""

from __future__ import annotations

from collections.abc import Sequence

from petsc4py import PETSc

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockKeyed, BlockSystem, ContactRegion, refuse_unsolvable
from dd_contact.parallel import any_rank
from dd_contact.solvers.linalg import (
    PatternedMatrix,
    SparseCholesky,
    SparseStatistics,
    sparse_statistics,
)
from dd_contact.solvers.unsymmetric import SparseLU
from dd_contact.solvers.worklog import WorkLog

__all__ = ["MonolithicSolver", "monolithic_statistics"]


class MonolithicSolver:
    """Block system (14) as one distributed PETSc matrix, plus contact terms.

    Blocks are numbered rank by rank (all blocks of rank 0 first), so that each rank's rows
    form one contiguous range, as PETSc requires. Each contact region reserves its
    pattern once; :meth:`set_contact` changes its values, and the next :meth:`solve`
    re-factorises (numerically; the symbolic analysis is kept).

    Args:
        comm: Communicator.
        system: This rank's pieces of the (constrained) block system.
        contacts: This rank's contact regions.
        log: Where factorisations and solves are recorded.
    """

    def __init__(
        self,
        comm,
        system: BlockSystem,
        contacts: Sequence[ContactRegion],
        log: WorkLog,
    ):
        refuse_unsolvable(contacts, monolithic=True)
        self.comm, self.system, self.log = comm, system, log
        order = sorted(system.sizes, key=lambda b: system.owners[b])
        self.offsets: dict[str, int] = {}
        start = 0
        for name in order:
            self.offsets[name] = start
            start += system.sizes[name]
        self.size = start
        self.local_size = sum(system.sizes[b] for b in order if system.owners[b] == comm.rank)
        base = system.triplets(self.offsets)
        self.matrix = PatternedMatrix(
            comm,
            self.local_size,
            self.size,
            base,
            [region.shifted(self.offsets) for region in contacts],
        )
        self._factor: SparseCholesky | None = None
        #: MUMPS's LU where friction makes the matrix unsymmetric, Cholesky otherwise.
        self._kind = (
            SparseLU if any_rank(comm, any(not r.symmetric for r in contacts)) else SparseCholesky
        )
        self._last: dict[str, np.ndarray] = {}

    def set_contact(self, key: str, matrix: sp.csr_array, active: np.ndarray | None = None) -> None:
        """Replace the contact matrix of region ``key`` (surface dof numbering).

        ``active`` is not used: the matrix is factorised whole.
        """
        self.matrix.set_contact(key, matrix)

    def _refactorise(self) -> None:
        """Collective: push new values to PETSc and factorise (once per contact change)."""
        if self._factor is not None and not any_rank(self.comm, self.matrix.dirty):
            return
        self.matrix.push()
        if self._factor is None:
            assert self.matrix.A is not None  # a PETSc matrix: not upper_coo
            self._factor = self._kind(self.matrix.A, self.log, "FULL")
        else:
            self._factor.refactorise()

    def solve(self, rhs: BlockKeyed[np.ndarray]) -> dict[str, np.ndarray]:
        """Solve with this rank's right-hand-side contributions; every rank gets every block."""
        with self.log.solving():
            return self._solve(rhs)

    def _solve(self, rhs: BlockKeyed[np.ndarray]) -> dict[str, np.ndarray]:
        self._refactorise()
        assert self.matrix.A is not None
        b = self.matrix.A.createVecRight()
        for name, vector in rhs.items():
            idx = np.arange(len(vector), dtype=PETSc.IntType) + self.offsets[name]
            # petsc4py's stubs (here and below): values as a Sequence (an ndarray is not), the
            # insert mode as InsertMode (its values are ints)
            b.setValues(idx, vector, addv=PETSc.InsertMode.ADD_VALUES)  # type: ignore[arg-type]
        b.assemble()
        x = self._apply(b)
        if self.comm.size == 1:  # x holds every row already
            values = x.getArray(readonly=True).copy()
        else:
            scatter, x_all = PETSc.Scatter.toAll(x)
            scatter.scatter(x, x_all, addv=PETSc.InsertMode.INSERT_VALUES)  # type: ignore[arg-type]
            values = x_all.getArray().copy()
            scatter.destroy()
            x_all.destroy()
        x.destroy()
        b.destroy()
        self._last = {
            name: values[off : off + self.system.sizes[Block.parse(name)]]
            for name, off in self.offsets.items()
        }
        return self._last

    def _apply(self, b: PETSc.Vec) -> PETSc.Vec:
        """A^-1 b, a new vector (the factor's substitution; a subclass may iterate instead)."""
        assert self._factor is not None  # _refactorise came first
        return self._factor.solve(b)

    def finish(self) -> dict[str, np.ndarray]:
        """Every block of the last solution (nothing is left to back-substitute)."""
        return self._last

    @property
    def rhs_offset(self) -> dict[str, np.ndarray]:
        """Nothing is subtracted from the right-hand side."""
        return {}

    def analyse(self) -> SparseStatistics:
        """Collective: MUMPS's analysis of the matrix (contact patterns included)."""
        self.matrix.push()
        assert self.matrix.A is not None  # a PETSc matrix: not upper_coo
        return sparse_statistics(self.matrix.A)

    def rebase(self) -> None:
        """A checkpoint: nothing to drop (each change re-factorises the whole matrix)."""

    def destroy(self) -> None:
        """Free PETSc objects."""
        if self._factor is not None:
            self._factor.destroy()
        self.matrix.destroy()


def monolithic_statistics(
    comm, system: BlockSystem, contacts: Sequence[ContactRegion]
) -> SparseStatistics:
    """Collective: MUMPS's analysis of the matrix FULL factorises (contact patterns included)."""
    solver = MonolithicSolver(comm, system, contacts, WorkLog())
    stats = solver.analyse()
    solver.destroy()
    return stats
