"""Friction in the orders: stuck Cholesky factors, the slip corrected (solvers/stuck.py)."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from dd_contact.friction import SLIP
from dd_contact.paper.verify.friction import sliding_scene
from dd_contact.problem import StaticProblem
from dd_contact.solvers import lowrank
from dd_contact.solvers.lowrank import LowRankSurface
from dd_contact.solvers.stuck import StuckSurface

MU, STEPS = 0.3, 12


def _slide(kind: str, algorithm: str) -> tuple[np.ndarray, StaticProblem, int]:
    """The sliding block's load steps: u, the problem (closed) and its most slipping points."""
    problem = StaticProblem(sliding_scene(kind, MU, MPI.COMM_SELF), algorithm=algorithm)
    friction = problem.analysis.zones[0].operator.friction
    slipping = 0
    for step in range(1, STEPS + 1):
        problem.solve(float(step))
        slipping = max(slipping, int(np.sum(friction.state == SLIP)))
    u = np.concatenate([s.u.x.array for s in problem.scene.subdomains])
    problem.close()
    return u, problem, slipping


def _kinds(problem) -> list[str]:
    return [r.kind for r in problem.work.records if r.block != lowrank.UPDATES]


@pytest.mark.parametrize(("kind", "algorithm"), [("single", "w-u"), ("interface", "v-w-u")])
def test_slip_is_corrected_on_stuck_factors_with_the_lu_answers(kind, algorithm, monkeypatch):
    """LU factors' answers to round-off, with fewer factorisations.

    Round-off: the penalty's (the orders differ from FULL by 4-7e-10 here, and as much
    from the LU path: tests/test_friction.py holds 1e-8).
    """
    u, problem, slipping = _slide(kind, algorithm)
    assert isinstance(problem.solver.surface, StuckSurface) and not problem.solver.surface.exact
    monkeypatch.setattr(LowRankSurface, "enabled", False)  # every change re-factorised, LU
    u_lu, plain, _ = _slide(kind, algorithm)
    assert not isinstance(plain.solver.surface, StuckSurface)
    assert slipping >= 5 and plain.changes["gamma"] == problem.changes["gamma"] >= 3
    assert np.linalg.norm(u - u_lu) <= 1e-8 * np.linalg.norm(u_lu)
    assert _kinds(problem).count("dense_factor") < _kinds(plain).count("dense_factor")


def test_an_inaccurate_correction_falls_back_to_lu(monkeypatch):
    """A corrected solve whose backward error stays above the tolerance: LU from then on."""
    monkeypatch.setattr(lowrank, "UPDATE_TOLERANCE", -1.0)  # no corrected solve is accepted
    u, problem, _ = _slide("single", "w-u")
    assert problem.solver.surface.exact
    monkeypatch.setattr(LowRankSurface, "enabled", False)
    u_lu, _, _ = _slide("single", "w-u")
    assert np.linalg.norm(u - u_lu) <= 1e-8 * np.linalg.norm(u_lu)


def test_the_stuck_matrix_is_symmetric_and_differs_at_the_slipping_points_only():
    problem = StaticProblem(sliding_scene("single", MU, MPI.COMM_SELF), algorithm="w-u")
    operator = problem.analysis.zones[0].operator
    for step in range(1, 11):
        problem.solve(float(step))
    matrix = operator.matrix(operator.friction.state != 0)  # the decided state's active set
    stuck = operator.stuck()
    slipping = np.flatnonzero(operator.friction.state == SLIP)
    assert len(slipping) >= 10
    assert abs(stuck - stuck.T).max() <= 1e-15 * abs(stuck).max()
    delta = (matrix - stuck).tocoo()
    delta.eliminate_zeros()
    assert set(delta.row // 3) == set(slipping)  # nodal points: 3 dofs each
    assert abs(matrix - matrix.T).max() > 1e-3 * abs(matrix).max()  # the slip's, not stuck's
    problem.close()
