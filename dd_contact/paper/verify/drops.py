"""Bodies dropped on a rigid plane: 3-D impacts beyond the 1-D bar, with the default settings.

A falling block (a box of any proportions flying at a plane, lateral faces free) and an
elastic hemisphere dropped pole first. Nothing holds them but the plane while they touch,
the loads do no work: the energy after the drop must equal the energy before, never more
(``docs/contact.md``, "Impact"). :func:`drop` runs any of their scenes and can trace the
contact history step by step, to compare algorithms.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.models import Record, locator
from dd_contact.paper.verify.orders import displacements
from dd_contact.problem import TransientProblem
from dd_contact.scene import (
    ContactBoundary,
    ContactInterface,
    Interface,
    Scene,
)
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "DROP",
    "ENERGY_SLACK",
    "box_drop_scene",
    "case_falling_block",
    "case_sphere_drop",
    "drop",
    "energy_record",
    "falling_block",
    "hemisphere_drop_scene",
    "sphere_drop",
    "wave_speed",
]

#: The dropped bodies: E = rho = 1, nu = 0.3 (P-wave speed ~1.16), speed 0.01 of it.
DROP = {"E": 1.0, "nu": 0.3, "rho": 1.0, "v0": 0.01}

#: Energy after / before may exceed 1 by this much (round-off), never more.
ENERGY_SLACK = 1e-6


def wave_speed(E: float, nu: float, rho: float) -> float:
    """The P-wave (dilatational) speed ``sqrt(E (1 - nu) / ((1 + nu)(1 - 2 nu) rho))``."""
    return float(np.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu) * rho)))


def box_drop_scene(
    size: tuple[float, float, float] = (1.0, 1.0, 1.0),
    cells: tuple[int, int, int] = (4, 4, 4),
    nu: float = DROP["nu"],
    v0: float = DROP["v0"],
    contact: str = "boundary",
    split: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """A box ``[0, Lx] x [0, Ly] x [0, Lz]`` flying at ``-v0`` along x onto the plane x = 0.

    It touches the plane at t = 0 (its end face on it); nothing else holds it. The bar of
    :func:`dd_contact.paper.verify.bar_impact` is such a box, long and thin with nu = 0.

    Args:
        size: Edge lengths.
        cells: Hexahedra along each edge (``cells[0]`` even with ``split``).
        nu: Poisson's ratio (E = rho = 1).
        v0: Speed towards the plane.
        contact: ``"boundary"`` (on the box's own end face) or ``"interface"`` (a contact
            interface, the end face's copy, tied to it).
        split: Cut the box at x = Lx / 2 into two subdomains tied by an interface mesh
            (the second one is meshed one cell finer across: non-matching).
        comm: Communicator.
    """
    (L, b, c), (n, ny, nz) = size, cells
    material = Material(DROP["E"], nu, DROP["rho"])
    cuts = [(0.0, L / 2, n // 2, 0), (L / 2, L, n - n // 2, 1)] if split else [(0.0, L, n, 0)]
    parts = [
        Subdomain(
            meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x1, b, c], [m, ny + extra, nz + extra]),
            material,
            f"box{k}" if split else "box",
        )
        for k, (x0, x1, m, extra) in enumerate(cuts)
    ]
    for part in parts:
        part.velocity.interpolate(
            lambda x: np.vstack([np.full(x.shape[1], -v0), 0 * x[0], 0 * x[0]])
        )
    interface = None
    if split:
        interface = Interface.from_boundary(parts[0], locator(0, L / 2), parts, resolution=(ny, nz))
    wall = Plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    zone: ContactBoundary | ContactInterface
    if contact == "boundary":
        zone = ContactBoundary(parts[0], locator(0, 0.0), wall, name="end")
    else:
        zone = ContactInterface.from_boundary(
            parts[0], locator(0, 0.0), wall, resolution=(ny, nz), name="end"
        )
    return Scene(comm, parts, interface, contacts=[zone])


def hemisphere_drop_scene(
    h_contact: float = 0.1,
    h_far: float = 0.4,
    v0: float = DROP["v0"],
    gap: float = 0.0,
    contact: str = "boundary",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """A quarter hemisphere (R = 1) falling pole first at ``-v0`` onto the plane z = -gap.

    Rollers on its symmetry planes x = 0 and y = 0. The mesh is
    :func:`dd_contact.meshes.hemisphere` (size ``h_contact`` near the pole, ``h_far`` away);
    the cap below z = 0.3 R may touch.
    """
    R = 1.0
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, 0.3 * R, h_contact, h_far)
    ball = Subdomain(mesh, Material(DROP["E"], DROP["nu"], DROP["rho"]), "ball")
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    ball.velocity.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], np.full(x.shape[1], -v0)]))
    cap = ball.locate_facets((tags, meshes.HEMISPHERE_CURVED))
    mid = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap)].mean(axis=1)
    near = cap[mid[:, 2] < 0.3 * R]
    plane = Plane([0.0, 0.0, -gap], [0.0, 0.0, 1.0])
    zone: ContactBoundary | ContactInterface
    if contact == "boundary":
        zone = ContactBoundary(ball, near, plane, name="cap")
    else:
        zone = ContactInterface.from_boundary(ball, near, plane, name="cap")
    return Scene(comm, [ball], contacts=[zone])


def drop(
    scene: Scene,
    dt: float,
    n_steps: int,
    algorithm: str = "FULL",
    trace: bool = False,
) -> dict:
    """Collective: run a dropped body with the default settings; its energy and contact.

    Returns ``energy_ratio`` (total energy at the end / at the start), ``changes``
    (gamma), ``release_solves``, ``episodes`` (steps in contact of each contact episode,
    the last one open if ``touching_at_end``, the points in contact after the last step),
    ``history`` (state changes per step), and with
    ``trace`` the ``active`` sets (per step, region -> points; this rank's regions) and the
    ``states`` (:func:`dd_contact.paper.verify.displacements` after each step).
    """
    active: list[dict[str, np.ndarray]] = []
    states: list[np.ndarray] = []

    def observe(_):
        active.append({name: a.copy() for name, a in problem.iteration.active.items()})
        states.append(displacements(scene))

    with TransientProblem(scene, dt, algorithm=algorithm) as problem:
        problem.start()
        before = problem.energy()["total"]
        history = problem.run(
            n_steps, progress=False, summary=False, callback=observe if trace else None
        )
        result = {
            "energy_ratio": problem.energy()["total"] / before,
            "changes": problem.changes["gamma"],
            "release_solves": problem.iteration.release_solves,
            "history": [r["changes"] for r in history],
            "episodes": _episodes([sum(r["active"].values()) for r in history]),
            "touching_at_end": sum(history[-1]["active"].values()),
            "steps": n_steps,
        }
    if trace:
        result.update(active=active, states=np.array(states))
    return result


def _episodes(touching: list[int]) -> list[int]:
    """Steps of each run of steps with a point in contact."""
    runs, length = [], 0
    for count in touching:
        if count:
            length += 1
        elif length:
            runs.append(length)
            length = 0
    return runs + ([length] if length else [])


def falling_block(
    n: int = 4,
    cfl: float = 0.5,
    end_time: float = 6.0,
    contact: str = "boundary",
    split: bool = False,
    algorithm: str = "FULL",
    comm: MPI.Comm = MPI.COMM_WORLD,
    trace: bool = False,
) -> dict:
    """A unit cube of n^3 hexahedra landing flat on a plane at 0.01 c (:func:`drop`).

    ``dt = cfl h / c`` (h = 1 / n, c the P-wave speed); ``end_time`` in units of 1 / c
    (about 2 / c in contact, then it flies off ringing).
    """
    c = wave_speed(DROP["E"], DROP["nu"], DROP["rho"])
    scene = box_drop_scene(cells=(n, n, n), contact=contact, split=split, comm=comm)
    dt = cfl / n / c
    return drop(scene, dt, round(end_time / c / dt), algorithm, trace)


def sphere_drop(
    steps_per_contact: float = 40,
    h_contact: float = 0.1,
    end_time: float = 1.5,
    contact: str = "boundary",
    algorithm: str = "FULL",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dict:
    """An elastic hemisphere (R = 1) dropped on a plane at 0.01 c (:func:`drop`).

    The time step is Hertz's contact duration ``t_H = 2.87 (m^2 / (R E*^2 v0))^(1/5)``
    (rigid plane, E* = E / (1 - nu^2), m the hemisphere's mass) over
    ``steps_per_contact``; the run lasts ``end_time`` t_H after first touch (the pole
    starts 3 steps above the plane). Also returns ``duration_hertz`` and ``duration``
    (steps in the first contact episode times dt).
    """
    E, nu, rho, v0 = DROP["E"], DROP["nu"], DROP["rho"], DROP["v0"]
    mass = rho * 2.0 / 3.0 * np.pi
    t_hertz = 2.87 * (mass**2 / ((E / (1 - nu**2)) ** 2 * v0)) ** 0.2
    dt = t_hertz / steps_per_contact
    scene = hemisphere_drop_scene(h_contact, v0=v0, gap=3 * v0 * dt, contact=contact, comm=comm)
    result = drop(scene, dt, round(end_time * steps_per_contact) + 3, algorithm)
    result["duration_hertz"] = float(t_hertz)
    result["duration"] = result["episodes"][0] * dt if result["episodes"] else 0.0
    return result


# -- the cases of ``dd-contact verify`` -----------------------------------------------------
def energy_record(case: str, ratio: float) -> Record:
    """Energy after / before within [0.98, 1 + 1e-6]: never created, at most 2 % lost."""
    passed = 0.98 <= ratio <= 1 + ENERGY_SLACK
    return Record(
        case, "energy after / before in [0.98, 1 + 1e-6]", ratio, 1.0, abs(ratio - 1), 0.02, passed
    )


def case_falling_block() -> list[Record]:
    """The falling block at two meshes and two time steps, default settings.

    The steps resolve the contact (over MIN_CONTACT_STEPS each: no CoarseTimeStepWarning);
    tests/test_drops.py runs coarser ones.
    """
    out = []
    for n, cfl in ((4, 0.15), (4, 0.075), (8, 0.25)):
        r = falling_block(n=n, cfl=cfl)
        out.append(energy_record(f"falling-block n={n} cfl={cfl}", r["energy_ratio"]))
    return out


def case_sphere_drop() -> list[Record]:
    """The dropped hemisphere at two time steps, default settings (contact resolved)."""
    out = []
    for steps in (80, 160):
        r = sphere_drop(steps_per_contact=steps)
        out.append(energy_record(f"sphere-drop t_H/dt={steps}", r["energy_ratio"]))
    return out
