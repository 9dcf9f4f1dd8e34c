"""FULL: the block system (14) assembled into one matrix and factorised as a whole.

This is the classical approach and the baseline the decomposition orders are measured
against. It is also the reference for their correctness: the monolithic solution.
"""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np

from dd_contact.assembly import BlockSystem
from dd_contact.solvers.linalg import SparseCholesky, WorkLog, coo_of, petsc_matrix

__all__ = ["MonolithicSystem"]


def _cat(arrays: list[np.ndarray], dtype) -> np.ndarray:
    return np.concatenate(arrays).astype(dtype) if arrays else np.zeros(0, dtype)


class MonolithicSystem:
    """Block system (14) as one distributed PETSc matrix.

    Blocks are numbered rank by rank (all blocks of rank 0 first), so that each rank's rows
    form one contiguous range, as PETSc requires.

    Args:
        comm: Communicator.
        system: This rank's pieces of the block system.
    """

    def __init__(self, comm, system: BlockSystem):
        self.comm = comm
        self.system = system
        order = sorted(system.sizes, key=lambda b: system.owners[b])
        self.offsets, start = {}, 0
        for name in order:
            self.offsets[name] = start
            start += system.sizes[name]
        self.size = start
        self.local_size = sum(system.sizes[b] for b in order if system.owners[b] == comm.rank)
        rows, cols, vals = [], [], []
        for (rb, cb), block in system.matrices.items():
            r, c, v = coo_of(block)
            r, c = r + self.offsets[rb], c + self.offsets[cb]
            rows.append(r), cols.append(c), vals.append(v)
            if rb != cb:  # the transpose is implied
                rows.append(c), cols.append(r), vals.append(v)
        self.A = petsc_matrix(
            comm,
            self.local_size,
            self.size,
            _cat(rows, np.int64),
            _cat(cols, np.int64),
            _cat(vals, np.float64),
        )
        self.b = self.A.createVecRight()
        for name, vector in system.rhs.items():
            idx = np.arange(len(vector), dtype=PETSc.IntType) + self.offsets[name]
            self.b.setValues(idx, vector, addv=PETSc.InsertMode.ADD_VALUES)
        self.b.assemble()

    def solve(self, log: WorkLog) -> dict[str, np.ndarray]:
        """Factorise and solve; every rank gets every block of the solution."""
        factor = SparseCholesky(self.A, log, "FULL")
        x = factor.solve(self.b)
        factor.destroy()
        scatter, x_all = PETSc.Scatter.toAll(x)
        scatter.scatter(x, x_all, addv=PETSc.InsertMode.INSERT_VALUES)
        values = x_all.getArray().copy()
        scatter.destroy(), x_all.destroy(), x.destroy()
        return {
            name: values[off : off + self.system.sizes[name]] for name, off in self.offsets.items()
        }

    def destroy(self) -> None:
        """Free PETSc objects."""
        self.A.destroy()
        self.b.destroy()
