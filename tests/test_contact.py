"""Contact: obstacles, the contact operators, the contact iteration and the closed forms."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import meshes
from dd_contact.errors import ContactCycleWarning, ContactIterationError
from dd_contact.iteration import ContactIteration, ContactSettings
from dd_contact.paper import verify


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


# -- obstacles -----------------------------------------------------------------------------
def test_obstacle_gaps_and_normals():
    x = np.array([[0.0, 0.0, 2.0], [3.0, 4.0, 0.0]])
    s, n = dd.Plane([0, 0, 1], [0, 0, 2]).gap_normal(x)
    assert np.allclose(s, [1.0, -1.0]) and np.allclose(n, [[0, 0, -1]] * 2)
    s, n = dd.Sphere([0, 0, 0], 1.0).gap_normal(x)
    assert np.allclose(s, [1.0, 4.0]) and np.allclose(n[1], [-0.6, -0.8, 0])
    # A pin along z through the origin, radius 1: the body lies around it.
    s, n = dd.Cylinder([0, 0, 5], [0, 0, 1], 1.0).gap_normal(x)
    assert np.allclose(s, [-1.0, 4.0]) and np.allclose(n[1], [-0.6, -0.8, 0])
    moving = dd.Plane([0, 0, 0], [0, 0, 1], motion=lambda t: [0, 0, 0.5 * t])
    assert np.allclose(moving.gap_normal(x, t=2.0)[0], [1.0, -1.0])


def test_an_obstacle_at_rest_is_evaluated_once_a_moving_one_every_time():
    import scipy.sparse as sp

    from dd_contact.contact import ContactOperator, ContactPoints

    x = np.array([[0.0, 0.0, 0.1], [0.5, 0.2, 0.3]])
    points = ContactPoints(x, np.ones(2), sp.eye_array(2, format="csr"), np.ones(2))
    plane = dd.Plane((0, 0, 0), (0, 0, 1))
    op = ContactOperator(points, plane, 1e-3)
    G = op.G
    op.update(1.0)
    assert op.G is G and op.t == 1.0  # kept: the same gap and normals at every time
    plane.motion = lambda t: (0.0, 0.0, t)  # moving from now on: evaluated again
    op.update(0.05)
    np.testing.assert_allclose(op.gap, plane.gap_normal(x, 0.05)[0])
    assert op.G is not G
    down = lambda x, t: np.tile([0, 0, -1.0], (len(x), 1))  # noqa: E731
    user = dd.UserObstacle(lambda x, t: x[:, 2] - t, down)
    op = ContactOperator(points, user, 1e-3)
    op.update(0.05)  # a gap_normal of its own may depend on t
    np.testing.assert_allclose(op.gap, x[:, 2] - 0.05)


def test_nodal_products_are_the_sparse_ones_bit_for_bit():
    import scipy.sparse as sp

    from dd_contact.contact import ContactOperator, ContactPoints

    rng = np.random.default_rng(3)
    x = rng.uniform(0.1, 1.0, (50, 3))
    points = ContactPoints(
        x, rng.uniform(0.5, 1.0, 50), sp.eye_array(50, format="csr"), np.ones(50)
    )
    sphere = dd.Sphere((0.0, 0.0, -1.0), 1.0, motion=lambda t: (0.0, 0.0, 0.1 * t))
    op = ContactOperator(points, sphere, 1e-3)
    active = rng.uniform(size=50) < 0.5
    for t in (0.0, 0.3):  # moving: G rebuilt, the products follow it
        op.update(t)
        w = rng.standard_normal(150)
        assert np.array_equal(op.penetration(w), op.G @ w - op.gap)  # the same bits
        rhs = op.G.T @ np.where(active, op.points.weight * op.gap / op.epsilon, 0.0)
        assert np.array_equal(op.rhs(active), rhs)
        op.rhs(active)[:] = 1.0  # the caller's copy: the kept one stays
        assert np.array_equal(op.rhs(active), rhs)
        pressure = op.points.N.T @ (op.points.weight * op.point_pressure(w))
        assert np.array_equal(op.nodal_pressure(w), pressure)
        W = rng.standard_normal((150, 2))  # several at once: the sparse product
        assert np.array_equal(op._times_g(W), op.G @ W)
    kept = op.matrix(active)
    assert op.matrix(active.copy()) is kept  # the same active set and G: kept
    op.update(0.6)
    assert op.matrix(active) is not kept  # G moved


def test_user_obstacle_is_checked():
    ok = dd.UserObstacle(lambda x, t: x[:, 2], lambda x, t: np.tile([0, 0, -1.0], (len(x), 1)))
    assert np.allclose(ok.gap_normal(np.ones((2, 3)))[0], [1, 1])
    bad = dd.UserObstacle(lambda x, t: x[:, 2], lambda x, t: np.tile([0, 0, -2.0], (len(x), 1)))
    with pytest.raises(dd.InputError, match="unit vectors"):
        bad.gap_normal(np.ones((2, 3)))


# -- a block pressed on a wall: uniaxial strain, exact up to the penalty --------------------
def _pressed_block(kind: str, points: str, delta: float = 0.01, E: float = 1000.0):
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 3, 3]), dd.Material(E, 0.0), "block"
    )
    block.fix(_on(2, 1.0), components=[2], value=[0, 0, -delta])
    block.fix(_on(0, 0.0), components=[0]).fix(_on(1, 0.0), components=[1])
    wall = dd.Plane([0, 0, 0], [0, 0, 1])
    if kind == "boundary":
        zone = dd.ContactBoundary(block, _on(2, 0.0), wall, points=points)
    else:
        zone = dd.ContactInterface.from_boundary(
            block, _on(2, 0.0), wall, resolution=(4, 5), points=points
        )
    return block, zone


@pytest.mark.mpi
@pytest.mark.parametrize("kind", ["boundary", "interface"])
@pytest.mark.parametrize("points", ["nodes", "quadrature"])
def test_pressed_block_carries_the_exact_force(kind, points):
    block, zone = _pressed_block(kind, points)
    problem = dd.StaticProblem(dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone]))
    problem.solve()
    force = problem.contact_forces()["contact"]
    # nu = 0: sigma_zz = E delta / L on the unit face; penalties in series cost ~1e-6 each.
    assert force[2] == pytest.approx(1000.0 * 0.01, rel=5e-6)
    assert np.allclose(force[:2], 0.0, atol=1e-12)
    # Every point of the face is in contact with the same pressure.
    if MPI.COMM_WORLD.rank == problem.scene.contact_owner(zone):
        assert np.allclose(zone.pressure.x.array, 10.0, rtol=5e-6)


def test_lifted_block_loses_contact_and_counts_the_change():
    block, zone = _pressed_block("boundary", "nodes", delta=-0.01)  # pulled away
    problem = dd.StaticProblem(dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone]))
    problem.solve()
    # All 16 face nodes start touching (gap 0), one solve shows them apart: one change.
    assert problem.changes == {"gamma": 1, "contact": 1}
    assert problem.iterations == 2
    assert np.allclose(problem.contact_forces()["contact"], 0.0)
    assert problem.work.count("sparse_factor", "FULL") == 2


# -- the contact iteration on a scripted solver ---------------------------------------------
class _ScriptedZone:
    """A zone whose penetration is whatever the scripted solver returns."""

    class _Op:
        def __init__(self):
            self.gap = np.zeros(2)
            self.points = type("P", (), {"x": np.array([[0.0, 0, 0], [1.0, 0, 0]])})()

        def update(self, t):
            pass

        def penetration(self, w):
            return w

        def active_set(self, w):
            return w > 0

    def __init__(self):
        self.contact = type("C", (), {"name": "zone"})()
        self.block, self.dofs, self.operator = "w:zone", np.arange(2), self._Op()
        self.length = 1.0

    def contribution(self, active):
        return None, np.zeros(len(self.dofs))

    @property
    def parts(self):
        return [(self.block, self.dofs)]

    def gather(self, x):
        return x[self.block][self.dofs]

    def scatter(self, vector, sizes):
        return {self.block: vector}


class _ScriptedSolver:
    def __init__(self, answers):
        self.answers, self.calls = list(answers), 0
        self.system = type("S", (), {"sizes": {"w:zone": len(answers[0])}})()

    def set_contact(self, name, matrix, active=None):
        pass

    def solve(self, rhs):
        answer = self.answers[min(self.calls, len(self.answers) - 1)]
        self.calls += 1
        self.last = {"w:zone": np.array(answer, dtype=float)}
        return self.last

    def finish(self):
        return self.last


def test_cycling_is_detected_and_located():
    # Active sets: {} -> {0} -> {1} -> {0}: a cycle of length two.
    solver = _ScriptedSolver([[1, -1], [-1, 1], [1, -1], [-1, 1]])
    settings = ContactSettings(on_cycle="raise")
    iteration = ContactIteration(MPI.COMM_SELF, [_ScriptedZone()], settings, {"w:zone": 2})
    iteration.start(0.0)
    iteration.active["zone"] = np.zeros(2, bool)
    with pytest.raises(ContactIterationError, match=r"cycles at step 3.*iteration 3 returns"):
        iteration.solve(solver, {}, 0.0, "step 3")


def test_cycle_resolved_by_union():
    solver = _ScriptedSolver([[1, -1], [-1, 1], [1, -1], [1, 1]])
    iteration = ContactIteration(MPI.COMM_SELF, [_ScriptedZone()], ContactSettings(), {"w:zone": 2})
    iteration.start(0.0)
    iteration.active["zone"] = np.zeros(2, bool)
    with pytest.warns(ContactCycleWarning, match=r"step 1: iteration 3 returns to .* 1\."):
        iteration.solve(solver, {}, 0.0, "step 1")
    assert iteration.active["zone"].tolist() == [True, True]
    assert iteration.cycles_resolved == 1
    # {} -> {0} -> {1} -> {0} (the cycle) -> {0, 1} (the union): four states, four changes.
    assert iteration.gamma == 4 and iteration.alpha["zone"] == 4


def test_iteration_limit_is_a_setting():
    # Penetration patterns that never repeat within the limit: 3 points, 3 iterations.
    answers = [[1, -1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]]
    zone = _ScriptedZone()
    zone.dofs = np.arange(3)
    zone.operator.gap = np.zeros(3)
    solver = _ScriptedSolver(answers)
    iteration = ContactIteration(
        MPI.COMM_SELF, [zone], ContactSettings(max_iterations=3), {"w:zone": 3}
    )
    iteration.start(0.0)
    iteration.active["zone"] = np.zeros(3, bool)
    with pytest.raises(ContactIterationError, match="did not settle in 3 iterations"):
        iteration.solve(solver, {}, 0.0, "t = 0")


# -- closed forms ---------------------------------------------------------------------------
@pytest.mark.parametrize("contact", ["boundary", "interface"])
def test_hertz(contact):
    # Nodal contact points (the default); benchmarks/hertz_convergence.py compares the schemes.
    r = verify.hertz(0.015, contact=contact)
    assert r["a"] == pytest.approx(r["a_ref"], rel=0.05)
    assert r["p_max"] == pytest.approx(r["p0_ref"], rel=0.10)
    # The computed force is that of a hemisphere pushed 0.03 R: a sanity bound on F.
    assert 0.005 < r["force"] < 0.012


@pytest.mark.parametrize("contact", ["boundary", "interface"])
def test_bar_impact(contact):
    r = verify.bar_impact(n=40, cfl=0.5, contact_kappa=1.0, contact=contact)
    assert r["duration"] == pytest.approx(r["duration_ref"], rel=0.03)
    assert r["rebound"] == pytest.approx(1.0, rel=0.03)
    assert r["energy_ratio"] == pytest.approx(1.0, rel=0.03)
    # FULL re-factorises once at the start and once per contact state change.
    assert r["factorisations"] == 1 + r["changes"]


def test_free_vibration_conserves_energy():
    r = verify.free_vibration(1000)
    assert r["energy0"] > 0
    assert r["drift"] < 1e-8
