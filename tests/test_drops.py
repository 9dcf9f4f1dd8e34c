"""3-D bodies dropped on a rigid plane keep their energy (dd_contact.paper.verify.drops)."""

from __future__ import annotations

import warnings

from mpi4py import MPI

import pytest

import dd_contact as dd
from dd_contact.paper import verify
from dd_contact.problem import MIN_CONTACT_STEPS


def _run_quietly(run) -> tuple[dict, bool]:
    """The result, and whether a CoarseTimeStepWarning came; energy growth is an error."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("error", dd.EnergyGrowthWarning)
        result = run()
    return result, any(issubclass(w.category, dd.CoarseTimeStepWarning) for w in caught)


@pytest.mark.parametrize("cfl", [0.5, 0.1])
def test_a_falling_block_keeps_its_energy(cfl):
    # Default settings, 4^3 hexahedra, nu = 0.3, lateral faces free. Measured: energy after /
    # before 0.99603 (cfl 0.5), 0.99991 (0.1); it lands and lifts off as it rings.
    r, coarse = _run_quietly(lambda: verify.falling_block(n=4, cfl=cfl, comm=MPI.COMM_SELF))
    assert 0.98 <= r["energy_ratio"] <= 1 + 1e-6
    assert r["changes"] >= 2 and r["touching_at_end"] == 0  # it landed and left
    # one episode: 21 steps at cfl 0.5 (too few: warned), 105 at 0.1
    assert len(r["episodes"]) == 1 and coarse == (r["episodes"][0] < MIN_CONTACT_STEPS)


@pytest.mark.parametrize("steps_per_contact", [20, 40])
def test_a_dropped_sphere_keeps_its_energy(steps_per_contact):
    pytest.importorskip("gmsh")
    # A hemisphere (R = 1, h = 0.1 R near the pole) at 0.01 c. Measured: energy 0.99144
    # (20 steps per Hertz contact time), 0.99566 (40); contact 0.90-0.93 of Hertz's time.
    r, coarse = _run_quietly(lambda: verify.sphere_drop(steps_per_contact, comm=MPI.COMM_SELF))
    assert 0.98 <= r["energy_ratio"] <= 1 + 1e-6
    assert coarse  # 18 and 37 steps in contact: fewer than MIN_CONTACT_STEPS
    # one contact of about Hertz's duration, then it flies off
    assert len(r["episodes"]) == 1 and r["touching_at_end"] == 0
    assert 0.85 * steps_per_contact <= r["episodes"][0] <= 1.0 * steps_per_contact


def test_the_drops_are_verify_cases():
    assert verify.CASES["falling-block"] is verify.drops.case_falling_block
    assert verify.CASES["sphere-drop"] is verify.drops.case_sphere_drop
    inside, above = verify.drops.energy_record("x", 0.99), verify.drops.energy_record("x", 1 + 2e-6)
    assert inside.passed and not above.passed
