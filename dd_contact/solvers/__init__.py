"""Solvers of the block system (14): FULL and (later) the block-elimination engine."""

from dd_contact.solvers.full import MonolithicSystem
from dd_contact.solvers.linalg import SparseCholesky, WorkLog, WorkRecord

__all__ = ["MonolithicSystem", "SparseCholesky", "WorkLog", "WorkRecord"]
