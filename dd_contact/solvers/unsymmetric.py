"""LU factorisations for what friction makes unsymmetric, and where they are needed.

A slipping contact point gives its contact block an unsymmetric matrix
(:mod:`dd_contact.friction`). The subdomains never hold one (a contact interface's block is
on the surface). The orders factorise friction against obstacles with every point sticking
and correct for the slip (:mod:`dd_contact.solvers.stuck`); where they do not (a contact
pair, low-rank corrections switched off, a correction that failed), the dense surface group
holding the block is factorised with LU (:class:`DenseLU`), and so is every group its
elimination reaches (:func:`lu_groups`). FULL takes MUMPS's LU (:class:`SparseLU`) only when
some region has friction: without it everything stays Cholesky, bit for bit as before.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterable

from petsc4py import PETSc

import numpy as np
import scipy.linalg as sla

from dd_contact.blocks import Block
from dd_contact.errors import SingularMatrixError
from dd_contact.solvers.dense import DenseCholesky
from dd_contact.solvers.linalg import SparseCholesky
from dd_contact.solvers.schedule import Schedule
from dd_contact.solvers.worklog import WorkLog

__all__ = ["DenseLU", "SparseLU", "lu_groups"]


class SparseLU(SparseCholesky):
    """A MUMPS LU factorisation of a PETSc matrix that need not be symmetric."""

    PC_TYPE, SYMMETRIC = PETSc.PC.Type.LU, False


class DenseLU(DenseCholesky):
    """A LAPACK LU factorisation (getrf, partial pivoting) of a dense matrix.

    Args:
        A: The matrix; overwritten by the factor.
        log: Where to record the work.
        block: Name of the block, for the log.
    """

    def __init__(self, A: np.ndarray, log: WorkLog, block: str):
        self.log, self.block, self.size = log, block, A.shape[0]
        start = time.perf_counter()
        with warnings.catch_warnings():  # a zero pivot is the error below, said once
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            lu, piv = sla.lu_factor(A, overwrite_a=True, check_finite=False)
        pivots = np.abs(np.diag(lu))
        if not (np.all(np.isfinite(pivots)) and pivots.min(initial=1.0) > 0.0):
            raise SingularMatrixError(
                f"dense block {block!r} is singular: part of the model can move freely; "
                "check its supports, ties and contacts"
            )
        self.lu = (lu, piv)
        n = self.size
        log.add(block, "dense_factor", n, 0, time.perf_counter() - start, 2.0 * n**3 / 3.0)

    def congruence(self, B: np.ndarray, what: str = "", left: np.ndarray | None = None):
        """``left^T A^-1 B`` (``left`` defaults to B): what eliminating the group subtracts."""
        X = self.solve(B, what)
        start = time.perf_counter()
        out = (B if left is None else left).T @ X
        n, m = B.shape
        self.log.add(
            self.block, "dense_product", n, m, time.perf_counter() - start, 2.0 * n * m * m, what
        )
        return out

    def substitute(self, B: np.ndarray) -> np.ndarray:
        """``A^-1 B`` by the factor (getrs); :meth:`DenseCholesky.solve` times and logs it."""
        return sla.lu_solve(self.lu, B, check_finite=False)


def lu_groups(schedule: Schedule, unsymmetric: Iterable[Block]) -> set[str]:
    """The surface groups whose matrix is unsymmetric: LU, not Cholesky.

    A group holding an unsymmetric contact block is; eliminating it leaves its neighbours'
    pairs unsymmetric (``C A^-1 B`` with ``C != B^T``), so theirs are too, level by level.
    """
    blocks, out = set(unsymmetric), set()
    for level in schedule.groups:
        for group in level:
            if blocks & set(group.blocks):
                out.add(group.name)
                blocks |= set(group.neighbours)
    return out
