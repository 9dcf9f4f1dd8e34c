"""Every elimination order against FULL, on small block scenes whose contact state changes.

The blocks (:func:`blocks`, :func:`block_scene`) are the scenes tests, benchmarks and the
penalty sweep (:mod:`~dd_contact.paper.verify.extremes`) share; :func:`order_scene` makes
their contact state change; :func:`orders_agreement` runs each order and FULL on them.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.models import locator
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactBoundary, ContactInterface, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "ORDER_SCENES",
    "block_scene",
    "blocks",
    "displacements",
    "distort_in_plane",
    "order_scene",
    "orders_agreement",
]


#: Scene kinds of :func:`order_scene` and the decomposition orders each one admits.
ORDER_SCENES = {
    "interface": ("v-w-u", "w-v-u"),  # two blocks, an interface, a contact interface
    "boundary": ("v-u",),  # two blocks, an interface, contact on a block's own boundary
    "single": ("w-u",),  # one block with a contact interface
}


def blocks(kind: str, volume_cell: str = "hexahedron") -> list[Subdomain]:
    """The blocks of :func:`block_scene` (no loads, no supports).

    A = [0,1]^3 (4x3x3 cells) and, unless ``kind`` is ``"single"``, the non-matching
    B = [1,2]x[0,1]^2 (3x4x4 cells); E = 1000, nu = 0.3, rho = 1.
    """
    material = Material(1000.0, 0.3, 1.0)

    def box(x0: float, n: list[int]) -> dolfinx.mesh.Mesh:
        return meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x0 + 1, 1, 1], n, volume_cell)

    parts = [Subdomain(box(0.0, [4, 3, 3]), material, "A")]
    if kind != "single":
        parts.append(Subdomain(box(1.0, [3, 4, 4]), material, "B"))
    return parts


def block_scene(
    kind: str,
    parts: list[Subdomain],
    wall: Plane,
    comm: MPI.Comm,
    kappa: float | None = None,
    contact_tie_kappa: float | None = None,
    contact_kappa: float = 1.0,
    surface_cell: str = "quadrilateral",
    resolution: tuple[int, int] = (3, 3),
    distortion: float = 0.0,
) -> Scene:
    """The scene of :func:`blocks`: their surfaces and the rigid ``wall`` at A's end x = 0.

    ``kind`` (:data:`ORDER_SCENES`) says which surfaces there are: ``"interface"`` an
    interface on x = 1 and a contact interface on x = 0; ``"boundary"`` the interface and
    contact on A's own boundary; ``"single"`` a contact interface only. The surface meshes
    have ``resolution`` cells of ``surface_cell``; ``distortion`` moves their interior nodes
    in-plane (:func:`distort_in_plane`).
    """
    a = parts[0]

    def surface(x: float):
        mesh = meshes.surface_from_boundary(
            a.mesh, locator(0, x), resolution, surface_cell, comm=MPI.COMM_SELF
        )
        return distort_in_plane(mesh, distortion) if distortion else mesh

    interface = None
    if kind != "single":
        interface = Interface(surface(1.0), parts, kappa=kappa)
    zone: ContactBoundary | ContactInterface
    if kind == "boundary":
        zone = ContactBoundary(a, locator(0, 0.0), wall, contact_kappa=contact_kappa, name="end")
    else:
        zone = ContactInterface(
            surface(0.0), a, wall, kappa=contact_tie_kappa, contact_kappa=contact_kappa, name="end"
        )
    return Scene(comm, parts, interface, contacts=[zone])


def distort_in_plane(mesh: dolfinx.mesh.Mesh, amount: float) -> dolfinx.mesh.Mesh:
    """Move the interior nodes of a planar surface mesh within its plane (in place).

    Each interior node moves by up to ``amount`` times the shortest cell edge along each of
    two in-plane directions, in a fixed pseudo-random pattern of its position (the same on
    every rank); boundary nodes stay, so the mesh still covers the same region.
    """
    topology = mesh.topology
    topology.create_entities(1)
    topology.create_connectivity(1, 2)
    x = mesh.geometry.x
    edges = dolfinx.mesh.entities_to_geometry(
        mesh, 1, np.arange(topology.index_map(1).size_local, dtype=np.int32)
    )
    h = float(np.linalg.norm(x[edges[:, 1]] - x[edges[:, 0]], axis=1).min())
    outer = dolfinx.mesh.entities_to_geometry(
        mesh, 1, dolfinx.mesh.exterior_facet_indices(topology)
    )
    interior = np.setdiff1d(np.arange(len(x)), outer)
    _, _, axes = np.linalg.svd(x - x.mean(axis=0))
    phase = x[interior] @ np.array([12.9898, 78.233, 37.719])
    shift = np.sin(phase)[:, None] * axes[0] + np.cos(1.7 * phase + 0.5)[:, None] * axes[1]
    x[interior] += amount * h * shift
    return mesh


def order_scene(
    kind: str, dynamic: bool, kappa: float | None = None, comm: MPI.Comm = MPI.COMM_WORLD
) -> Scene:
    """A small scene whose contact state changes, for comparing elimination orders.

    Non-matching blocks A = [0,1]^3 and B = [1,2]x[0,1]^2 (``"single"``: A only) against a
    rigid wall at x = -0.002. Statically, the far end is pushed and tilted so part of the end
    face A touches and part lifts off; dynamically, both blocks fly at the wall with a
    velocity that varies across the section, so the contact area grows and shrinks.

    Args:
        kind: One of :data:`ORDER_SCENES`.
        dynamic: Flying blocks (for TransientProblem) instead of a pushed, held bar.
        kappa: Tie penalty of the interface and contact interface (default: the default).
        comm: Communicator.
    """
    parts = blocks(kind)
    far = parts[-1]
    if dynamic:
        for part in parts:
            part.velocity.interpolate(
                lambda x: np.vstack([-1.0 - 0.8 * (x[1] - 0.5), 0 * x[0], 0.2 + 0 * x[0]])
            )
    else:
        end = float(len(parts))
        far.fix(
            locator(0, end),
            value=lambda x: np.vstack([-0.004 - 0.02 * (x[1] - 0.5), 0 * x[0], 0 * x[0]]),
        )
    wall = Plane([-0.002, 0, 0], [1, 0, 0])
    return block_scene(kind, parts, wall, comm, kappa=kappa, contact_tie_kappa=kappa)


def displacements(scene: Scene) -> np.ndarray:
    """Every displacement of a scene (subdomains, interface, contacts) in one vector."""
    parts = [s.u.x.array for s in scene.subdomains]
    if scene.interface is not None:
        parts.append(scene.interface.v.x.array)
    return np.concatenate(parts)


def _run_order(kind, dynamic, kappa, order, comm, steps, dt):
    scene = order_scene(kind, dynamic, kappa, comm)
    problem: TransientProblem | StaticProblem
    if dynamic:
        problem = TransientProblem(scene, dt, algorithm=order)
        states: list[np.ndarray] = []
        problem.run(
            steps,
            progress=False,
            summary=False,
            callback=lambda _: states.append(displacements(scene)),
        )
        path = [r["changes"] for r in problem.history]
    else:
        problem = StaticProblem(scene, algorithm=order)
        problem.solve()
        states, path = [displacements(scene)], [problem.changes["gamma"]]
    return np.array(states), path, problem


def orders_agreement(
    kappa: float | None = 1e4,
    steps: int = 40,
    dt: float = 0.01,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> list[dict]:
    """Every decomposition order against FULL on the same scenes (static and dynamic).

    Returns:
        One dict per scene kind, static/dynamic and order: ``difference`` (largest over the
        steps of ||x - x_FULL|| / ||x_FULL||, x the subdomain and interface displacements),
        ``same_path`` (the contact state changes at the same steps) and ``changes`` (gamma).
    """
    out = []
    for kind, orders in ORDER_SCENES.items():
        for dynamic in (False, True):
            ref, ref_path, _ = _run_order(kind, dynamic, kappa, "FULL", comm, steps, dt)
            for order in orders:
                x, path, _ = _run_order(kind, dynamic, kappa, order, comm, steps, dt)
                diff = np.linalg.norm(x - ref, axis=1) / np.linalg.norm(ref, axis=1)
                out.append(
                    {
                        "scene": kind,
                        "dynamic": dynamic,
                        "order": order,
                        "difference": float(diff.max()),
                        "same_path": path == ref_path,
                        "changes": int(sum(path)),
                    }
                )
    return out
