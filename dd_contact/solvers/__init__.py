"""Solvers of the block system (14): FULL and (later) the block-elimination engine."""

from dd_contact.errors import SingularMatrixError
from dd_contact.solvers.full import MonolithicSolver
from dd_contact.solvers.linalg import SparseCholesky
from dd_contact.solvers.worklog import WorkLog, WorkRecord

__all__ = ["MonolithicSolver", "SingularMatrixError", "SparseCholesky", "WorkLog", "WorkRecord"]
