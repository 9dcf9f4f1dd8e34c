"""Energy-safe contact against obstacles that move (``motion=``), and their work.

The block hit by a wall moving at v is a closed form: the wall (infinitely heavy) sends
the free block off at 2 v, so its energy after the hit is ``2 m v^2``. Before the start
forces were taken at t_n (dd_contact.impact.StartForces), the release as the block left
the moving wall gave it 13x that energy (2.56e-3 J against 2e-4 J), with no warning.
"""

import warnings

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import meshes

V, DT, GAP = 0.01, 0.002, 1e-4  # wall speed, step, first gap: contact from step 6


def _bottom(x):
    return np.isclose(x[2], 0.0)


def _hit(energy_safe, surface):
    """The block (1 kg, free) hit by the wall: the history and the warnings' categories."""
    block = dd.Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]),
        dd.Material(1000.0, 0.0, rho=1.0),
        "b",
    )
    wall = dd.Plane([0, 0, -GAP], [0, 0, 1], motion=lambda t: [0.0, 0.0, V * t])
    if surface == "interface":
        zone = dd.ContactInterface.from_boundary(block, _bottom, wall, name="contact")
    else:
        zone = dd.ContactBoundary(block, _bottom, wall)
    scene = dd.Scene(MPI.COMM_WORLD, [block], contacts=[zone])
    problem = dd.TransientProblem(scene, dt=DT, energy_safe_contact=energy_safe)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        history = problem.run(60, progress=False, summary=False)
    return history, [w.category for w in caught]


@pytest.mark.parametrize("surface", ["interface", "boundary"])
def test_a_block_hit_by_a_moving_wall_leaves_at_twice_its_speed(surface):
    history, caught = _hit(True, surface)
    assert dd.EnergyGrowthWarning not in caught
    assert history[-1]["active"]["contact"] == 0  # off the wall
    energy = history[-1]["energy"]["total"]
    assert energy == pytest.approx(2 * V**2, rel=1e-2)  # 1.9933e-4, 1.9888e-4
    assert energy <= 2 * V**2  # the contact creates none
    impulse = DT * sum(r["force"]["contact"][2] for r in history)
    assert impulse == pytest.approx(2 * V, rel=5e-3)  # the momentum 2 m v


def test_energy_a_moving_wall_step_creates_is_reported():
    """Classic contact's release as the block leaves creates energy: the balance, with the
    wall's work counted, reports it (it skipped every step of a moving obstacle)."""
    history, caught = _hit(False, "interface")
    assert caught.count(dd.EnergyGrowthWarning) == 1
    assert history[-1]["energy"]["total"] > 3 * 2 * V**2  # 7.6e-4 J: created


def test_a_pin_pulled_through_a_hole_agrees_with_classic_contact():
    """demo_one_mesh's scene, small: a steel plate pulled by a pin through its hole."""

    def pull(t):
        s = min(t / 2e-3, 1.0)
        return (0.1e-3 * s * s * (3 - 2 * s), 0.0, 0.0)

    forces = {}
    for energy_safe in (True, False):
        mesh = meshes.hole_block(MPI.COMM_SELF, [-0.02, -0.02, 0], 0.04, 0.008, 0.005, 12, 4, 1)
        plate = dd.Subdomain(mesh, dd.Material(210e9, 0.3, rho=7850.0), "plate")
        plate.fix(lambda x: np.isclose(x[0], 0.02))
        pin = dd.Cylinder([0, 0, 0], [0, 0, 1], 0.008 - 20e-6, motion=pull)
        on_hole = lambda x: np.isclose(np.hypot(x[0], x[1]), 0.008)  # noqa: E731
        zone = dd.ContactInterface.from_boundary(plate, on_hole, pin, name="pin")
        scene = dd.Scene(MPI.COMM_WORLD, [plate], contacts=[zone])
        problem = dd.TransientProblem(scene, dt=1e-4, energy_safe_contact=energy_safe)
        with warnings.catch_warnings():
            warnings.simplefilter("error", dd.EnergyGrowthWarning)
            history = problem.run(20, progress=False, summary=False)
        forces[energy_safe] = np.array([r["force"]["pin"][0] for r in history])
    assert sum(r["changes"] for r in history) >= 5  # the contact grows point by point
    assert forces[True][-1] == pytest.approx(1.2315e5, rel=1e-3)
    np.testing.assert_allclose(forces[True], forces[False], atol=2e-3 * forces[False].max())
