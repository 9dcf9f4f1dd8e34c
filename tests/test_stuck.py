"""Friction in the orders: stuck Cholesky factors, the slip corrected (solvers/stuck.py)."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
from test_pairs import GAP, H_A, H_B, SIDE, TILT, _at, _blocks

import dd_contact as dc
from dd_contact.friction import SLIP
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.friction import sliding_scene
from dd_contact.problem import StaticProblem
from dd_contact.solvers import lowrank
from dd_contact.solvers.lowrank import LowRankSurface
from dd_contact.solvers.pointwise import PointwiseSurface
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


# -- friction against an obstacle and a frictionless pair in one correction ------------------
PUSH = 2e-5  # the wall's push into A's side per unit of time


def _mixed(enabled: bool, monkeypatch, mu: float = MU, tilt: float = 0.0):
    """tests/test_pairs.py's blocks, B pressed down unevenly onto A, A's side on a wall with
    friction ``mu`` (its normal tilted by ``tilt`` in z: the contact spreads down A's side),
    in w-u (one group): u, the changes, the work log and the surface."""
    monkeypatch.setattr(LowRankSurface, "enabled", enabled)
    cells = ("hexahedron", (4, 4, 2)), ("tetrahedron", (3, 3, 2))
    subdomains, _, a, b, B = _blocks(*cells, False, gap=GAP)
    press = lambda x: np.stack([0 * x[0], 0 * x[0], -TILT * x[0] * x[1]])  # noqa: E731
    B.fix(_at(2, H_A + GAP + H_B), [2], press)
    motion = lambda t: (-PUSH * t, 0.0, 0.0)  # noqa: E731
    wall = Plane([SIDE - PUSH, 0, H_A], [-1, 0, tilt], motion=motion)
    side = dc.ContactInterface.from_boundary(subdomains[0], _at(0, SIDE), wall, friction=mu)
    scene = dc.Scene(MPI.COMM_SELF, subdomains, None, [dc.ContactPair(a, b), side])
    with pytest.warns(dc.errors.CoarseContactWarning), StaticProblem(scene, "w-u") as problem:
        for step in range(1, 4):
            problem.solve(float(step))
        u = np.concatenate([s.u.x.array for s in scene.subdomains])
        return u, dict(problem.changes), problem.work, problem.solver.surface


def test_a_frictionless_pair_beside_friction_is_corrected_point_by_point(monkeypatch):
    """The pair's changes join the slip's correction as its points' rows: no group is
    factorised again, and the answers are the re-factorised ones."""
    u_lu, changes_lu, _, _ = _mixed(False, monkeypatch)
    u, changes, work, surface = _mixed(True, monkeypatch)
    assert changes == changes_lu and min(changes.values()) >= 5
    assert np.linalg.norm(u - u_lu) <= 1e-9 * np.linalg.norm(u_lu)
    assert isinstance(surface, StuckSurface) and not surface.exact
    factorised = [r for r in work.records if r.kind == "dense_factor"]
    updates = [r for r in work.records if r.kind == "dense_update"]
    assert len(factorised) == 1 and len(updates) == changes["gamma"] + 4  # and 4 step starts
    # the last correction: unit columns on the wall's dofs only (those the slip deviates
    # on among them), and one column per point of the pair, those that differ from the
    # flags the factors hold among them (not the dofs those points touch)
    c = surface.correction
    units = [dofs for (dofs, _), p in zip(c.pieces, c.points, strict=True) if p is None]
    points = np.concatenate([p for p in c.points if p is not None])
    assert {str(b) for dofs in units for b in dofs} == {"w:contact"}
    deviating = surface._deviating(surface.held)["w:contact"]
    assert set(deviating) <= {j for dofs in units for j in dofs["w:contact"]}
    assert set(np.flatnonzero(surface.flags()[1])) <= set(points) and len(points) > 0
    assert updates[-1].size == c.rank == sum(len(d["w:contact"]) for d in units) + len(points)


def test_a_pair_beside_a_frictionless_obstacle_keeps_its_points(monkeypatch):
    """A frictionless wall whose normals may turn (no point rows: taken as such here) has its
    changes join the pair's point correction as the eigenvectors of their change: the group
    is factorised once, the pair's points each eliminated once, and the answers are the
    re-factorised ones."""
    monkeypatch.setattr(Plane, "fixed_normals", property(lambda self: False))
    u_lu, changes_lu, _, _ = _mixed(False, monkeypatch, 0.0, -3 * PUSH)
    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    u, changes, work, surface = _mixed(True, monkeypatch, 0.0, -3 * PUSH)
    assert changes == changes_lu and changes["contact"] >= 2 and changes["gamma"] >= 10
    assert np.linalg.norm(u - u_lu) <= 1e-9 * np.linalg.norm(u_lu)
    assert isinstance(surface, PointwiseSurface) and not isinstance(surface, StuckSurface)
    factorised = [r for r in work.records if r.kind == "dense_factor"]
    updates = [r for r in work.records if r.kind == "dense_update"]
    assert len(factorised) == 1 and len(updates) >= changes["gamma"]  # and step starts
    # the points eliminated once each, kept while the factors last; the wall's columns not
    assert sum(r.nrhs for r in updates) == len(surface._cached) == surface._cache.rank
    # the last correction: the points that differ from the factorised flags, and the
    # eigenvectors of the wall's change (on the wall's dofs only)
    c = surface.correction
    differing = int(np.count_nonzero(surface.flags()[1]))
    assert {str(b) for dofs, _ in c.pieces for b in dofs} == {"w:contact"}
    wall = sum(U.shape[1] for _, U in c.pieces)
    assert c.values.shape[1] == differing
    assert updates[-1].size == c.rank == differing + wall > differing


def test_a_pair_beside_a_fixed_wall_corrects_both_point_by_point(monkeypatch):
    """A plane's normals never turn, so its point rows go with its region: its changes and
    the pair's are all point columns (no eigen-pieces), with the re-factorised answers."""
    u_lu, changes_lu, _, _ = _mixed(False, monkeypatch, 0.0, -3 * PUSH)
    monkeypatch.setattr(LowRankSurface, "refactorise_seconds", lambda self, blocks: np.inf)
    u, changes, work, surface = _mixed(True, monkeypatch, 0.0, -3 * PUSH)
    assert changes == changes_lu and changes["contact"] >= 2 and changes["gamma"] >= 10
    assert np.linalg.norm(u - u_lu) <= 1e-9 * np.linalg.norm(u_lu)
    assert len([r for r in work.records if r.kind == "dense_factor"]) == 1
    c = surface.correction
    assert not c.pieces and c.values.shape[1] == c.rank == int(np.count_nonzero(surface.flags()[1]))
