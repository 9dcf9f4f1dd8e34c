"""Time stepping: quasi-static steps, checkpoints and resume, progress, bad input."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import ufl

import dd_contact as dd
from dd_contact import meshes
from dd_contact.paper import verify


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _block(name="block"):
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]),
        dd.Material(1000.0, 0.0, 1.0),
        name,
    )
    return block.fix(_on(0, 0.0), components=[0]).fix(_on(1, 0.0), components=[1])


@pytest.mark.parametrize("load", ["callable", "ufl"])
def test_quasi_static_steps_follow_the_load(load):
    block = _block()
    if load == "callable":
        block.add_traction(_on(2, 1.0), lambda t: [0.0, 0.0, -100.0 * t])
    else:  # a UFL expression of the solver-updated time constant
        block.add_traction(_on(2, 1.0), ufl.as_vector((0.0, 0.0, -100.0 * block.time)))
    zone = dd.ContactBoundary(block, _on(2, 0.0), dd.Plane([0, 0, 0], [0, 0, 1]))
    problem = dd.TransientProblem(
        dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone]), dt=0.1, inertia=False
    )
    history = problem.run(5, progress=False)
    # Equilibrium: the wall carries the whole load at every step, whatever the penalty.
    for record in history:
        assert record["force"]["contact"][2] == pytest.approx(100.0 * record["t"], rel=1e-9)
    assert [r["step"] for r in history] == [1, 2, 3, 4, 5]


def test_moving_wall_pushes_a_held_block():
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]), dd.Material(1000.0, 0.0), "b"
    )
    block.fix(_on(2, 1.0))
    wall = dd.Plane([0, 0, -0.001], [0, 0, 1], motion=lambda t: [0.0, 0.0, 0.002 * t])
    zone = dd.ContactBoundary(block, _on(2, 0.0), wall)
    problem = dd.TransientProblem(
        dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone]), dt=0.25, inertia=False
    )
    forces = [r["force"]["contact"][2] for r in problem.run(4, progress=False)]
    # The wall reaches the block at t = 0.5, then compresses it by 0.002 (t - 0.5):
    # force = E A d / L (nu = 0), up to the penalty compliance.
    expected = [1000.0 * 0.002 * max(t - 0.5, 0.0) for t in (0.25, 0.5, 0.75, 1.0)]
    assert forces == pytest.approx(expected, rel=1e-5, abs=1e-12)


def test_a_moving_wall_pushing_a_block_with_inertia_is_no_energy_growth(recwarn):
    """The wall's work goes through contact, in no load vector: it is counted in the balance
    (StartForces.obstacle_work); uncounted, the first contact step warned EnergyGrowthWarning."""
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]),
        dd.Material(1000.0, 0.0, rho=1.0),
        "b",
    )
    block.fix(_on(2, 1.0))
    wall = dd.Plane([0, 0, -0.001], [0, 0, 1], motion=lambda t: [0.0, 0.0, 0.002 * t])
    zone = dd.ContactBoundary(block, _on(2, 0.0), wall)
    problem = dd.TransientProblem(dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone]), dt=0.25)
    forces = [r["force"]["contact"][2] for r in problem.run(8, progress=False, summary=False)]
    assert forces[2] > 0  # in contact from t = 0.75 on, pushed
    assert not [w for w in recwarn if issubclass(w.category, dd.errors.EnergyGrowthWarning)]


@pytest.mark.mpi
def test_resume_reproduces_the_uninterrupted_run(tmp_path, falling_bar):
    comm = MPI.COMM_WORLD
    out = comm.bcast(str(tmp_path) if comm.rank == 0 else None)
    bar, problem = falling_bar()
    reference = problem.run(30, progress=False)
    reference_problem_releases = dict(problem.iteration.releases)
    u_ref, v_ref = bar.u.x.array.copy(), bar.velocity.x.array.copy()
    assert problem.changes["gamma"] >= 2  # contact made and lost inside the run

    class Interrupt(Exception):
        pass

    def stop_at_12(record):
        if record["step"] == 12:
            raise Interrupt

    bar, problem = falling_bar()
    with pytest.raises(Interrupt):
        problem.run(30, output=out, checkpoint_every=5, callback=stop_at_12, progress=False)
    bar, problem = falling_bar()
    resumed = problem.run(30, output=out, checkpoint_every=5, resume=True, progress=False)
    assert resumed[10]["step"] == 11  # it went on from the checkpoint of step 10
    assert np.array_equal(bar.u.x.array, u_ref)
    assert np.array_equal(bar.velocity.x.array, v_ref)
    assert [r["force"] for r in resumed] == [r["force"] for r in reference]
    assert problem.changes["gamma"] == reference_changes(reference)
    assert problem.iteration.releases == reference_problem_releases  # counted on, not reset
    if comm.rank == 0:
        names = sorted(p.name for p in tmp_path.iterdir())
        assert "u_bar.xdmf" in names and not any(".from" in n for n in names)  # one series
        assert "history.json" in names and "checkpoint.rank0.npz" in names


@pytest.mark.mpi
@pytest.mark.parametrize(
    "options",
    [
        {"mass": "lumped"},
        {"scheme": "generalized-alpha"},
        {"energy_safe_contact": False},
    ],
)
def test_resume_with_other_time_integration_settings_is_refused(tmp_path, options, falling_bar):
    # The checkpoint records the scheme, mass and contact rule: continuing a consistent-mass
    # trapezoidal run with other settings would join two different integrations silently.
    out = MPI.COMM_WORLD.bcast(str(tmp_path) if MPI.COMM_WORLD.rank == 0 else None)
    _, problem = falling_bar()
    problem.run(4, output=out, checkpoint_every=2, progress=False, summary=False)
    _, other = falling_bar(**options)
    with pytest.raises(dd.InputError, match="resume: the checkpoint was written with inertia"):
        other.run(8, output=out, checkpoint_every=2, resume=True, progress=False)
    _, same = falling_bar()
    assert same.run(8, output=out, resume=True, progress=False, summary=False)[-1]["step"] == 8


def reference_changes(history):
    return sum(r["changes"] for r in history)


def test_progress_bar_is_shown_when_asked(capsys, falling_bar):
    _, problem = falling_bar()
    problem.run(3, progress=True)
    if MPI.COMM_WORLD.rank == 0:
        assert "3/3" in capsys.readouterr().err


@pytest.mark.mpi
def test_split_bar_impact_on_two_ranks():
    # Two subdomains tied by an interface (one per rank under mpiexec -n 2), contact on the end.
    r = verify.bar_impact(n=40, cfl=0.5, contact_kappa=1.0, split=True)
    assert r["duration"] == pytest.approx(2.0, rel=0.03)
    assert r["rebound"] == pytest.approx(1.0, rel=0.03)
    assert r["energy_ratio"] == pytest.approx(1.0, rel=0.03)


# -- bad input -----------------------------------------------------------------------------
def _scene(block, zone):
    return dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone])


def test_obstacle_penetrating_at_start_is_refused():
    block = _block()
    zone = dd.ContactBoundary(block, _on(2, 0.0), dd.Plane([0, 0, 0.05], [0, 0, 1]))
    with pytest.raises(dd.InputError, match=r"penetrates the body at t = 0.0 by 0.05 at \["):
        dd.TransientProblem(_scene(block, zone), dt=0.1)


def test_obstacle_normal_into_the_body_is_refused():
    block = _block()
    zone = dd.ContactBoundary(block, _on(2, 0.0), dd.Plane([0, 0, 0], [0, 0, -1]))
    with pytest.raises(dd.InputError, match="normal points into the body"):
        dd.StaticProblem(_scene(block, zone))


def test_contact_interface_off_the_boundary_is_refused():
    block = _block()
    far = meshes.surface_mesh(
        MPI.COMM_SELF,
        [[0, 0, -0.3], [1, 0, -0.3], [0, 1, -0.3], [1, 1, -0.3]],
        [[0, 1, 2, 3]],
        "quadrilateral",
    )
    zone = dd.ContactInterface(far, block, dd.Plane([0, 0, -1], [0, 0, 1]))
    with pytest.raises(dd.InputError, match="does not touch subdomain 'block'"):
        dd.StaticProblem(_scene(block, zone))


def test_non_positive_time_step_is_refused(falling_bar):
    _, problem = falling_bar()
    with pytest.raises(dd.InputError, match="dt must be a positive"):
        dd.TransientProblem(problem.scene, dt=0.0)


def test_nan_in_initial_velocity_is_refused(falling_bar):
    bar, problem = falling_bar()
    bar.velocity.x.array[4] = np.nan
    with pytest.raises(dd.InputError, match="initial velocity_bar contains NaN"):
        problem.run(1, progress=False)


def test_nan_in_a_load_is_refused_with_the_time():
    block = _block()
    block.add_traction(_on(2, 1.0), lambda t: [0.0, 0.0, np.nan if t > 0.25 else -t])
    zone = dd.ContactBoundary(block, _on(2, 0.0), dd.Plane([0, 0, 0], [0, 0, 1]))
    problem = dd.TransientProblem(_scene(block, zone), dt=0.1, inertia=False)
    with pytest.raises(dd.InputError, match=r"load callable returned .* at t = 0.3"):
        problem.run(5, progress=False)
    assert problem.step == 2  # the steps before the bad load are kept


def test_dynamic_problem_needs_density():
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [1, 1, 1]), dd.Material(1.0, 0.0), "b"
    )
    with pytest.raises(dd.InputError, match="no density"):
        dd.TransientProblem(dd.Scene(MPI.COMM_WORLD, [block]), dt=0.1)


@pytest.mark.parametrize("algorithm", ["w-v-u", "FULL"])
def test_a_resumed_dynamic_run_with_surfaces_is_the_uninterrupted_one(algorithm, tmp_path):
    """The next step's start forces read the interface and contact surfaces at t_n."""
    from dd_contact.paper import examples

    def problem():
        scene = examples.parallelepiped(algorithm, (12, 4, 2), comm=MPI.COMM_SELF)
        return dd.TransientProblem(scene, 1e-6, algorithm=algorithm, track_energy=False)

    whole = problem()
    whole.run(6, summary=False)
    problem().run(3, output=tmp_path, checkpoint_every=3, summary=False)
    resumed = problem()
    resumed.run(6, output=tmp_path, resume=True, summary=False)
    assert sum(r["changes"] for r in whole.history) >= 2  # contact changed on the way
    for mine, theirs in zip(resumed.scene.subdomains, whole.scene.subdomains, strict=True):
        for field in ("u", "velocity", "acceleration"):
            mine_values, their_values = getattr(mine, field), getattr(theirs, field)
            np.testing.assert_array_equal(mine_values.x.array, their_values.x.array)
    assert [r["force"] for r in resumed.history] == [r["force"] for r in whole.history]
