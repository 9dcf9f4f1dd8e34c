"""The trade-study scene ``tilted-wall``: the paper's parallelepiped shaken on a tilted wall.

The bar of :func:`dd_contact.paper.models.parallelepiped` (steel, 400 x 100 x 10 mm, cut in
two tied subdomains, a contact interface on its end; the far end clamped, a body force
``b sin(2 pi t / T)`` pushing the end onto a wall tilted by 2e-5 rad, so that contact spreads
row by row) is stepped over one period T = 4 ms. What a user reads is the force the wall
carries: the error of a run is the relative L2 norm of its wall-force history against a
converged run's (:data:`REFERENCE`), both averaged over windows of 0.2 ms (:data:`WINDOW`).

:func:`wall_forces` runs one setting; :func:`richardson` estimates the reference's own error
from three runs refined twice (mesh and step halved together).
"""

from __future__ import annotations

from typing import Any

from mpi4py import MPI

import numpy as np

from dd_contact.problem import TransientProblem

__all__ = ["PERIOD", "REFERENCE", "WINDOW", "richardson", "tilted_error", "wall_forces", "windows"]

#: The load's period and the simulated time [s].
PERIOD = 4e-3

#: The force is compared averaged over windows of 0.2 ms: at the step's scale the contact
#: rings (a row closing is an impact), and that ringing does not converge with the mesh.
WINDOW = 2e-4

#: The converged run (``benchmarks/tradeoff_tilted_reference.py`` measures it and prints
#: these numbers): 80 x 20 x 4 hexahedra, dt = 25 us, its wall force [N] averaged over each
#: window, and its own error estimated by Richardson extrapolation over (20, 5, 1) at
#: 100 us, (40, 10, 2) at 50 us and itself.
REFERENCE: dict[str, Any] = {
    "elements": (80, 20, 4),
    "dt": 2.5e-5,
    "windows": [
        80.005,
        521.368,
        1495.918,
        2148.704,
        2466.759,
        2505.016,
        2149.249,
        1387.707,
        365.27,
        5.673,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    "richardson": {
        "difference_coarse": 0.0951,
        "difference_fine": 0.0426,
        "order": 1.1606,
        "finest_error": 0.0344,
    },
}


def _surfaces(elements: tuple[int, int, int], surfaces: str) -> tuple[Any, Any]:
    """The interface's and contact interface's quads (y, z): None is the model's default."""
    ny, nz = elements[1], elements[2]
    if surfaces == "matching":
        return (ny, nz), (ny, nz)
    if surfaces == "coarse":
        coarse = (max(1, ny // 2), max(1, nz // 2))
        return coarse, coarse
    return None, None  # non-matching: one in five fewer


def wall_forces(settings: dict[str, Any]) -> tuple[float, np.ndarray, int]:
    """One run: its step, the wall force after every step and its contact state changes."""
    from dd_contact.paper.models import parallelepiped

    elements = tuple(settings["elements"])
    interface, contact = _surfaces(elements, settings["surfaces"])
    scene = parallelepiped(
        elements,
        split=tuple(settings["split"]),
        interface=interface,
        contact=contact,
        period=PERIOD,
        contact_kappa=settings["contact_kappa"],
        comm=MPI.COMM_SELF,
    )
    dt = settings["dt"]
    problem = TransientProblem(
        scene,
        dt,
        algorithm=settings["algorithm"],
        mass=settings["mass"],
        track_energy=False,
        expected_steps=round(PERIOD / dt),
    )
    forces = []
    for _ in range(round(PERIOD / dt)):
        problem.advance()
        forces.append(float(np.linalg.norm(problem.history[-1]["force"]["end"])))
    return dt, np.array(forces), int(problem.changes["gamma"])


def windows(dt: float, forces: np.ndarray, window: float = WINDOW) -> np.ndarray:
    """Forces (steps first) averaged over each ``window`` [s] (a step must divide it)."""
    per = round(window / dt)
    if not np.isclose(per * dt, window) or len(forces) % per:
        raise ValueError(f"dt = {dt:g} s does not divide the window of {window:g} s")
    return forces.reshape(-1, per, *forces.shape[1:]).mean(axis=1)


def tilted_error(settings: dict[str, Any]) -> dict[str, Any]:
    """A run's relative L2 error of its windowed wall force against :data:`REFERENCE`."""
    dt, forces, changes = wall_forces(settings)
    mine, exact = windows(dt, forces), np.asarray(REFERENCE["windows"])
    parts = {
        "peak_force": float(mine.max() / exact.max() - 1.0),
        "impulse": float(mine.sum() / exact.sum() - 1.0),
        "changes": changes,
        "steps": len(forces),
    }
    return {"error": float(np.linalg.norm(mine - exact) / np.linalg.norm(exact)), "parts": parts}


def richardson(runs: list[tuple[float, np.ndarray]], window: float = WINDOW) -> dict[str, float]:
    """The finest of three runs' own error, from their differences (mesh and step halved).

    ``runs``: (dt, forces) coarse to fine, compared by their :func:`windows`: d1 = |W1 -
    W2|, d2 = |W2 - W3| (relative to |W3|), the observed order p = log2(d1 / d2) and the
    finest run's estimated error d2 / (2^p - 1).
    """
    w1, w2, w3 = (windows(dt, f, window) for dt, f in runs)
    d1 = float(np.linalg.norm(w1 - w2) / np.linalg.norm(w3))
    d2 = float(np.linalg.norm(w2 - w3) / np.linalg.norm(w3))
    order = float(np.log2(d1 / d2))
    return {"difference_coarse": d1, "difference_fine": d2, "order": order,
            "finest_error": d2 / (2.0**order - 1.0)}  # fmt: skip
