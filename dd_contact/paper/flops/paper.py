"""The paper's two examples as scene-size generators (method.md 7.1 and 7.2).

* The rectangular parallelepiped (:func:`parallelepiped_sizes`): a structured bar cut across x
  into two subdomains; every size has a closed form.
* The multi-pin lap joint (:class:`PinJointLayout`, :func:`pin_joint_mesh_counts`,
  :func:`pin_joint_sizes`): closed forms for the node and dof counts; the plate's half-bandwidth
  is computed on its mesh, generated here (numpy only, no mesher) as O-grid hole blocks next to
  a structured grip.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dd_contact.paper.flops.bandwidth import half_bandwidth_box
from dd_contact.paper.flops.model import (
    ContactCounts,
    MeshCounts,
    SceneSizes,
    SubdomainCounts,
    check_positive,
    is_int,
)

__all__ = [
    "PAPER_BAR",
    "PaperBar",
    "PinJointLayout",
    "parallelepiped_sizes",
    "pin_joint_mesh_counts",
    "pin_joint_sizes",
    "split_layers",
]


# --------------------------------------------------------------------------- paper's bar


@dataclass(frozen=True)
class PaperBar:
    """The paper's rectangular parallelepiped and its efficiency study (method.md 7.1).

    The one place these numbers live: the operation-count model (:func:`parallelepiped_sizes`,
    :func:`~dd_contact.paper.flops.studies.parallelepiped_studies`) and the finite element model
    (:func:`dd_contact.paper.models.parallelepiped` at ``scale="paper"``) both read them.

    Attributes:
        elements: Hexahedra along x (long, cut direction), y, z.
        split: Element layers of subdomain 1 : subdomain 2.
        interface: Quads of the interface mesh on the cut.
        contact: Quads of the contact interface on the end face of subdomain 1.
        steps: Time steps ``N_TS`` of the study.
        changes: Contact state changes ``alpha = gamma`` of the study.
    """

    elements: tuple[int, int, int] = (400, 100, 10)
    split: tuple[int, int] = (5, 5)
    interface: tuple[int, int] = (100, 10)
    contact: tuple[int, int] = (100, 10)
    steps: int = 10000
    changes: int = 20000


#: The paper's bar: 400 x 100 x 10 hexahedra, 1,336,533 dofs, cut 5:5.
PAPER_BAR = PaperBar()


def split_layers(nx: int, split: tuple[int, int]) -> tuple[int, int]:
    """Element layers of the bar's two subdomains for the ratio ``split``.

    Args:
        nx: Element layers of the whole bar (along the cut direction).
        split: Ratio of layers in subdomain 1 : subdomain 2, positive integers.

    Returns:
        The layers of subdomain 1 and 2.

    Raises:
        ValueError: If ``split`` is not positive or does not divide ``nx`` layers evenly.
    """
    a, b = split
    check_positive("split[0]", a)
    check_positive("split[1]", b)
    if (nx * a) % (a + b) != 0:
        raise ValueError(f"split {a}:{b} does not divide {nx} element layers evenly")
    layers1 = nx * a // (a + b)
    return layers1, nx - layers1


def parallelepiped_sizes(
    elements: tuple[int, int, int] = PAPER_BAR.elements,
    split: tuple[int, int] = PAPER_BAR.split,
    interface: tuple[int, int] = PAPER_BAR.interface,
    contact: tuple[int, int] = PAPER_BAR.contact,
    steps: int = PAPER_BAR.steps,
    changes: int = PAPER_BAR.changes,
) -> SceneSizes:
    """Scene of the paper's rectangular parallelepiped (method.md 7.1).

    The bar of ``nx x ny x nz`` hexahedra (3 dofs per node) is cut across x into two subdomains
    of ``nx * split[0] / sum(split)`` and the remaining element layers, so subdomain ``k`` has
    ``(layers + 1)(ny + 1)(nz + 1) * 3`` dofs. Each subdomain (and the whole bar) is numbered
    structurally with its longest direction slowest and its shortest fastest
    (:func:`half_bandwidth_box`): for the paper's 400 x 100 x 10 bar this is x slowest and
    ``B = 3372`` for the bar and both halves; a subdomain shorter than ``ny`` layers is numbered
    y slowest and gets a smaller bandwidth (40 x 100 x 10 at 1:9: ``B = 3 (42 * 11 + 2) =
    1392``). Interface and contact interface are structured quad meshes, ``(m0 + 1)(m1 + 1) * 3``
    dofs; the interface ties the whole cut of both subdomains; the contact interface sits on the
    far end face of subdomain 1 (index 0). ``alpha = gamma = changes``. ``"FULL"`` and ``"w-u"``
    use the whole bar, ``(nx+1)(ny+1)(nz+1) * 3`` dofs.

    Args:
        elements: Hexahedra along x (long, cut direction), y, z.
        split: Ratio of element layers in subdomain 1 : subdomain 2.
        interface: Quads of the interface mesh on the cut.
        contact: Quads of the contact interface mesh.
        steps: ``N_TS``.
        changes: ``alpha = gamma``.

    Returns:
        The scene.

    Raises:
        ValueError: If the split does not give whole, non-empty element layers.
    """
    nx, ny, nz = elements
    for name, v in (("nx", nx), ("ny", ny), ("nz", nz)):
        check_positive(name, v)
    layers = split_layers(nx, split)
    if min(layers) < 1:
        raise ValueError(f"split {split} leaves an empty subdomain")
    per_layer = (ny + 1) * (nz + 1) * 3
    subdomains = tuple(
        SubdomainCounts(f"Omega{i + 1}", (n + 1) * per_layer, half_bandwidth_box(n, ny, nz))
        for i, n in enumerate(layers)
    )
    for name, mesh in (("interface", interface), ("contact", contact)):
        for v in mesh:
            check_positive(name, v)
    quad_dofs = [(m0 + 1) * (m1 + 1) * 3 for m0, m1 in (interface, contact)]
    return SceneSizes(
        subdomains=subdomains,
        contacts=(ContactCounts("Gamma_C1", quad_dofs[1], 0, changes),),
        interface_dofs=quad_dofs[0],
        n_steps=steps,
        gamma=changes,
        whole=MeshCounts("Omega", (nx + 1) * per_layer, half_bandwidth_box(nx, ny, nz)),
    )


# --------------------------------------------------------------------------- multi-pin joint


@dataclass(frozen=True)
class PinJointLayout:
    """A steel lap joint: two plates with a row of holes, pinned (method.md 7.2).

    Each plate (thickness ``thickness``) is ``n_holes * pitch`` wide (x) and ``pitch +
    free_length`` long (y): a hole strip of ``n_holes`` square hole blocks ``pitch x pitch`` with
    a centred hole of ``hole_diameter``, then the free (grip) part ``free_length`` long. The
    upper and lower plates overlap over their hole strips, their grips point in opposite
    directions, and a rigid pin of the hole diameter passes through each pair of holes.

    Mesh (8-node hexahedra, 3 dofs per node, conforming inside a plate): each hole block is an
    O-grid, ``4 n_circumferential`` elements around the hole (``n_circumferential`` along each
    side of the block), ``n_radial`` from the hole to the block's boundary, ``n_layers`` through
    the thickness; the grip is a structured ``n_holes n_circumferential x n_length x n_layers``
    box. The decomposition has ``2 (n_holes + 1)`` subdomains (each hole block and each grip),
    one interface (the cuts between hole blocks and between the hole strip and the grip, in both
    plates, meshed like the subdomain faces) and ``2 n_holes`` contact interfaces (each hole's
    cylindrical surface, meshed like the hole).

    The defaults (20 mm pins at a 60 mm pitch, edge distance 30 mm, 10 mm plates 300 mm wide
    and 330 mm long, 3.75 mm elements on the block sides and in the grip, 0.98 mm around the
    hole) give 174,080 hexahedra and 201,672 nodes, close to the paper's 173,250 and 197,472.

    Attributes:
        hole_diameter: Hole (pin) diameter, mm.
        pitch: Hole spacing = hole block side, mm.
        thickness: Plate thickness, mm.
        free_length: Length of each plate beyond the hole strip, mm.
        n_holes: Holes (pins) in the row.
        n_circumferential: Elements along each side of a hole block (a quarter of the hole).
        n_radial: Elements from the hole to the hole block's boundary.
        n_layers: Elements through the thickness.
        n_length: Elements along the grip's length.
    """

    hole_diameter: float = 20.0
    pitch: float = 60.0
    thickness: float = 10.0
    free_length: float = 270.0
    n_holes: int = 5
    n_circumferential: int = 16
    n_radial: int = 16
    n_layers: int = 8
    n_length: int = 72

    def __post_init__(self) -> None:
        for name in ("n_holes", "n_circumferential", "n_radial", "n_layers", "n_length"):
            check_positive(name, getattr(self, name))
        if not 0.0 < self.hole_diameter < self.pitch:
            raise ValueError("need 0 < hole_diameter < pitch")
        if self.thickness <= 0.0 or self.free_length <= 0.0:
            raise ValueError("thickness and free_length must be positive")


def pin_joint_mesh_counts(layout: PinJointLayout | None = None) -> dict[str, int]:
    """Node, element, dof and bandwidth counts of the multi-pin joint's meshes.

    Closed forms (``c, r, t, y, h`` = ``n_circumferential, n_radial, n_layers, n_length,
    n_holes``, ``g = h c`` grip elements across the width):

    * hole block: ``4 c (r + 1)(t + 1)`` nodes, ``4 c r t`` hexahedra; half-bandwidth of the
      better of two zig-zag O-grid numberings (ring position slowest, visited 0, 1, -1, 2, -2,
      ... so that ring neighbours are at most 2 apart: ``3 ((2 r + 3)(t + 1) + 2)``; or radial
      layer slowest with the same zig-zag inside each ring: ``3 ((4 c + 2)(t + 1) + 2)``);
    * grip: ``(g + 1)(y + 1)(t + 1)`` nodes, ``g y t`` hexahedra, :func:`half_bandwidth_box`;
    * plate: ``[4 h c (r + 1) - (h - 1)(c + 1) + (g + 1) y](t + 1)`` nodes (neighbouring hole
      blocks share a side, the grip shares the strip's edge), ``4 h c r t + g y t`` hexahedra;
      its half-bandwidth is computed (see :func:`_plate_half_bandwidth`); the whole model is
      both plates numbered one after the other, so it has the plate's half-bandwidth;
    * contact interface (a hole's surface): ``4 c (t + 1)`` nodes, ``4 c t`` quadrilaterals;
    * interface: in each plate the ``h - 1`` cuts between hole blocks (``c x t`` quads each) and
      the cut between strip and grip (``g x t``), one surface mesh (the short cuts end on the
      long one): ``((2 h - 1) c + 1)(t + 1)`` nodes per plate;
    * tied interface dofs ``D_V^(k)``: an end hole block touches its top and one side,
      ``3 (2 c + 1)(t + 1)``; an inner hole block its top and two sides, ``3 (3 c + 1)(t + 1)``;
      the grip the long cut, ``3 (g + 1)(t + 1)``; a single hole block its top only.

    Args:
        layout: The joint; the default :class:`PinJointLayout` if ``None``.

    Returns:
        A dict with keys ``hexahedra``, ``nodes``, ``dofs`` (whole model), ``half_bandwidth``
        (whole model), ``plate_*``, ``hole_block_*``, ``grip_*`` (``nodes``, ``hexahedra``,
        ``dofs``, ``half_bandwidth``), ``contact_nodes``, ``contact_quads``, ``contact_dofs``,
        ``interface_nodes``, ``interface_quads``, ``interface_dofs``, and
        ``tied_dofs_end_block``, ``tied_dofs_inner_block``, ``tied_dofs_grip``.
    """
    lay = layout or PinJointLayout()
    c, r, t = lay.n_circumferential, lay.n_radial, lay.n_layers
    y, h = lay.n_length, lay.n_holes
    g = h * c
    hole_nodes = 4 * c * (r + 1) * (t + 1)
    grip_nodes = (g + 1) * (y + 1) * (t + 1)
    plate_nodes = (4 * h * c * (r + 1) - (h - 1) * (c + 1) + (g + 1) * y) * (t + 1)
    plate_hex = h * 4 * c * r * t + g * y * t
    plate_b = _plate_half_bandwidth(lay)
    iface_nodes = 2 * ((2 * h - 1) * c + 1) * (t + 1)
    end_sides = 1 if h > 1 else 0  # an end block touches one side, a single block none
    return {
        "hexahedra": 2 * plate_hex,
        "nodes": 2 * plate_nodes,
        "dofs": 6 * plate_nodes,
        "half_bandwidth": plate_b,
        "plate_nodes": plate_nodes,
        "plate_hexahedra": plate_hex,
        "plate_dofs": 3 * plate_nodes,
        "plate_half_bandwidth": plate_b,
        "hole_block_nodes": hole_nodes,
        "hole_block_hexahedra": 4 * c * r * t,
        "hole_block_dofs": 3 * hole_nodes,
        "hole_block_half_bandwidth": 3 * (min(2 * r + 3, 4 * c + 2) * (t + 1) + 2),
        "grip_nodes": grip_nodes,
        "grip_hexahedra": g * y * t,
        "grip_dofs": 3 * grip_nodes,
        "grip_half_bandwidth": half_bandwidth_box(g, y, t),
        "contact_nodes": 4 * c * (t + 1),
        "contact_quads": 4 * c * t,
        "contact_dofs": 12 * c * (t + 1),
        "interface_nodes": iface_nodes,
        "interface_quads": 2 * (h - 1) * c * t + 2 * g * t,
        "interface_dofs": 3 * iface_nodes,
        "tied_dofs_end_block": 3 * ((1 + end_sides) * c + 1) * (t + 1),
        "tied_dofs_inner_block": 3 * (3 * c + 1) * (t + 1),
        "tied_dofs_grip": 3 * (g + 1) * (t + 1),
    }


def _hole_block_mesh(lay: PinJointLayout, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates (mm) and hexahedra of the O-grid hole block ``i`` (local numbering).

    Ring index ``a`` (counter-clockwise from the lower-left corner, ``c`` per block side),
    radial index ``b`` (0 on the hole), layer ``l``: node ``(a (r + 1) + b)(t + 1) + l``.
    Points on the block's boundary are integer multiples of the side element size, so that
    nodes shared with neighbours have bit-identical coordinates.
    """
    c, r, t = lay.n_circumferential, lay.n_radial, lay.n_layers
    n_ring, h_side = 4 * c, lay.pitch / c
    a = np.arange(n_ring)
    side, k = np.divmod(a, c)
    sq = np.select(  # boundary point in side-element units, relative to the block corner
        [(side == q)[:, None] for q in range(4)],
        [np.c_[k, 0 * k], np.c_[c + 0 * k, k], np.c_[c - k, c + 0 * k], np.c_[0 * k, c - k]],
    ) + np.array([i * c, 0])
    theta = np.deg2rad(225.0) + 0.5 * np.pi * a / c
    centre = np.array([(i + 0.5) * lay.pitch, 0.5 * lay.pitch])
    hole = centre + 0.5 * lay.hole_diameter * np.c_[np.cos(theta), np.sin(theta)]
    s = np.arange(r + 1) / r
    xy = hole[:, None, :] * (1.0 - s)[None, :, None] + (sq * h_side)[:, None, :] * s[None, :, None]
    z = np.arange(t + 1) * (lay.thickness / t)
    xyz = np.concatenate(
        [
            np.repeat(xy[:, :, None, :], t + 1, axis=2),
            np.broadcast_to(z[None, None, :, None], (n_ring, r + 1, t + 1, 1)),
        ],
        axis=3,
    ).reshape(-1, 3)
    idx = np.arange(xyz.shape[0]).reshape(n_ring, r + 1, t + 1)
    ia, ib, il = np.meshgrid(np.arange(n_ring), np.arange(r), np.arange(t), indexing="ij")
    ia1 = (ia + 1) % n_ring
    hexes = np.stack(
        [idx[aa, ib + db, il + dl] for aa in (ia, ia1) for db in (0, 1) for dl in (0, 1)], axis=-1
    ).reshape(-1, 8)
    return xyz, hexes


def _box_mesh(
    n: tuple[int, int, int], origin: Sequence[float], h: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and hexahedra of a structured box (x slowest, z fastest)."""
    axes = [origin[d] + np.arange(n[d] + 1) * h[d] for d in range(3)]
    xyz = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    idx = np.arange(xyz.shape[0]).reshape(n[0] + 1, n[1] + 1, n[2] + 1)
    i, j, k = np.meshgrid(*(np.arange(m) for m in n), indexing="ij")
    hexes = np.stack(
        [idx[i + di, j + dj, k + dk] for di in (0, 1) for dj in (0, 1) for dk in (0, 1)], axis=-1
    ).reshape(-1, 8)
    return xyz, hexes


def _plate_mesh(lay: PinJointLayout) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and hexahedra of one plate (hole blocks and grip, shared nodes merged)."""
    c, t = lay.n_circumferential, lay.n_layers
    g = lay.n_holes * c
    h_side = lay.pitch / c
    parts = [_hole_block_mesh(lay, i) for i in range(lay.n_holes)]
    parts.append(
        _box_mesh(
            (g, lay.n_length, t),
            (0.0, c * h_side, 0.0),
            (h_side, lay.free_length / lay.n_length, lay.thickness / t),
        )
    )
    offsets = np.cumsum([0] + [p[0].shape[0] for p in parts])
    xyz = np.concatenate([p[0] for p in parts])
    hexes = np.concatenate([p[1] + o for p, o in zip(parts, offsets[:-1], strict=True)])
    unique, inverse = np.unique(xyz, axis=0, return_inverse=True)
    return unique, inverse.ravel()[hexes]


def _span_half_bandwidth(rank: np.ndarray, hexes: np.ndarray, dofs_per_node: int) -> int:
    r = rank[hexes]
    return dofs_per_node * int((r.max(axis=1) - r.min(axis=1)).max()) + dofs_per_node


def _rank_of(order: np.ndarray) -> np.ndarray:
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank


def _best_half_bandwidth(xyz: np.ndarray, hexes: np.ndarray, dofs_per_node: int = 3) -> int:
    """Smallest half-bandwidth of four frontal numberings of a plate-like hexahedral mesh.

    For each in-plane axis ``a`` in (x, y): (1) lexicographic by coordinates, ``a`` slowest,
    then the other in-plane axis, z fastest; (2) Cuthill-McKee level structure from the face
    ``a = min`` (graph distance in element hops), inside a level by the other in-plane axis,
    then z. On a structured box numbering (1) with the longer axis is the natural numbering of
    :func:`half_bandwidth_structured_hex`.
    """
    n = xyz.shape[0]
    ranks = []
    for a in (0, 1):
        other = 1 - a
        ranks.append(_rank_of(np.lexsort((xyz[:, 2], xyz[:, other], xyz[:, a]))))
        level = np.full(n, -1, dtype=np.int64)
        front = xyz[:, a] == xyz[:, a].min()
        level[front] = 0
        depth = 0
        while front.any():  # next level: unvisited nodes of the cells touching the front
            depth += 1
            reached = np.zeros(n, dtype=bool)
            reached[hexes[front[hexes].any(axis=1)]] = True
            front = reached & (level < 0)
            level[front] = depth
        ranks.append(_rank_of(np.lexsort((xyz[:, 2], xyz[:, other], level))))
    return min(_span_half_bandwidth(rank, hexes, dofs_per_node) for rank in ranks)


@functools.lru_cache(maxsize=8)
def _plate_half_bandwidth(lay: PinJointLayout) -> int:
    """Half-bandwidth of one plate of the pin joint: :func:`_best_half_bandwidth` of its mesh.

    The mesh is generated here only as integer connectivity and node coordinates (numpy, no
    mesher): no closed form gives a good numbering of a row of O-grids next to a box. Cached.
    """
    xyz, hexes = _plate_mesh(lay)
    return _best_half_bandwidth(xyz, hexes)


def pin_joint_sizes(
    active_holes: int = 10,
    steps: int = 10000,
    changes: int = 20000,
    layout: PinJointLayout | None = None,
) -> SceneSizes:
    """Scene of the multi-pin joint (method.md 7.2) with ``active_holes`` holes in contact.

    Subdomains, in order: upper plate ``U-hole1 ... U-hole<h>``, ``U-grip``, then the lower
    plate ``L-...`` (:func:`pin_joint_mesh_counts` gives their sizes). Contact interfaces exist
    only on the holes in contact: pin 1 in the upper plate, pin 1 in the lower plate, pin 2 in
    the upper plate, ... (``active_holes`` of the ``2 n_holes`` holes). All of them change state
    together: ``alpha^(k) = gamma = changes``.

    The two plates touch only the (rigid) pins, so the whole model is two disjoint bodies and
    the interface two disjoint pieces; like the paper's model we still price the interface
    matrix and the coupled contact block of w-v-u and w-u as single dense matrices (an
    implementation that factorised each body's block separately would be cheaper there).

    Args:
        active_holes: Holes in contact, ``1 <= active_holes <= 2 n_holes``.
        steps: ``N_TS``.
        changes: ``gamma`` (and each ``alpha``).
        layout: The joint; the default :class:`PinJointLayout` if ``None``.

    Returns:
        The scene.
    """
    lay = layout or PinJointLayout()
    h = lay.n_holes
    if not is_int(active_holes) or not 1 <= active_holes <= 2 * h:
        raise ValueError(f"active_holes must be in 1..{2 * h}, got {active_holes!r}")
    m = pin_joint_mesh_counts(lay)
    subdomains = []
    for plate in "UL":
        for i in range(h):
            end = i in (0, h - 1)
            tied = m["tied_dofs_end_block"] if end else m["tied_dofs_inner_block"]
            subdomains.append(
                SubdomainCounts(
                    f"{plate}-hole{i + 1}",
                    m["hole_block_dofs"],
                    m["hole_block_half_bandwidth"],
                    tied,
                )
            )
        subdomains.append(
            SubdomainCounts(
                f"{plate}-grip", m["grip_dofs"], m["grip_half_bandwidth"], m["tied_dofs_grip"]
            )
        )
    contacts = []
    for j in range(active_holes):
        pin, side = divmod(j, 2)
        k = side * (h + 1) + pin
        contacts.append(
            ContactCounts(f"Gamma_C {subdomains[k].name}", m["contact_dofs"], k, changes)
        )
    return SceneSizes(
        subdomains=tuple(subdomains),
        contacts=tuple(contacts),
        interface_dofs=m["interface_dofs"],
        n_steps=steps,
        gamma=changes,
        whole=MeshCounts("Omega (both plates)", m["dofs"], m["half_bandwidth"]),
    )
