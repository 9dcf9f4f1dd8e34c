"""Side solves of a transient start, outside the contact iteration.

Both factorise a matrix once, solve, record the work in the run's :class:`WorkLog` and free
their PETSc objects before returning:

* :func:`solve_mass`: ``M a = r`` on one subdomain (the initial acceleration), with the
  prescribed dofs eliminated as in the effective matrix;
* :func:`surfaces_in_equilibrium`: the massless interface and contact interfaces in
  equilibrium with a given subdomain displacement (one FULL solve of the block system).
"""

from __future__ import annotations

from collections.abc import Mapping

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockSystem
from dd_contact.solvers.full import MonolithicSolver
from dd_contact.solvers.linalg import SparseCholesky, coo_of, petsc_matrix
from dd_contact.solvers.worklog import WorkLog

__all__ = ["solve_mass", "surfaces_in_equilibrium"]


def solve_mass(
    mass_matrix: sp.csr_array,
    fixed_dofs: np.ndarray,
    rhs: np.ndarray,
    log: WorkLog,
    name: str,
) -> np.ndarray:
    """Solve ``M a = rhs`` with the dofs ``fixed_dofs`` prescribed to zero.

    A subdomain's mass matrix is held whole by its owner rank, so this runs on that rank
    alone (``MPI.COMM_SELF``). The factorisation is logged as block ``mass:<name>``.

    Args:
        mass_matrix: M of one subdomain.
        fixed_dofs: Dofs eliminated (their rows and columns become the identity).
        rhs: Right-hand side (zero on ``fixed_dofs``).
        log: Where the factorisation and the solve are recorded.
        name: The subdomain's name.
    """
    n = mass_matrix.shape[0]
    block = Block("u", name)
    mass = BlockSystem({block: n}, {block: 0}, {(block, block): mass_matrix})
    mass.constrain(block, fixed_dofs, np.zeros(fixed_dofs.size))
    row, col, val = coo_of(mass.block(block, block))
    A = petsc_matrix(MPI.COMM_SELF, n, n, row, col, val)
    factor = b = a = None
    try:
        factor = SparseCholesky(A, log, f"mass:{name}")
        b = A.createVecRight()
        b.array[:] = rhs
        a = factor.solve(b)
        return a.array.copy()
    finally:
        for obj in (a, b, factor, A):
            if obj is not None:
                obj.destroy()


def surfaces_in_equilibrium(
    comm: MPI.Comm, system: BlockSystem, u0: Mapping[Block, np.ndarray], log: WorkLog
) -> dict[str, np.ndarray]:
    """Interface and contact-interface displacements in equilibrium with given u (collective).

    Args:
        comm: Communicator of the block system.
        system: This rank's pieces of the unconstrained block system (not changed).
        u0: Displacement of every owned subdomain block.
        log: Where the FULL factorisation and solve are recorded.

    Returns:
        Every ``v:`` and ``w:`` block, on every rank.
    """
    system = system.copy()
    for block, values in u0.items():
        system.constrain(block, np.arange(len(values), dtype=np.int32), values)
    solver = MonolithicSolver(comm, system, (), log)
    try:
        x = solver.solve(system.rhs)
    finally:
        solver.destroy()
    return {k: v for k, v in x.items() if Block.parse(k).kind != "u"}
