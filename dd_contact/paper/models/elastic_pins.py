"""Elastic pins for the multi-pin joint: each pin a steel subdomain in contact pairs.

``pin_joint(..., pins="elastic")`` replaces each rigid :class:`~dd_contact.Cylinder` by a
pin of its own (a hexahedral butterfly mesh: a square core and four O-grid patches, made by
gmsh) spanning both plates, held at its two ends, and pairs each hole wall's contact
interface with the pin's surface within that plate (:class:`~dd_contact.ContactPair`, the
hole wall as side a). The pin's surface nodes lie on its circle at the hole wall's angles,
so the faceted gap is the clearance everywhere.
"""

from __future__ import annotations

from types import ModuleType

from mpi4py import MPI

import dolfinx.io.gmsh
import dolfinx.mesh
import numpy as np

from dd_contact.meshes import _gmsh_model
from dd_contact.paper.models.common import STEEL
from dd_contact.problem import StaticProblem
from dd_contact.scene import ContactInterface, ContactPair
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "PIN_SIDES",
    "elastic_pin",
    "elastic_pins",
    "pin_mesh",
    "pin_pairs",
    "towards_rigid",
]

#: The pins' contact surfaces: within the lower plate (z < t) and within the upper one.
PIN_SIDES = ("lower", "upper")


def pin_mesh(
    comm: MPI.Comm,
    centre: tuple[float, float],
    radius: float,
    length: float,
    cells_quarter: int,
    layers: int,
    phase: float = 0.5,
) -> dolfinx.mesh.Mesh:
    """Hexahedra of a solid round pin along z from 0 to ``length``: a butterfly grid by gmsh.

    ``cells_quarter`` cells along each quarter of the circle (and each side of the square
    core), as many from the core to the circle; ``layers`` through the length. The circle's
    nodes are at the angles ``2 pi (phase + i) / (4 cells_quarter)`` from +x, the angles of
    :func:`~dd_contact.meshes.cylinder_surface` with the same count and phase.
    """
    with _gmsh_model("pin", {"General.Terminal": 0}) as gmsh:
        _pin_model(gmsh, centre, radius, length, cells_quarter, layers, phase)
        return dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3).mesh


def _pin_model(
    gmsh: ModuleType,
    centre: tuple[float, float],
    radius: float,
    length: float,
    n: int,
    layers: int,
    phase: float,
) -> None:
    """Build and mesh the butterfly grid of :func:`pin_mesh` in the current gmsh model."""
    geo = gmsh.model.geo
    cx, cy = centre
    middle = geo.addPoint(cx, cy, 0.0)
    # the quarters' corners: nodes of the circle, n cells apart
    angles = 2 * np.pi * phase / (4 * n) + np.arange(4) * np.pi / 2
    core = 0.45 * radius  # the square core's half diagonal
    rim = [geo.addPoint(cx + radius * np.cos(a), cy + radius * np.sin(a), 0.0) for a in angles]
    square = [geo.addPoint(cx + core * np.cos(a), cy + core * np.sin(a), 0.0) for a in angles]
    arcs = [geo.addCircleArc(rim[i], middle, rim[(i + 1) % 4]) for i in range(4)]
    sides = [geo.addLine(square[i], square[(i + 1) % 4]) for i in range(4)]
    spokes = [geo.addLine(square[i], rim[i]) for i in range(4)]
    for curve in arcs + sides + spokes:
        geo.mesh.setTransfiniteCurve(curve, n + 1)
    loops = [geo.addCurveLoop(sides)]
    for i in range(4):
        loops.append(geo.addCurveLoop([sides[i], spokes[(i + 1) % 4], -arcs[i], -spokes[i]]))
    patches = []
    for loop in loops:
        patch = geo.addPlaneSurface([loop])
        geo.mesh.setTransfiniteSurface(patch)
        geo.mesh.setRecombine(2, patch)
        patches.append((2, patch))
    extruded = geo.extrude(patches, 0, 0, length, numElements=[layers], recombine=True)
    geo.synchronize()
    gmsh.model.addPhysicalGroup(3, [tag for dim, tag in extruded if dim == 3], 1)
    gmsh.model.mesh.generate(3)


def elastic_pin(
    name: str,
    centre: tuple[float, float],
    radius: float,
    thickness: float,
    cells_quarter: int,
    layers: int,
    material: Material,
) -> Subdomain:
    """A pin through both plates (0 <= z <= 2 thickness), held at its two ends."""
    mesh = pin_mesh(MPI.COMM_SELF, centre, radius, 2 * thickness, cells_quarter, 2 * layers)
    pin = Subdomain(mesh, material, name)
    top = 2 * thickness
    pin.fix(lambda x: np.isclose(x[2], 0.0) | np.isclose(x[2], top))
    return pin


def pin_pairs(
    pin: Subdomain,
    walls: dict[str, ContactInterface],
    centre: tuple[float, float],
    radius: float,
    thickness: float,
) -> list[ContactPair]:
    """The pairs of each hole wall (side a) with the pin's surface within its plate.

    ``walls``: ``{"lower" | "upper": the hole wall's contact interface (no obstacle)}``.
    """
    cx, cy = centre
    pairs = []
    for k, plate in enumerate(PIN_SIDES):
        if plate not in walls:
            continue
        z0, z1 = k * thickness, (k + 1) * thickness
        tol = 1e-6 * radius

        def lateral(x, z0=z0, z1=z1):
            on_circle = np.isclose(np.hypot(x[0] - cx, x[1] - cy), radius, atol=tol)
            return on_circle & (x[2] >= z0 - tol) & (x[2] <= z1 + tol)

        side = ContactInterface.from_boundary(pin, lateral, None, name=f"{pin.name}_{plate}")
        wall = walls[plate]
        pairs.append(ContactPair(wall, side, name=f"{wall.name}-{side.name}"))
    return pairs


def elastic_pins(
    model, walls: dict, pins, radii: np.ndarray, material: Material
) -> tuple[list[Subdomain], list[ContactPair]]:
    """The pins of the joint's meshes ``model`` (:class:`PinJointMeshes`) and their pairs.

    ``walls``: the hole walls' contact interfaces by hole block name (``upper2``, ...);
    ``pins``: the pin numbers; ``radii``: each pin's radius.
    """
    lay = model.layout
    thick = lay.thickness * 1e-3
    subdomains, pairs = [], []
    for k in pins:
        centre = model.holes[f"lower{k}"]
        pin = elastic_pin(
            f"pin{k}", centre, radii[k], thick, lay.n_circumferential, lay.n_layers, material
        )
        plates = {p: walls[f"{p}{k}"] for p in PIN_SIDES}
        subdomains.append(pin)
        pairs += pin_pairs(pin, plates, centre, radii[k], thick)
    return subdomains, pairs


def _static_pull(scene, t: float) -> tuple[np.ndarray, float]:
    """Each pin's force on the upper plate (|F|, N), the upper grip end's mean y displacement.

    Solved statically at load time ``t``.
    """
    with StaticProblem(scene) as problem:
        problem.solve(t)
        forces = problem.contact_forces()
        grip = next(s for s in scene.subdomains if s.name == "upper_grip")
        x = grip.V.tabulate_dof_coordinates()
        end = np.isclose(x[:, 1], x[:, 1].max())
        u_end = float(grip.u.x.array.reshape(-1, 3)[end, 1].mean())
    upper = sorted(name for name in forces if name.startswith("hole_upper"))
    return np.array([np.linalg.norm(forces[name]) for name in upper]), u_end


def towards_rigid(
    scale,
    factors: tuple[float, ...] = (1.0, 10.0, 100.0),
    pin_material: Material | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dict:
    """The elastic-pin joint against the rigid-pin one as the pins' Young's modulus grows.

    Both without clearance (the pins touch the holes: a static solve is defined), pulled to
    the load's peak (t = period / 4). Per factor f (E_pin = f E_steel): each pin's force on
    the upper plate and the upper grip end's displacement along the load, and their
    relative differences to the rigid model's.
    """
    from dd_contact.paper.models.pin_joint import pin_joint  # which imports this module

    base = STEEL if pin_material is None else pin_material
    period = 2e-3
    rigid_forces, rigid_u = _static_pull(
        pin_joint(scale, clearance=0.0, period=period, comm=comm), period / 4
    )
    rows = []
    for f in factors:
        material = Material(f * base.E, base.nu, base.rho)
        scene = pin_joint(
            scale, clearance=0.0, period=period, pins="elastic", pin_material=material, comm=comm
        )
        forces, u = _static_pull(scene, period / 4)
        rows.append(
            {
                "factor": f,
                "E_pin": f * base.E,
                "pin_forces": forces.tolist(),
                "u_end": u,
                "force_difference": float(np.abs(forces - rigid_forces).max() / rigid_forces.max()),
                "u_difference": (u - rigid_u) / rigid_u,
            }
        )
    return {"rigid_forces": rigid_forces.tolist(), "rigid_u_end": rigid_u, "rows": rows}
