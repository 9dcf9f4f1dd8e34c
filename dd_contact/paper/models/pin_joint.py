"""The paper's multi-pin joint (method.md 7.2) as a finite element model.

Two steel plates lapped over each other, joined by a row of rigid pins. The dimensions are
those of :class:`dd_contact.paper.flops.PinJointLayout` (in mm there, in m here): 10 mm plates,
300 mm wide, 20 mm holes at a 60 mm pitch, 270 mm grips. Each plate is cut into a hole
block per hole (``pitch x pitch``, an O-grid of hexahedra made by gmsh) and a grip; the
lower plate lies in 0 <= z <= t with its grip towards -y, the upper one on top of it with
its grip towards +y, their hole strips 0 <= y <= pitch over each other. One interface
mesh covers every cut of both plates; every hole wall of every plate is a contact
interface of its own (a cylinder mesh with nodes on the circle, turned half a cell from
the wall's nodes) against its pin, a :class:`~dd_contact.Cylinder` ``clearance`` thinner
than the hole.

The upper plate is pulled and pushed along y at its grip's end by ``load * sin(2 pi t /
period)``, that end guided in x and z. The lower plate (``lower="pulled"``, the default)
takes the opposite load at its grip's end, guided the same way: the joint in tension, the
pins passing the load from one plate to the other, so both plates bear on them. With
``lower="clamped"`` the lower plate is clamped at its grip's end and nothing pushes it onto
the pins, which then carry the upper plate's load to the ground alone.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

from mpi4py import MPI

import basix.ufl
import dolfinx.mesh
import numpy as np
import ufl

from dd_contact import meshes
from dd_contact.decomposition import ContactCandidate, DecomposedScene, decompose
from dd_contact.errors import InputError
from dd_contact.obstacles import Cylinder
from dd_contact.paper.flops.paper import PinJointLayout
from dd_contact.paper.models.common import FACE_TAGS, STEEL, block_tags
from dd_contact.paper.models.elastic_pins import elastic_pins
from dd_contact.scene import ContactInterface, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "LOWER_PLATE_SUPPORTS",
    "PIN_JOINT_SCALES",
    "PIN_KINDS",
    "PinJointMeshes",
    "pin_joint",
    "pin_joint_layout",
    "pin_joint_meshes",
    "pin_joint_one_mesh",
]

#: Element counts of the named scales; "paper" is PinJointLayout's 174,080 hexahedra.
PIN_JOINT_SCALES = {
    "paper": {},
    "small": {"n_circumferential": 4, "n_radial": 3, "n_layers": 2, "n_length": 12},
    "tiny": {"n_circumferential": 2, "n_radial": 2, "n_layers": 1, "n_length": 4},
}
#: mm of PinJointLayout to m.
MM = 1e-3
#: The pins: rigid cylinders (the paper's) or elastic subdomains in contact pairs.
PIN_KINDS = ("rigid", "elastic")
#: How the lower plate is held: pulled by the upper plate's load reversed, or clamped.
LOWER_PLATE_SUPPORTS = ("pulled", "clamped")


def pin_joint_layout(scale: str | PinJointLayout = "small") -> PinJointLayout:
    """The joint at a named scale (:data:`PIN_JOINT_SCALES`) or as given."""
    if isinstance(scale, PinJointLayout):
        return scale
    if scale not in PIN_JOINT_SCALES:
        raise InputError(
            f"pin_joint: scale {scale!r} is not one of {sorted(PIN_JOINT_SCALES)}; give a name "
            "or a dd_contact.paper.flops.PinJointLayout"
        )
    return dataclasses.replace(PinJointLayout(), **PIN_JOINT_SCALES[scale])


@dataclass
class PinJointMeshes:
    """The meshes of the joint (metres), each on one rank's communicator.

    Attributes:
        layout: The joint (dimensions in mm).
        subdomains: ``{name: (hexahedral mesh, facet tags)}``: ``lower0..``, ``lower_grip``,
            ``upper0..``, ``upper_grip``; tags :data:`FACE_TAGS`.
        holes: ``{subdomain name: (x, y) of its hole's axis}``.
        plates: ``{subdomain name: "lower" | "upper"}``.
        interface: The surface mesh of every cut of both plates.
        walls: ``{subdomain name: surface mesh of its hole wall}``.
    """

    layout: PinJointLayout
    subdomains: dict[str, tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]]
    holes: dict[str, tuple[float, float]]
    plates: dict[str, str]
    interface: dolfinx.mesh.Mesh
    walls: dict[str, dolfinx.mesh.Mesh]


def pin_joint_meshes(
    scale: str | PinJointLayout = "small", wall_cells: int | None = None
) -> PinJointMeshes:
    """Every mesh of the joint (see the module's description).

    Args:
        scale: A name of :data:`PIN_JOINT_SCALES` or a :class:`PinJointLayout`.
        wall_cells: Cells around each hole wall's contact interface (default as many as the
            plate has around the hole; no more, or the surface is finer than its wall,
            docs/contact.md).
    """
    lay = pin_joint_layout(scale)
    c, r, t, h = lay.n_circumferential, lay.n_radial, lay.n_layers, lay.n_holes
    pitch, thick, grip = lay.pitch * MM, lay.thickness * MM, lay.free_length * MM
    radius, width = lay.hole_diameter * MM / 2, h * pitch
    around = 4 * c if wall_cells is None else int(wall_cells)
    subdomains, holes, plates, walls = {}, {}, {}, {}
    # interface rectangles: origin, e1, e2, n1, n2
    pieces: list[tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], int, int]] = []
    for plate, z0, grip_y in (
        ("lower", 0.0, (-grip, 0.0)),
        ("upper", thick, (pitch, pitch + grip)),
    ):
        for k in range(h):
            name = f"{plate}{k}"
            lower, upper = (k * pitch, 0.0, z0), ((k + 1) * pitch, pitch, z0 + thick)
            mesh = meshes.hole_block(MPI.COMM_SELF, lower, pitch, radius, thick, c, r, t)
            centre = ((k + 0.5) * pitch, 0.5 * pitch)
            subdomains[name] = (mesh, block_tags(mesh, lower, upper, (centre, radius)))
            holes[name], plates[name] = centre, plate
            walls[name] = meshes.cylinder_surface(
                MPI.COMM_SELF, (*centre, z0), radius, thick, around, t, phase=0.5
            )
            if k > 0:
                pieces.append(((k * pitch, 0.0, z0), (0, pitch, 0), (0, 0, thick), c, t))
        lower, upper = (0.0, grip_y[0], z0), (width, grip_y[1], z0 + thick)
        mesh = meshes.box(MPI.COMM_SELF, lower, upper, (h * c, lay.n_length, t))
        subdomains[f"{plate}_grip"] = (mesh, block_tags(mesh, lower, upper))
        plates[f"{plate}_grip"] = plate
        cut_y = pitch if plate == "upper" else 0.0
        pieces.append(((0.0, cut_y, z0), (width, 0, 0), (0, 0, thick), h * c, t))
    points: list[np.ndarray] = []
    cells: list[np.ndarray] = []
    for origin, e1, e2, n1, n2 in pieces:
        p, q = meshes.rectangle_grid(
            np.array(origin), np.array(e1, float), np.array(e2, float), n1, n2, "quadrilateral"
        )
        cells.append(q + sum(len(x) for x in points))
        points.append(p)
    interface = meshes.surface_mesh(
        MPI.COMM_SELF, np.vstack(points), np.vstack(cells), "quadrilateral"
    )
    return PinJointMeshes(lay, subdomains, holes, plates, interface, walls)


def _pin(hole: str, plates: dict[str, str]) -> int:
    """The pin of a hole block (``upper3`` -> 3)."""
    return int(hole.removeprefix(plates[hole]))


def pin_joint(
    scale: str | PinJointLayout = "small",
    clearance: float | Sequence[float] = 0.05e-3,
    load: float = 20e3,
    period: float = 2e-3,
    wall_cells: int | None = None,
    lower: str = "pulled",
    contact_pins: Sequence[int] | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    pins: str = "rigid",
    pin_material: Material = STEEL,
    walls: str = "cylinders",
    friction: float = 0.0,
) -> Scene:
    """The multi-pin joint: 12 subdomains, 1 interface, 10 contact interfaces, 5 pins.

    Args:
        scale: ``"paper"`` (174,080 hexahedra), ``"small"`` (1,920), ``"tiny"`` (240), or a
            :class:`PinJointLayout`.
        clearance: Hole radius minus pin radius [m] (0: the pins touch the hole walls); one
            per pin to choose which pins the upper plate strikes.
        load: Amplitude of the force on the upper plate's grip end, along +y [N].
        period: Period of the load [s]; ``load * sin(2 pi t / period)``.
        wall_cells: Cells around each contact interface (default the plate's).
        lower: ``"pulled"``: the lower plate's grip end takes the load reversed (along -y),
            guided in x and z like the upper one's, so both plates bear on the pins;
            ``"clamped"``: it is clamped, and only the upper plate's walls touch the pins.
        contact_pins: The pins whose holes carry contact interfaces (both plates' walls;
            default all): the paper's "holes in contact" (docs/cost.md), the other holes
            are free.
        comm: Communicator.
        pins: ``"rigid"`` (the paper's: each hole wall against a :class:`Cylinder`) or
            ``"elastic"``: each pin a subdomain of ``pin_material`` through both plates, held
            at its two ends, in a :class:`ContactPair` with each of its hole walls
            (:mod:`~dd_contact.paper.models.elastic_pins`): 12 + 5 subdomains.
        pin_material: The elastic pins' material (default steel).
        walls: ``"cylinders"`` (each wall's contact interface a cylinder mesh of its own,
            turned half a cell from the wall's nodes) or ``"facets"`` (a copy of the wall's
            facets, as :func:`pin_joint_one_mesh` builds them; rigid pins only).
        friction: Coulomb's mu of the hole walls on their rigid pins (0: frictionless;
            docs/contact.md, "Friction").
    """
    _check_options(lower, clearance, period)
    _check_kinds(pins, walls, friction)
    model = pin_joint_meshes(scale, wall_cells)
    lay = model.layout
    radius, thick = lay.hole_diameter * MM / 2, lay.thickness * MM
    gaps = _pin_clearances(clearance, lay.n_holes, radius)
    in_contact = _holes_in_contact(contact_pins, lay.n_holes)
    width = lay.n_holes * lay.pitch * MM
    parts = {name: Subdomain(mesh, STEEL, name) for name, (mesh, _) in model.subdomains.items()}
    tags = {name: t for name, (_, t) in model.subdomains.items()}
    _load_grips(parts, tags, load / (width * thick), period, lower)
    interface = Interface(model.interface, list(parts.values()), name="cuts")
    # The wall's nodes lie on the circle, off the plate's facet chords by up to a sagitta.
    sagitta = radius * (1.0 - np.cos(np.pi / (4 * lay.n_circumferential)))
    zones = {}
    for name, (x, y) in model.holes.items():
        if _pin(name, model.plates) not in in_contact:
            continue
        pin = Cylinder([x, y, 0.0], [0.0, 0.0, 1.0], radius - gaps[_pin(name, model.plates)])
        if walls == "facets":
            hole = (tags[name], FACE_TAGS["hole"])
            zones[name] = ContactInterface.from_boundary(
                parts[name], hole, pin, friction=friction, name=f"hole_{name}"
            )
            continue
        obstacle = None if pins == "elastic" else pin
        zones[name] = ContactInterface(
            model.walls[name], parts[name], obstacle, tolerance=2.0 * sagitta,
            friction=friction, name=f"hole_{name}",
        )  # fmt: skip
    if pins == "rigid":
        return Scene(comm, list(parts.values()), interface, contacts=list(zones.values()))
    pin_parts, pairs = elastic_pins(model, zones, in_contact, radius - gaps, pin_material)
    return Scene(comm, [*parts.values(), *pin_parts], interface, contacts=pairs)


def pin_joint_one_mesh(
    scale: str | PinJointLayout = "small",
    clearance: float | Sequence[float] = 0.05e-3,
    load: float = 20e3,
    period: float = 2e-3,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> DecomposedScene:
    """The joint's two plates as one mesh, cut by :func:`~dd_contact.decompose`.

    The hexahedra of :func:`pin_joint_meshes` in one mesh of two bodies (nodes shared within
    a plate, not between the plates), every cell tagged with its hand-built subdomain's
    number, so that ``parts=`` those tags gives the same cells (part k is the k-th subdomain
    of :func:`pin_joint_meshes`); every hole wall a candidate against its pin, the grips
    loaded as ``pin_joint(lower="pulled")``'s. Its hand-built twin: ``pin_joint(scale,
    walls="facets")`` (docs/decompose.md: they agree to round-off).
    """
    _check_options("pulled", clearance, period)
    model = pin_joint_meshes(scale)
    lay = model.layout
    radius, thick, pitch = lay.hole_diameter * MM / 2, lay.thickness * MM, lay.pitch * MM
    gaps = _pin_clearances(clearance, lay.n_holes, radius)
    mesh, tags = _one_mesh(model)
    candidates = []
    for plate, z0 in (("lower", 0.0), ("upper", thick)):
        for k in range(lay.n_holes):
            centre = ((k + 0.5) * pitch, 0.5 * pitch)

            def wall(x, c=centre, z0=z0):
                on = np.hypot(x[0] - c[0], x[1] - c[1]) < radius * 1.001
                return on & (x[2] > z0 - 1e-9 * thick) & (x[2] < z0 + thick * (1 + 1e-9))

            pin = Cylinder([*centre, 0.0], [0.0, 0.0, 1.0], radius - gaps[k])
            candidates.append(ContactCandidate(wall, pin, name=f"hole_{plate}{k}"))
    scene = decompose(mesh, STEEL, parts=tags, contacts=candidates, margin=radius, comm=comm)
    stress = load / (lay.n_holes * pitch * thick)
    grip = lay.free_length * MM
    for sign, y in ((1.0, pitch + grip), (-1.0, -grip)):

        def end(x, y=y):
            return np.isclose(x[1], y)

        def pull(t, s=sign):
            return [0.0, s * stress * np.sin(2 * np.pi * t / period), 0.0]

        scene.fix(end, components=[0, 2])
        scene.add_traction(end, pull)
    return scene


def _one_mesh(model: PinJointMeshes) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """The subdomain meshes as one (nodes merged within a plate) and each cell's subdomain."""
    points: list[np.ndarray] = []
    cells, numbers = [], []
    names = list(model.subdomains)
    for plate in ("lower", "upper"):
        mine = [n for n in names if model.plates[n] == plate]
        x = np.vstack([model.subdomains[n][0].geometry.x for n in mine])
        key = np.round(x / (1e-9 * np.ptp(x))).astype(np.int64)  # coincident nodes: one
        _, first, merged = np.unique(key, axis=0, return_index=True, return_inverse=True)
        merged, start, base = merged.ravel(), 0, sum(len(p) for p in points)
        for n in mine:
            sub = model.subdomains[n][0]
            cells.append(merged[start + sub.geometry.dofmaps[0]] + base)
            numbers.append(np.full(len(sub.geometry.dofmaps[0]), names.index(n)))
            start += len(sub.geometry.x)
        points.append(x[first])
    element = basix.ufl.element("Lagrange", "hexahedron", 1, shape=(3,))
    mesh = dolfinx.mesh.create_mesh(
        MPI.COMM_SELF, np.vstack(cells).astype(np.int64), ufl.Mesh(element), np.vstack(points)
    )
    number = np.concatenate(numbers)[mesh.topology.original_cell_index].astype(np.int32)
    every = np.arange(len(number), dtype=np.int32)
    return mesh, dolfinx.mesh.meshtags(mesh, 3, every, number)


def _check_options(lower: str, clearance: float | Sequence[float], period: float) -> None:
    """The checks of :func:`pin_joint` that need no mesh, made before the meshes are built."""
    if lower not in LOWER_PLATE_SUPPORTS:
        raise InputError(
            f"pin_joint: lower={lower!r} is not a support of the lower plate; give one of "
            f"{LOWER_PLATE_SUPPORTS}"
        )
    if not np.all(np.atleast_1d(np.asarray(clearance, float)) >= 0.0):
        raise InputError(f"pin_joint: clearance must be >= 0, got {clearance}")
    if not period > 0.0:
        raise InputError(f"pin_joint: period must be positive, got {period}")


def _check_kinds(pins: str, walls: str, friction: float) -> None:
    """The pins, the walls and the friction of :func:`pin_joint`: each fits the others."""
    if pins not in PIN_KINDS:
        raise InputError(f"pin_joint: pins={pins!r} is not one of {PIN_KINDS}")
    if friction and pins != "rigid":
        raise InputError(
            f"pin_joint: friction={friction!r} with pins={pins!r}: friction is on the hole "
            "walls against rigid pins; give pins='rigid' or friction=0"
        )
    if walls not in ("cylinders", "facets") or (walls == "facets" and pins != "rigid"):
        raise InputError(
            f"pin_joint: walls={walls!r} with pins={pins!r}: give walls='cylinders', or "
            "walls='facets' with rigid pins"
        )


def _pin_clearances(clearance: float | Sequence[float], n_pins: int, radius: float) -> np.ndarray:
    """Each pin's clearance [m], given as one number or one per pin; each below the radius."""
    gaps = np.atleast_1d(np.asarray(clearance, float))
    if len(gaps) not in (1, n_pins):
        raise InputError(
            f"pin_joint: clearance has {len(gaps)} values for {n_pins} pins; give one "
            "number, or one per pin"
        )
    if not np.all(gaps < radius):
        raise InputError(f"pin_joint: clearance {clearance} m leaves no pin in a {radius} m hole")
    return np.broadcast_to(gaps, (n_pins,))


def _holes_in_contact(contact_pins: Sequence[int] | None, n_pins: int) -> Sequence[int]:
    """The pins whose holes carry contact interfaces (all if None), checked and sorted."""
    pins = range(n_pins) if contact_pins is None else sorted(set(contact_pins))
    if not pins or not all(isinstance(k, int | np.integer) and 0 <= k < n_pins for k in pins):
        raise InputError(
            f"pin_joint: contact_pins {contact_pins} must be pin numbers 0..{n_pins - 1} "
            "(at least one), the pins whose holes carry contact interfaces"
        )
    return pins


def _load_grips(
    parts: dict[str, Subdomain],
    tags: dict[str, dolfinx.mesh.MeshTags],
    stress: float,
    period: float,
    lower: str,
) -> None:
    """The upper grip end pulled along +y; the lower one clamped or pulled back (along -y)."""

    def pull(sign):
        return lambda t: [0.0, sign * stress * np.sin(2 * np.pi * t / period), 0.0]

    upper_end = (tags["upper_grip"], FACE_TAGS["y1"])
    parts["upper_grip"].fix(upper_end, components=[0, 2])
    parts["upper_grip"].add_traction(upper_end, pull(1.0))
    lower_end = (tags["lower_grip"], FACE_TAGS["y0"])
    if lower == "clamped":
        parts["lower_grip"].fix(lower_end)
    else:  # the support's reaction, which the pins pass to the upper plate
        parts["lower_grip"].fix(lower_end, components=[0, 2])
        parts["lower_grip"].add_traction(lower_end, pull(-1.0))
