"""The trade-study scene ``pin-joint``: the paper's multi-pin joint, pulled onto its pins.

The joint of :func:`dd_contact.paper.models.pin_joint` (two steel plates lapped over five
rigid pins, 0.05 mm clearance, 12 subdomains tied through one interface, ten hole walls as
contact interfaces) at a small scale, its grips pulled apart by 20 kN sin(2 pi t / 2 ms),
stepped over :data:`SPAN` (0.3 of a period): the plates cross the clearance, strike the
pins and bear on them near the load's peak. What a user reads is the force each pin
carries from each plate (bearing stress, fatigue, how the load is shared): the error of a
run is the relative L2 norm of the ten walls' forces along the load, averaged over windows
of :data:`WINDOW`, against a converged run's (:data:`REFERENCE`).

:func:`pin_forces` runs one setting; :func:`tilted.richardson` estimates the reference's
own error from three runs refined twice (mesh and step halved together).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mpi4py import MPI

import numpy as np

from dd_contact.paper.tradeoff.tilted import windows
from dd_contact.problem import TransientProblem
from dd_contact.scene import Penalty

__all__ = ["PERIOD", "REFERENCE", "SPAN", "WALLS", "WINDOW", "pin_error", "pin_forces", "score"]

#: The load's period [s] (the demo's) and the simulated span: the flight across the
#: clearance, the first strike on the pins and the bearing near the load's peak.
PERIOD, SPAN = 2e-3, 6e-4

#: The forces are compared averaged over windows of 20 us: a strike lasts 0.12-0.2 ms, so
#: its course is kept, not the ringing at the step's scale.
WINDOW = 2e-5

#: The ten hole walls, upper plate first.
WALLS = tuple(f"hole_{plate}{k}" for plate in ("upper", "lower") for k in range(5))

#: The converged run (``benchmarks/tradeoff_pin_reference.py`` measures it): its mesh
#: (cells c, r, t, grip rows as :data:`dd_contact.paper.models.PIN_JOINT_SCALES`), step,
#: each wall's force along y [N] averaged over each window, and its own error by Richardson
#: extrapolation over two coarser runs (mesh and step doubled each time).
# fmt: off
REFERENCE: dict[str, Any] = {
    "elements": (12, 8, 4, 16),
    "dt": 1e-06,
    "windows": [  # N (rounded), windows x walls (WALLS)
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [-3609, -3628, -3574, -3628, -3609, 3609, 3628, 3574, 3628, 3609],
        [-8304, -8777, -8870, -8777, -8304, 8304, 8777, 8870, 8777, 8304],
        [-11287, -11865, -11797, -11865, -11287, 11287, 11865, 11797, 11865, 11287],
        [-12874, -13533, -13826, -13533, -12874, 12874, 13533, 13826, 13533, 12874],
        [-14340, -14855, -14982, -14855, -14340, 14340, 14855, 14982, 14855, 14340],
        [-15888, -16073, -15948, -16073, -15888, 15888, 16073, 15948, 16073, 15888],
        [-16171, -15834, -15447, -15834, -16171, 16171, 15834, 15447, 15834, 16171],
        [-9857, -10304, -10449, -10304, -9857, 9857, 10304, 10449, 10304, 9857],
        [-4503, -5653, -6172, -5653, -4503, 4503, 5653, 6172, 5653, 4503],
        [-1305, -1555, -1351, -1555, -1305, 1305, 1555, 1351, 1555, 1305],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    ],
    "richardson": {
        "difference_coarse": 0.1328,
        "difference_fine": 0.0409,
        "order": 1.6996,
        "finest_error": 0.0182,
    },
}
# fmt: on


def _scene(settings: dict[str, Any]) -> Any:
    """The joint at ``settings["elements"]`` with the penalties and contact points set."""
    from dd_contact.paper import models

    c, r, t, g = settings["elements"]
    layout = dataclasses.replace(
        models.pin_joint_layout("small"),
        n_circumferential=c, n_radial=r, n_layers=t, n_length=g,
    )  # fmt: skip
    per_quarter = settings["wall_cells"]
    scene = models.pin_joint(
        layout,
        wall_cells=None if per_quarter is None else 4 * per_quarter,
        walls=settings["walls"],
        period=PERIOD,
        comm=MPI.COMM_SELF,
    )
    # The model takes the package's penalties and points; the knobs set them on its parts.
    assert scene.interface is not None  # the joint's cuts
    scene.interface.penalty = Penalty(kappa=settings["kappa"])
    for zone in scene.contacts:
        zone.penalty = Penalty(kappa=settings["kappa"])
        zone.contact_penalty = Penalty(kappa=settings["contact_kappa"])
        zone.points = settings["points"]
    return scene


def pin_forces(settings: dict[str, Any]) -> tuple[float, np.ndarray, int]:
    """One run: its step, each wall's force along y after every step, its contact changes."""
    scene = _scene(settings)
    dt = settings["dt"]
    steps = round(SPAN / dt)
    problem = TransientProblem(
        scene,
        dt,
        algorithm=settings["algorithm"],
        mass=settings["mass"],
        scheme=settings["scheme"],
        rho_infinity=settings["rho_infinity"],
        energy_safe_contact=settings["energy_safe_contact"],
        track_energy=False,
        expected_steps=steps,
    )
    forces = []
    for _ in range(steps):
        problem.advance()
        force = problem.history[-1]["force"]
        forces.append([force[w][1] for w in WALLS])
    return dt, np.array(forces), int(problem.changes["gamma"])


def pin_error(settings: dict[str, Any]) -> dict[str, Any]:
    """A run's relative L2 error of its windowed pin forces against :data:`REFERENCE`."""
    dt, forces, changes = pin_forces(settings)
    scored = score(windows(dt, forces, WINDOW))
    scored["parts"].update(changes=changes, steps=len(forces))
    return scored


def score(mine: np.ndarray) -> dict[str, Any]:
    """The error of windowed pin forces ``mine`` (windows x walls) and its parts.

    Kept apart from the run so that a study's runs (their parts hold their windows) can be
    scored again against a new reference (``benchmarks/tradeoff.py --charts``).
    """
    mine, exact = np.asarray(mine), np.asarray(REFERENCE["windows"])
    total, total_exact = np.abs(mine).sum(axis=1), np.abs(exact).sum(axis=1)
    parts = {
        "peak_pin_force": float(np.abs(mine).max() / np.abs(exact).max() - 1.0),
        "impulse": float(total.sum() / total_exact.sum() - 1.0),
        "first_strike_ms": float(1e3 * WINDOW * np.argmax(total > 0.05 * total_exact.max())),
        "windows": mine.round(3).tolist(),  # the error again against another reference
    }
    return {"error": float(np.linalg.norm(mine - exact) / np.linalg.norm(exact)), "parts": parts}
