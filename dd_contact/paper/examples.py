"""Scenes for benchmarks, demos and tests.

The paper's parallelepiped (method.md 7.1) pressed on a wall (the benchmark scene; the
model itself is :mod:`dd_contact.paper.models`), and a row of blocks with many contact
interfaces. Benchmarks and demos build their models here, so that every algorithm
runs the same problem.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np

from dd_contact import meshes
from dd_contact.obstacles import Plane
from dd_contact.paper.models.parallelepiped import LAYOUTS, bar_scene
from dd_contact.scene import (
    ContactInterface,
    Interface,
    Scene,
)
from dd_contact.subdomains import Material, Subdomain

__all__ = ["PARALLELEPIPED_LAYOUTS", "parallelepiped", "row_of_blocks"]

#: How the bar is modelled for each algorithm (:data:`dd_contact.paper.models.LAYOUTS`).
PARALLELEPIPED_LAYOUTS = {a: layout for a, layout in LAYOUTS.items() if a is not None}


def parallelepiped(
    algorithm: str,
    elements: tuple[int, int, int] = (40, 10, 4),
    split: tuple[int, int] = (1, 1),
    element_size: float = 1e-3,
    speed: float = 1.0,
    tilt: float = 5e-4,
    pressure: float = 2.0e7,
    ramp: float = 1e-5,
    contact_kappa: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """The bar of method.md 7.1 pressed with one end on a rigid wall, for a given algorithm.

    The benchmark scene (``benchmarks/decomposition_speed.py``): the decomposition of
    :func:`dd_contact.paper.models.bar_scene` with matching surfaces, free of supports. A steel bar
    of ``elements`` 8-node hexahedra (size ``element_size``), long in x, moves at ``speed``
    towards a rigid plane through the origin whose normal is tilted by ``tilt`` (radians)
    about z: the bar's end touches it along the edge y = 0 first, and the contact area then
    grows across the face by about ``speed * dt / (tilt * element_size)`` element rows per
    time step dt, while a pressure (ramped up over ``ramp`` seconds) pushes the far end.
    For the decomposition orders it is cut across x in the ratio ``split`` into two
    subdomains tied by an interface mesh on the cut; contact is on a contact interface
    covering the end face of the first subdomain, or on that face itself, as
    :data:`PARALLELEPIPED_LAYOUTS` says.

    Args:
        algorithm: The algorithm the scene is for (a key of :data:`PARALLELEPIPED_LAYOUTS`).
        elements: Hexahedra along x, y, z.
        split: Omega1 : Omega2 (element layers along x in this ratio).
        element_size: Edge of the cubic elements [m].
        speed: Initial speed towards the wall [m/s].
        tilt: Angle between the wall and the end face [rad].
        pressure: Pressure on the far end [Pa].
        ramp: Time over which the pressure rises from zero [s].
        contact_kappa: Dimensionless contact penalty (impact wants a soft one).
        comm: Communicator.
    """
    nx, ny, nz = elements
    length = nx * element_size

    def move_and_press(parts: list[Subdomain]) -> None:
        for part in parts:
            part.velocity.interpolate(lambda x: np.vstack([-speed + 0 * x[0], 0 * x[0], 0 * x[0]]))
        parts[-1].add_traction(
            lambda x: np.isclose(x[0], length),
            lambda t: [-pressure * min(t / ramp, 1.0), 0.0, 0.0],
        )

    return bar_scene(
        elements,
        [n * element_size for n in elements],
        split,
        interface=(ny, nz),
        contact=(ny, nz),
        layout=PARALLELEPIPED_LAYOUTS[algorithm],
        wall=Plane([0.0, 0.0, 0.0], [np.cos(tilt), np.sin(tilt), 0.0]),
        contact_kappa=contact_kappa,
        setup=move_and_press,
        comm=comm,
    )


def row_of_blocks(
    n_blocks: int = 5,
    elements: tuple[int, int, int] = (12, 3, 3),
    block: tuple[float, float, float] = (4.0, 1.0, 1.0),
    gap: float = 1e-3,
    speed: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """Blocks in a row along x, glued end to end, each flying up against a rigid ceiling.

    Many contact interfaces, each on its own subdomain: the top face of every block is a
    contact interface (``top0``, ``top1``, ...) against the plane ``z = height + gap``. The
    blocks are tied through one interface mesh made of the end faces between neighbours
    (``n_blocks - 1`` separate rectangles). The top faces are long and the end faces small,
    so the contact interfaces together are much larger than the interface.

    Args:
        n_blocks: Number of blocks (subdomains).
        elements: Hexahedra of each block along x, y, z.
        block: Edges of each block.
        gap: Distance between the blocks' tops and the ceiling at the start.
        speed: Initial upward speed.
        comm: Communicator.
    """
    if n_blocks < 2:
        raise ValueError(f"a row needs at least 2 blocks, got {n_blocks}")
    (nx, ny, nz), (a, b, c) = elements, block
    material = Material(1000.0, 0.3, 1.0)
    parts = [
        Subdomain(
            meshes.box(MPI.COMM_SELF, [k * a, 0, 0], [(k + 1) * a, b, c], [nx, ny, nz]),
            material,
            f"B{k}",
        )
        for k in range(n_blocks)
    ]
    for part in parts:
        part.velocity.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], speed + 0 * x[0]]))
    points: list[np.ndarray] = []
    cells: list[np.ndarray] = []
    for k in range(1, n_blocks):
        p, q = meshes.rectangle_grid(
            np.array([k * a, 0.0, 0.0]),
            np.array([0.0, b, 0]),
            np.array([0, 0, c]),
            ny,
            nz,
            "quadrilateral",
        )
        cells.append(q + sum(len(x) for x in points))
        points.append(p)
    ends = meshes.surface_mesh(MPI.COMM_SELF, np.vstack(points), np.vstack(cells), "quadrilateral")
    interface = Interface(ends, parts, name="ends")
    ceiling = Plane([0.0, 0.0, c + gap], [0.0, 0.0, -1.0])
    contacts = [
        ContactInterface.from_boundary(
            part, lambda x: np.isclose(x[2], c), ceiling, resolution=(nx, ny), name=f"top{k}"
        )
        for k, part in enumerate(parts)
    ]
    return Scene(comm, parts, interface, contacts=contacts)
