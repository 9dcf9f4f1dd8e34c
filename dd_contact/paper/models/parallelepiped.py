"""The paper's rectangular parallelepiped (method.md 7.1) as a finite element model.

A steel bar 400 x 100 x 10 mm of 8-node hexahedra at any resolution (``scale="paper"``:
400 x 100 x 10 hexahedra, 1,336,533 dofs), cut across its length into two independently
meshed subdomains in any ratio, tied through an interface mesh on the cut; its end x = 0
faces a rigid wall, on a contact interface of its own resolution. Interface and contact
interface are not copies of the subdomains' faces unless asked.

:func:`parallelepiped` is the model: the far end clamped, the bar shaken along its axis by a
periodic body force, so that its free end closes on the wall and opens again every period.
:func:`bar_scene` builds the bar's decomposition with any supports and loads; the benchmark
scene :func:`dd_contact.paper.examples.parallelepiped` uses it too.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from typing import cast

from mpi4py import MPI

import numpy as np

from dd_contact import meshes
from dd_contact.errors import InputError
from dd_contact.obstacles import Plane
from dd_contact.paper.flops.paper import PAPER_BAR
from dd_contact.paper.models.common import STEEL
from dd_contact.scene import (
    ContactBoundary,
    ContactInterface,
    Interface,
    Scene,
)
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "BAR_SCALES",
    "BAR_SIZE",
    "LAYOUTS",
    "bar_elements",
    "bar_scene",
    "parallelepiped",
]

#: Edges of the bar [m]: the paper's hexahedra at 1 mm.
BAR_SIZE = (0.4, 0.1, 0.01)
#: Hexahedra of the named scales ("paper" is method.md 7.1).
BAR_SCALES = {"paper": PAPER_BAR.elements, "small": (80, 20, 2), "tiny": (20, 5, 1)}

#: How the bar is modelled for each algorithm: split in two or one mesh, contact on a
#: contact interface or on the subdomain's own boundary. ``None``: the scene every
#: algorithm with an interface and a contact interface runs (FULL, v-w-u, w-v-u).
LAYOUTS = {
    None: ("split", "interface"),
    "FULL": ("one mesh", "boundary"),
    "v-w-u": ("split", "interface"),
    "w-v-u": ("split", "interface"),
    "w-u": ("one mesh", "interface"),
    "v-u": ("split", "boundary"),
}


def bar_elements(scale: str | float | Sequence[int]) -> tuple[int, ...]:
    """Hexahedra along x, y, z for a scale.

    A name of :data:`BAR_SCALES`, a fraction of the paper's resolution per direction (at
    least one element), or three counts.
    """
    if isinstance(scale, str):
        if scale not in BAR_SCALES:
            raise InputError(
                f"parallelepiped: scale {scale!r} is not one of {sorted(BAR_SCALES)}; give a "
                "name, a fraction of the paper's resolution or three element counts"
            )
        return BAR_SCALES[scale]
    if np.ndim(scale) == 0:
        fraction = cast(float, scale)  # a number, numpy's too
        if not float(fraction) > 0.0:
            raise InputError(f"parallelepiped: scale must be positive, got {scale}")
        return tuple(max(1, round(n * float(fraction))) for n in PAPER_BAR.elements)
    given = cast(Sequence[int], scale)
    counts = tuple(int(n) for n in given)
    if len(counts) != 3 or min(counts) < 1 or list(counts) != list(given):
        raise InputError(
            f"parallelepiped: scale {scale!r} must be three positive element counts (nx, ny, nz)"
        )
    return counts


def _coarser(n: int) -> int:
    """The default surface resolution along an edge of n elements: one in five fewer."""
    return max(1, n - max(1, n // 5)) if n > 1 else 1


def bar_scene(
    elements: Sequence[int],
    size: Sequence[float] = BAR_SIZE,
    split: Sequence[int] = PAPER_BAR.split,
    interface: Sequence[int] | None = None,
    contact: Sequence[int] | None = None,
    layout: tuple[str, str] = LAYOUTS[None],
    wall: Plane | None = None,
    material: Material = STEEL,
    contact_kappa: float | None = None,
    setup: Callable[[list[Subdomain]], None] | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """The bar's decomposition, with the supports and loads ``setup`` adds.

    Subdomains ``Omega1`` (from x = 0) and ``Omega2``, the interface (named ``interface``) on
    the cut, and the contact region ``end``: the face x = 0 against ``wall``.

    Args:
        elements: Hexahedra along x, y, z.
        size: Edges of the bar [m].
        split: Omega1 : Omega2, element layers along x in this ratio (rounded).
        interface: Quads of the interface mesh on the cut (y, z); default one in five fewer
            than the subdomains' faces (non-matching).
        contact: Quads of the contact interface on the end face; default as ``interface``.
        layout: ``("split" | "one mesh", "interface" | "boundary")``, see :data:`LAYOUTS`.
        wall: The rigid obstacle the end x = 0 faces (default the plane x = 0).
        material: The bar's material.
        contact_kappa: Dimensionless contact penalty (default the package's).
        setup: Called with the subdomains to add supports, loads and initial velocities
            before the contact and interface are built.
        comm: Communicator of the scene.
    """
    nx, ny, nz = (int(n) for n in elements)
    length, width, height = (float(a) for a in size)
    h = length / nx
    interface = interface or (_coarser(ny), _coarser(nz))
    contact = contact or (_coarser(ny), _coarser(nz))
    cuts = [0, nx]
    if layout[0] == "split":
        first = round(nx * split[0] / sum(split))
        if not 0 < first < nx:
            raise InputError(
                f"parallelepiped: split {tuple(split)} leaves an empty subdomain of {nx} element "
                "layers; give a ratio of positive integers or more layers"
            )
        cuts = [0, first, nx]
    parts = [
        Subdomain(
            meshes.box(MPI.COMM_SELF, [a * h, 0, 0], [b * h, width, height], [b - a, ny, nz]),
            material,
            f"Omega{k + 1}",
        )
        for k, (a, b) in enumerate(itertools.pairwise(cuts))
    ]
    if setup is not None:
        setup(parts)
    tie = None
    if len(parts) == 2:
        x_cut = cuts[1] * h
        tie = Interface.from_boundary(
            parts[0],
            lambda x: np.isclose(x[0], x_cut),
            parts,
            resolution=cast(tuple[int, int], tuple(interface)),
        )
    wall = wall or Plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    zone: ContactInterface | ContactBoundary
    end = lambda x: np.isclose(x[0], 0.0)  # noqa: E731
    if layout[1] == "interface":
        zone = ContactInterface.from_boundary(
            parts[0], end, wall, resolution=cast(tuple[int, int], tuple(contact)),
            contact_kappa=contact_kappa, name="end",
        )  # fmt: skip
    else:
        zone = ContactBoundary(parts[0], end, wall, contact_kappa=contact_kappa, name="end")
    return Scene(comm, parts, tie, contacts=[zone])


def parallelepiped(
    scale: str | float | Sequence[int] = "small",
    algorithm: str | None = None,
    split: Sequence[int] = PAPER_BAR.split,
    interface: Sequence[int] | None = None,
    contact: Sequence[int] | None = None,
    gap: float = 2e-6,
    tilt: float = 2e-5,
    body_force: float | None = None,
    period: float = 4e-3,
    contact_kappa: float | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """The paper's bar, clamped at x = 0.4 m and shaken against a rigid wall at its other end.

    The wall is the plane at distance ``gap`` from the end face x = 0, tilted by ``tilt``
    about z, so that the gap grows from ``gap`` at y = 0 to ``gap + 0.1 tilt`` at y = 0.1 m.
    A body force ``body_force * sin(2 pi t / period)`` along -x pushes the free end onto the
    wall for half a period and pulls it off for the other half: the contact closes row by row
    and opens again in every period. The default amplitude closes the widest gap twice over
    in a static solve (end displacement ``b L^2 / (2E)``); the default period is about 13
    times the bar's first axial period (0.31 ms), so the response is nearly quasi-static.

    Args:
        scale: ``"paper"`` (400 x 100 x 10), ``"small"`` (80 x 20 x 2), ``"tiny"``
            (20 x 5 x 1), a fraction of the paper's resolution, or (nx, ny, nz).
        algorithm: Build the layout this algorithm needs (:data:`LAYOUTS`); ``None``: split
            in two with a contact interface, the scene FULL, v-w-u and w-v-u all run.
        split: Omega1 : Omega2 (Omega1 holds the contact end).
        interface: Quads of the interface (y, z); default non-matching (one in five fewer).
        contact: Quads of the contact interface (y, z); default non-matching likewise.
        gap: Gap between the end face and the wall at y = 0 [m].
        tilt: Angle between the wall and the end face [rad].
        body_force: Amplitude of the body force [N/m^3]; default as above.
        period: Period of the load [s].
        contact_kappa: Dimensionless contact penalty (default the package's).
        comm: Communicator.
    """
    if algorithm not in LAYOUTS:
        names = sorted(a for a in LAYOUTS if a is not None)
        raise InputError(
            f"parallelepiped: algorithm {algorithm!r} is not one of {names} (or None for the "
            "scene FULL, v-w-u and w-v-u share)"
        )
    for argument, value in (("gap", gap), ("period", period)):
        if not value > 0.0:
            raise InputError(f"parallelepiped: {argument} must be positive, got {value}")
    elements = bar_elements(scale)
    length, width, _ = BAR_SIZE
    widest = gap + width * np.sin(tilt)
    amplitude = 4.0 * STEEL.E * widest / length**2 if body_force is None else body_force

    def clamp_and_shake(parts: list[Subdomain]) -> None:
        parts[-1].fix(lambda x: np.isclose(x[0], length))
        for part in parts:
            part.set_body_force(lambda t: [-amplitude * np.sin(2 * np.pi * t / period), 0.0, 0.0])

    wall = Plane([-gap, 0.0, 0.0], [np.cos(tilt), np.sin(tilt), 0.0])
    return bar_scene(
        elements, BAR_SIZE, split, interface, contact, LAYOUTS[algorithm], wall,
        contact_kappa=contact_kappa, setup=clamp_and_shake, comm=comm,
    )  # fmt: skip
