"""Coulomb friction: the sliding block in every algorithm that fits, inputs, the history."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import numpy as np
import pytest
from friction_checks import assert_resumed_is_whole, assert_sticks_below_half

from dd_contact.errors import EnergyGrowthWarning, InputError, SingularMatrixError
from dd_contact.friction import SLIP, Friction
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.friction import (
    DRAG,
    SLIDING_SCENES,
    sliding_balance,
    sliding_block,
    sliding_scene,
)
from dd_contact.paper.verify.models import locator
from dd_contact.paper.verify.orders import blocks
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactBoundary, ContactInterface

MU, STEPS = 0.3, 20
RUNS = [
    (kind, algorithm) for kind, algorithms in SLIDING_SCENES.items() for algorithm in algorithms
]


@pytest.fixture(scope="module")
def runs():
    """Each scene and algorithm, run once for the tests below."""
    return {(k, a): sliding_block(k, a, MU, STEPS) for k, a in RUNS}


@pytest.mark.parametrize(("kind", "algorithm"), RUNS)
def test_sliding_reaction_is_mu_n(runs, kind, algorithm):
    """Once the whole face slides, the plane's tangential force is mu N to 1e-6."""
    run = runs[(kind, algorithm)]
    assert run["slipping"][-1] == 25  # every contact node slides
    T, N = np.array(run["T"]), np.array(run["N"])
    assert N[-1] == pytest.approx(1.0, rel=1e-9)  # the pressure on the unit face
    assert abs(T[-1] / (MU * N[-1]) - 1.0) < 1e-6


@pytest.mark.parametrize(("kind", "algorithm"), RUNS)
def test_no_slip_below_half_mu_n(runs, kind, algorithm):
    """While T < mu N / 2 nothing slips: the face follows the plane (penalty compliance)."""
    assert_sticks_below_half(runs[(kind, algorithm)], MU)


@pytest.mark.parametrize("kind", ["single", "interface"])
def test_orders_agree_with_full(runs, kind):
    """Every order's displacements after the run equal FULL's (same stick/slip path)."""
    full = runs[(kind, "FULL")]
    for algorithm in SLIDING_SCENES[kind][1:]:
        run = runs[(kind, algorithm)]
        assert run["changes"] == full["changes"]
        error = np.linalg.norm(run["u"] - full["u"]) / np.linalg.norm(full["u"])
        assert error < 1e-8


def test_stick_slip_changes_count(runs):
    """A point moving between stick and slip is a contact state change (gamma)."""
    frictionless = sliding_block("single", "w-u", 0.0, 3)
    assert frictionless["changes"] == 0  # the face stays in contact: no change
    assert runs[("single", "w-u")]["changes"] >= 2  # edges, then the whole face, slip


@pytest.mark.parametrize("algorithm", ["FULL", "w-u"])
def test_mu_zero_is_frictionless(algorithm):
    """friction=0 is the frictionless code path; a tiny mu converges to it."""
    runs = {mu: sliding_block("single", algorithm, mu, 2) for mu in (0.0, 1e-10)}
    u0, u1 = runs[0.0]["u"], runs[1e-10]["u"]
    assert np.linalg.norm(u1 - u0) <= 1e-8 * np.linalg.norm(u0)
    scene = sliding_scene("single", 0.0, MPI.COMM_WORLD)
    problem = StaticProblem(scene, algorithm=algorithm)
    region = problem.analysis.zones[0].region
    assert region.symmetric and not region.history
    problem.close()


def test_dissipation_while_sliding():
    """Each step dissipates >= 0; sliding, exactly mu N times the plane's travel."""
    scene = sliding_scene("single", MU, MPI.COMM_WORLD)
    problem = StaticProblem(scene, algorithm="w-u")
    friction = problem.analysis.zones[0].operator.friction
    dissipated = []
    for step in range(1, STEPS + 1):
        problem.solve(float(step))
        dissipated.append(friction.dissipation)
    problem.close()
    assert min(dissipated) >= 0.0
    assert np.all(friction.state == SLIP)
    travel = 8e-5 * 0.25  # TRAVEL x the block's height, per step
    assert dissipated[-1] == pytest.approx(MU * 1.0 * travel, rel=1e-6)


def test_history_round_trip():
    """The friction history is arrays and back, bit for bit."""
    scene = sliding_scene("single", MU, MPI.COMM_WORLD)
    problem = StaticProblem(scene, algorithm="w-u")
    for step in (1, 2, 3):
        problem.solve(float(step))
    friction = problem.analysis.zones[0].operator.friction
    saved = friction.arrays()
    before = {k: v.copy() for k, v in saved.items()}
    problem.solve(9.0)
    friction.restore(saved)
    for name, value in friction.arrays().items():
        assert np.array_equal(value, before[name])
    problem.close()


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), "0.3", True])
def test_bad_friction(bad):
    """A negative, non-finite or non-numeric coefficient is refused, naming it."""
    a = blocks("single")[0]
    with pytest.raises(InputError, match="friction must be a finite number >= 0"):
        ContactBoundary(a, locator(0, 0.0), Plane([0, 0, 0], [1, 0, 0]), friction=bad)


def test_friction_on_pair_side_refused():
    """A pair side has no friction of its own: the message says it is the pair's."""
    a = blocks("single")[0]
    with pytest.raises(InputError, match="friction between two bodies is the pair's"):
        ContactInterface.from_boundary(a, locator(0, 0.0), None, friction=0.2)


@pytest.mark.parametrize("algorithm", ["FULL", "v-w-u"])
def test_resumed_sliding_run_is_the_uninterrupted_one(algorithm, tmp_path):
    """The friction history is checkpointed: a resumed quasi-static run is bit for bit."""

    def problem():
        scene = sliding_scene("interface", MU, MPI.COMM_SELF)
        return TransientProblem(scene, 1.0, algorithm=algorithm, inertia=False)

    assert_resumed_is_whole(problem, tmp_path)


@pytest.mark.parametrize(("kind", "algorithm"), [("single", "w-u"), ("boundary", "FULL")])
def test_energy_balance_takes_out_the_dissipation(kind, algorithm):
    """With inertia: energy now = before + loads' work - dissipation, to round-off.

    The block slides (it lands as the pressure's wave reaches its base at step 6) and no
    EnergyGrowthWarning is given; the steps without a contact change close the books.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGrowthWarning)
        steps = sliding_balance(kind, algorithm, MU, 26)
    dissipated = np.array([s["dissipated"] for s in steps])
    assert dissipated.min() >= 0.0 and dissipated.max() > 1e-5
    settled = [s for s in steps if s["changes"] == 0 and s["dissipated"] > 0]
    assert len(settled) >= 15
    for s in settled:
        assert abs(s["residual"]) <= 1e-8 * s["total"] < 1e-3 * s["dissipated"]


@pytest.mark.parametrize(("kind", "algorithm"), [("single", "w-u"), ("boundary", "FULL")])
def test_energy_balance_counts_a_dragging_planes_tangential_work(kind, algorithm):
    """The plane drags the pressed block (travel DRAG t^3): it sticks, then slips; the
    balance with the plane's work (normal and tangential) and the dissipation closes.

    Measured: |residual| <= 3.3e-14 J (w-u), 1.3e-15 J (FULL) in the steps without a
    contact change, energy ~4e-4 J, the plane's work up to 1.05e-5 J a step; the landing's
    step (6) loses 1.2e-7 J.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGrowthWarning)
        steps = sliding_balance(kind, algorithm, MU, 30, drag=DRAG)
    sticking = [s for s in steps if s["obstacle"] > 0 and s["slipping"] == 0]
    slipping = [s for s in steps if s["slipping"] == 25]
    assert len(sticking) >= 15 and len(slipping) >= 4  # 19 and 5
    assert max(s["obstacle"] for s in steps) > 1e-5
    for s in steps:
        assert s["residual"] <= 1e-6 * s["total"]  # ENERGY_GROWTH_TOLERANCE: none created
        if s["changes"] == 0:
            assert abs(s["residual"]) <= 1e-9 * s["total"]
    assert sum(s["dissipated"] for s in slipping) > 0.1 * sum(s["obstacle"] for s in slipping)


def test_a_dragging_planes_tangential_work_undercounted_is_reported(monkeypatch):
    """Half the plane's tangential work counted: the other half is energy created, reported."""
    commit = Friction.commit

    def halved(self, w, *solved):
        commit(self, w, *solved)
        self.obstacle_work *= 0.5

    monkeypatch.setattr(Friction, "commit", halved)
    with pytest.warns(EnergyGrowthWarning, match=r"step 7 \(t = 0\.007\)"):
        steps = sliding_balance("single", "w-u", MU, 30, drag=DRAG)
    assert max(s["residual"] for s in steps) > 1e-3 * max(s["obstacle"] for s in steps)


def test_slip_and_traction_are_written(tmp_path):
    """The output has slip, tangential traction and the stick/slip map of the contact."""
    from dd_contact.results import load_results

    scene = sliding_scene("single", MU, MPI.COMM_SELF)
    problem = TransientProblem(scene, 1.0, algorithm="w-u", inertia=False)
    problem.run(STEPS, output=tmp_path, summary=False, progress=False)
    friction = problem.analysis.zones[0].operator.friction
    stored = load_results(tmp_path).arrays(STEPS, "w_base")  # per node, in mesh order
    for name, values in (("traction", friction.traction), ("slip", friction.slip)):
        mine = np.sort(stored[f"{name}_base"].reshape(-1, 3), axis=0)
        np.testing.assert_allclose(mine, np.sort(friction.nodal(values), axis=0), atol=1e-15)
    assert np.all(stored["stick_base"] == SLIP)  # the whole face slides
    assert stored["traction_base"].reshape(-1, 3)[:, 0].min() > 0  # dragged along +x
    problem.close()


@pytest.mark.mpi
@pytest.mark.parametrize("algorithm", ["FULL", "v-w-u", "w-v-u"])
def test_sliding_on_the_ranks_of_the_communicator(algorithm):
    """On any number of ranks: T = mu N once sliding, and the serial run's displacements."""
    run = sliding_block("interface", algorithm, MU, STEPS, MPI.COMM_WORLD)
    serial = sliding_block("interface", algorithm, MU, STEPS, MPI.COMM_SELF)
    assert abs(run["T"][-1] / (MU * run["N"][-1]) - 1.0) < 1e-6
    assert run["changes"] == serial["changes"]
    error = np.linalg.norm(run["u"] - serial["u"]) / np.linalg.norm(serial["u"])
    assert error < 1e-9


def test_v_u_does_not_fit_friction_on_a_subdomain_boundary():
    """auto leaves v-u out; asked for, it is refused naming what fits (FULL)."""
    from dd_contact.paper.verify.orders import block_scene

    def scene():
        parts = blocks("boundary")
        parts[-1].fix(locator(0, 2.0), value=[-0.004, 0.0, 0.0])
        wall = Plane([-0.002, 0, 0], [1, 0, 0])
        made = block_scene("boundary", parts, wall, MPI.COMM_WORLD)
        made.contacts[0].friction = 0.3  # read when the contact operator is built
        return made

    with pytest.raises(InputError, match="valid for it: FULL or auto"):
        StaticProblem(scene(), algorithm="v-u")
    problem = StaticProblem(scene(), algorithm="auto")
    problem.solve()
    assert problem.algorithm == "FULL"
    problem.close()


def test_lu_factors_solve_unsymmetric_matrices():
    """DenseLU's solve and left^T A^-1 B, SparseLU's solve, against numpy."""
    from dd_contact.solvers.linalg import petsc_matrix
    from dd_contact.solvers.unsymmetric import DenseLU, SparseLU
    from dd_contact.solvers.worklog import WorkLog

    rng = np.random.default_rng(7)
    A = rng.standard_normal((6, 6)) + 6 * np.eye(6)
    A[0, 5] += 3.0  # unsymmetric
    B, C, b = rng.standard_normal((6, 2)), rng.standard_normal((6, 2)), rng.standard_normal(6)
    dense = DenseLU(A.copy(), WorkLog(), "g")
    np.testing.assert_allclose(dense.solve(b), np.linalg.solve(A, b), rtol=1e-12)
    expected = C.T @ np.linalg.solve(A, B)
    np.testing.assert_allclose(dense.congruence(B, left=C), expected, rtol=1e-12)
    rows, cols = np.nonzero(np.ones_like(A))
    matrix = petsc_matrix(MPI.COMM_SELF, 6, 6, rows, cols, A[rows, cols])
    sparse = SparseLU(matrix, WorkLog(), "FULL")
    np.testing.assert_allclose(sparse.solve_array(b), np.linalg.solve(A, b), rtol=1e-12)
    sparse.destroy(), matrix.destroy()
    with pytest.raises(SingularMatrixError):
        DenseLU(np.zeros((3, 3)), WorkLog(), "g")
