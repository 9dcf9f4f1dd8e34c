"""One dolfinx mesh in, a scene out: the decomposition built for the user (``decompose``).

The parts are meshes of their own (:class:`~dd_contact.subdomains.Subdomain`, subdomain k on
rank ``k % size`` as in every scene), cut from the user's mesh by cell tags, by recursive
coordinate bisection or by planes (:mod:`dd_contact.partition`), or by the cut that puts the
surfaces that can touch an obstacle into a small part (``parts="auto"``). The interface is a
copy of the facets between parts, so it matches both sides and the tie is exact up to its
penalty. Contact interfaces are built only on the candidate surfaces that come within a
margin of their obstacle over the obstacle's prescribed motion; the rest are listed with
the reason (:attr:`DecomposedScene.decomposition`). Supports and loads are given on the
user's mesh and carried to the parts (:meth:`DecomposedScene.fix`, ...).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import ufl
from scipy.spatial import cKDTree

from dd_contact import arguments, meshes, partition
from dd_contact.arguments import Region
from dd_contact.errors import InputError, warn
from dd_contact.obstacles import Obstacle
from dd_contact.parallel import bcast_from_root
from dd_contact.partition import Whole
from dd_contact.prescribed import Value
from dd_contact.scene import ContactInterface, ContactPair, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "ContactCandidate",
    "DecomposedScene",
    "Decomposition",
    "LeftOut",
    "UnreachableObstacleWarning",
    "decompose",
]

#: The default margin of :func:`decompose`, as a fraction of the mesh's bounding-box diagonal.
DEFAULT_MARGIN = 0.05
#: What ``decompose(partitioner=...)`` takes for a number of parts.
PARTITIONERS = ("auto", "bisection", "scotch", "kahip")


class UnreachableObstacleWarning(UserWarning):
    """An obstacle that no candidate surface comes within the margin of: no contact built."""


class ContactCandidate:
    """A surface of the one mesh that may touch an obstacle, or another surface of it.

    Args:
        where: The surface on the one mesh: a locator ``x -> bool``, a facet MeshTags,
            ``(meshtags, value)`` or facet indices (serial meshes only).
        obstacle: The rigid obstacle it may touch (:mod:`dd_contact.obstacles`).
        name: Name of its contact interface (a part's name is appended if it spans parts),
            or of the contact pair (its sides: ``name_a``, ``name_b``).
        partner: Instead of an obstacle, the surface of another body of the one mesh it may
            touch: a :class:`~dd_contact.scene.ContactPair` between them.
        **options: Passed to :class:`~dd_contact.scene.ContactInterface` (``contact_kappa``,
            ``kappa``, ``points``, ...), or to the ContactPair (``kappa``, ``points``,
            ``unbiased``, ...).
    """

    def __init__(
        self,
        where: Region,
        obstacle: Obstacle | None = None,
        name: str = "contact",
        partner: Region | None = None,
        **options: Any,
    ):
        arguments.name(name, "ContactCandidate")
        if (obstacle is None) == (partner is None):
            raise InputError(
                f"ContactCandidate {name!r}: give an obstacle or a partner surface, one of them"
            )
        if obstacle is not None and not isinstance(obstacle, Obstacle):
            raise InputError(
                f"ContactCandidate {name!r}: obstacle must be a dd_contact Obstacle (Plane, "
                f"Sphere, Cylinder or UserObstacle), got {type(obstacle).__name__}"
            )
        self.where, self.obstacle, self.name, self.options = where, obstacle, name, options
        self.partner = partner


@dataclass(frozen=True)
class LeftOut:
    """Facets of a candidate surface that get no contact interface, and why.

    Attributes:
        name: The candidate's name.
        facets: How many of its facets (of the one mesh) are left out.
        of: How many facets the candidate has.
        nearest: The smallest gap of those facets' nodes to the obstacle over the times.
        reason: Why they are left out.
    """

    name: str
    facets: int
    of: int
    nearest: float
    reason: str


@dataclass
class Decomposition:
    """What :func:`decompose` built from the one mesh, and what it left out.

    Attributes:
        mesh: The user's mesh.
        whole: The user's mesh whole on this rank (a copy if it is distributed).
        method: ``"tags"``, ``"bisection"``, ``"scotch"``, ``"kahip"``, ``"planes"``, ``"auto"``,
            ``"bodies"`` or ``"one part"``.
        description: The cut in words.
        cells: Per part name, its cells as cells of :attr:`whole` (in the part's order).
        nodes: Per part name, its geometry nodes as nodes of :attr:`whole`.
        interface_facets: Facets of the one mesh between parts (0: no interface).
        contacts: Per contact interface built: ``(name, part, facets)``.
        left_out: The candidate facets left out (:class:`LeftOut`).
        margin: The reach margin used.
        times: The times at which the obstacles' positions were checked.
    """

    mesh: dolfinx.mesh.Mesh
    whole: Whole
    method: str
    description: str
    cells: dict[str, np.ndarray]
    nodes: dict[str, np.ndarray]
    interface_facets: int = 0
    contacts: list[tuple[str, str, int]] = field(default_factory=list)
    left_out: list[LeftOut] = field(default_factory=list)
    margin: float = 0.0
    times: tuple[float, ...] = (0.0,)

    def table(self) -> str:
        """The decomposition as text: parts, interface, contacts, what was left out."""
        lines = [f"decomposition ({self.method}): {self.description}"]
        lines += [f"  part {n}: {len(c)} cells" for n, c in self.cells.items()]
        lines.append(f"  interface: {self.interface_facets} facets")
        lines += [f"  contact {n} on {p}: {f} facets" for n, p, f in self.contacts]
        lines += [
            f"  left out of {o.name}: {o.facets} of {o.of} facets ({o.reason})"
            for o in self.left_out
        ]
        return "\n".join(lines)


class DecomposedScene(Scene):
    """A :class:`~dd_contact.scene.Scene` made by :func:`decompose`, with its one mesh.

    Supports and loads are given on the one mesh and carried to every part that holds
    facets of the region; :attr:`decomposition` says what was built and left out.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        subdomains: Sequence[Subdomain],
        interface: Interface | None,
        contacts: Sequence[ContactInterface | ContactPair],
        decomposition: Decomposition,
    ):
        super().__init__(comm, subdomains, interface, contacts)
        self.decomposition = decomposition
        self._keys: dict[str, dict[tuple, int]] = {}

    def part_facets(self, where: Region, argument: str = "where") -> dict[str, np.ndarray]:
        """The facets of each part that a region of the one mesh's boundary covers.

        Parts that hold none of them are left out of the dict.
        """
        d = self.decomposition
        facets = _whole_facets(d.whole, where, f"decompose: {argument}")
        keys = partition.facet_keys(d.whole.mesh, facets)
        out = {}
        for sub in self.subdomains:
            lookup = self._exterior(sub)
            found = [lookup.get(tuple(k)) for k in keys]
            mine = np.array(sorted(f for f in found if f is not None), dtype=np.int32)
            if mine.size:
                out[sub.name] = mine
        return out

    def _exterior(self, sub: Subdomain) -> dict[tuple, int]:
        """A part's exterior facets by their keys (nodes of the whole mesh)."""
        if sub.name not in self._keys:
            self._keys[sub.name] = partition.exterior_keys(
                sub.mesh, self.decomposition.nodes[sub.name]
            )
        return self._keys[sub.name]

    def fix(
        self, where: Region, components: Sequence[int] | None = None, value: Value | None = None
    ) -> DecomposedScene:
        """:meth:`Subdomain.fix` on a region of the one mesh, for every part it touches."""
        if isinstance(where, fem.DirichletBC) or (
            isinstance(where, Sequence) and where and isinstance(where[0], fem.DirichletBC)
        ):
            raise InputError(
                "DecomposedScene.fix: a DirichletBC is built on one space and cannot be carried "
                "to the parts; give the region (locator or facet tags) and value instead"
            )
        for name, facets in self.part_facets(where, "fix").items():
            self._part(name).fix(facets, components, value)
        return self

    def add_traction(
        self,
        where: Region,
        traction: Sequence[float] | Callable[[float], Sequence[float]],
        amplitude: Callable[[float], float] | None = None,
    ) -> DecomposedScene:
        """:meth:`Subdomain.add_traction` on a region of the one mesh (a 3-vector or callable).

        A UFL expression lives on one mesh and cannot be carried to the parts.
        """
        if isinstance(traction, ufl.core.expr.Expr) or not (
            callable(traction) or isinstance(traction, (Sequence, np.ndarray))
        ):
            raise InputError(
                "DecomposedScene.add_traction: give the traction as a 3-vector or a callable "
                f"t -> 3-vector (a UFL expression belongs to one mesh), got {traction!r}"
            )
        for name, facets in self.part_facets(where, "add_traction").items():
            self._part(name).add_traction(facets, traction, amplitude)
        return self

    def set_body_force(
        self,
        force: Sequence[float] | Callable[[float], Sequence[float]],
        amplitude: Callable[[float], float] | None = None,
    ) -> DecomposedScene:
        """:meth:`Subdomain.set_body_force` on every part (a 3-vector or callable)."""
        if isinstance(force, ufl.core.expr.Expr):
            raise InputError(
                "DecomposedScene.set_body_force: give the force as a 3-vector or a callable "
                "t -> 3-vector (a UFL expression belongs to one mesh)"
            )
        for sub in self.subdomains:
            sub.set_body_force(force, amplitude)
        return self

    def _part(self, name: str) -> Subdomain:
        return next(s for s in self.subdomains if s.name == name)


def _whole_facets(whole: Whole, where: Region, argument: str) -> np.ndarray:
    """The boundary facets of the whole mesh that a region of the user's mesh selects."""
    if isinstance(where, tuple) and len(where) == 2:
        where = (whole.tags(where[0], argument), where[1])
    elif isinstance(where, dolfinx.mesh.MeshTags):
        where = whole.tags(where, argument)
    elif not callable(where) and whole.copied:
        raise InputError(
            f"{argument}: facet indices are local to a rank of a distributed mesh; give a "
            "locator or facet MeshTags instead"
        )
    return arguments.boundary_facets(whole.mesh, where, argument)


@dataclass
class _Reached:
    """A candidate's facets (of the whole mesh) in reach, its partner's, what is left out."""

    facets: np.ndarray
    partner: np.ndarray | None = None
    left: list[LeftOut] = field(default_factory=list)


def _left_out(name: str, nearest: np.ndarray, reach: np.ndarray, margin: float, of: str):
    """The entry of :attr:`Decomposition.left_out` for facets not in ``reach``, or None."""
    if reach.all():
        return None
    far = nearest[~reach]
    what = "none of its facets comes" if not reach.any() else f"these {far.size} facets do not come"
    reason = f"{what} within the margin {margin:.4g} of {of} (nearest: gap {far.min():.4g})"
    return LeftOut(name, int(far.size), len(nearest), float(far.min()), reason)


def _reach(
    whole: Whole, candidate: ContactCandidate, margin: float, times: Sequence[float]
) -> _Reached:
    """The candidate's facets within ``margin`` of its obstacle at some time, and the rest.

    For a pair: the facets of each side with a node within ``margin`` of a node of the other
    side (undeformed).
    """
    facets = _whole_facets(whole, candidate.where, f"ContactCandidate {candidate.name!r}")
    x = whole.mesh.geometry.x
    nodes = dolfinx.mesh.entities_to_geometry(whole.mesh, 2, facets)
    if candidate.obstacle is None:
        return _reach_pair(whole, candidate, facets, nodes, margin)
    used, local = np.unique(nodes, return_inverse=True)
    obstacle = candidate.obstacle
    gap = np.min([obstacle.gap_normal(x[used], t)[0] for t in times], axis=0)
    nearest = gap[local.reshape(nodes.shape)].min(axis=1)
    reach = nearest <= margin
    what = f"obstacle {type(obstacle).__name__} at the {len(times)} times checked"
    left = _left_out(candidate.name, nearest, reach, margin, what)
    return _Reached(facets[reach], None, [] if left is None else [left])


def _reach_pair(
    whole: Whole, candidate: ContactCandidate, facets: np.ndarray, nodes: np.ndarray, margin
) -> _Reached:
    """Both sides of a pair candidate: the facets of each within reach of the other."""
    name, partner = candidate.name, candidate.partner
    assert partner is not None  # a pair candidate: the constructor took one of the two
    other = _whole_facets(whole, partner, f"ContactCandidate {name!r}: partner")
    if np.intersect1d(facets, other).size:
        raise InputError(
            f"ContactCandidate {name!r}: the surface and its partner share facets; name two "
            "surfaces of different bodies"
        )
    x = whole.mesh.geometry.x
    other_nodes = dolfinx.mesh.entities_to_geometry(whole.mesh, 2, other)
    sides, left = [], []
    for side, (mine, theirs, own) in zip(
        "ab", [(nodes, other_nodes, facets), (other_nodes, nodes, other)], strict=True
    ):
        distance, _ = cKDTree(x[np.unique(theirs)]).query(x[mine.ravel()])
        nearest = distance.reshape(mine.shape).min(axis=1)
        reach = nearest <= margin
        sides.append(own[reach])
        entry = _left_out(f"{name}_{side}", nearest, reach, margin, "the other side")
        left += [] if entry is None else [entry]
    return _Reached(sides[0], sides[1], left)


def _parts(
    whole: Whole,
    parts: int | str | dolfinx.mesh.MeshTags | Sequence,
    contact_cells: np.ndarray,
    layers: float,
    pairs: bool = False,
    partitioner: str = "auto",
) -> tuple[np.ndarray, list[str], str, str]:
    """The part of each cell, the parts' suffixes, the method and a description."""
    if partitioner not in PARTITIONERS:
        raise InputError(
            f"decompose: partitioner must be one of {PARTITIONERS}, got {partitioner!r}"
        )
    mesh = whole.mesh
    midpoints = partition.cell_midpoints(mesh)
    num = len(midpoints)
    if isinstance(parts, dolfinx.mesh.MeshTags):
        part, values = partition.by_tags(whole.tags(parts, "decompose: parts"), num)
        return part, [str(v) for v in values], "tags", f"{len(values)} parts by cell tags"
    if isinstance(parts, str):
        if parts not in ("auto", "bodies"):
            raise InputError(
                f"decompose: parts must be 'auto', 'bodies', a number, cell MeshTags or cut "
                f"planes, got {parts!r}"
            )
        if parts == "bodies" or pairs:  # contact between bodies: a part per body
            part = partition.bodies(mesh)
            n = int(part.max()) + 1
            return part, [str(k) for k in range(n)], "bodies", f"{n} parts, one per body"
        if contact_cells.size:
            nodes = mesh.geometry.x[mesh.geometry.dofmaps[0][:num]]
            sizes = np.ptp(nodes, axis=1).mean(axis=0)
            cut = partition.contact_cut(midpoints, sizes, contact_cells, layers)
            if cut is not None:
                return cut[0], ["0", "1"], "auto", cut[1]
        why = "no candidate surface in reach" if not contact_cells.size else "contact is everywhere"
        return np.zeros(num, dtype=np.int64), ["0"], "one part", f"one part ({why})"
    if isinstance(parts, (int, np.integer)) and not isinstance(parts, bool):
        n = arguments.positive_int(parts, "decompose: parts")
        if partitioner == "auto":
            part, partitioner = partition.fewest_facets(mesh, n)
        elif partitioner == "bisection":
            part = partition.bisection(midpoints, n)
        else:
            part = partition.graph_partition(mesh, n, partitioner)
        return part, [str(k) for k in range(n)], partitioner, f"{n} parts by {partitioner}"
    if not isinstance(parts, Sequence):
        raise InputError(
            f"decompose: parts must be 'auto', a number, cell MeshTags or a list of cut planes "
            f"(point, normal), got {parts!r}"
        )
    part = partition.by_planes(midpoints, parts)
    n = int(part.max()) + 1
    return part, [str(k) for k in range(n)], "planes", f"{n} parts by {len(parts)} planes"


def decompose(
    mesh: dolfinx.mesh.Mesh,
    material: Material,
    parts: int | str | dolfinx.mesh.MeshTags | Sequence = "auto",
    contacts: Sequence[ContactCandidate] = (),
    *,
    margin: float | None = None,
    times: Sequence[float] = (0.0,),
    kappa: float | None = None,
    epsilon: float | None = None,
    layers: float = 1.0,
    partitioner: str = "auto",
    name: str = "part",
    comm: MPI.Comm | None = None,
) -> DecomposedScene:
    """A scene from one dolfinx mesh: parts, the interface between them, contacts in reach.

    Collective over ``comm``. Every rank builds every part (as every rank holds every mesh
    of a scene); part k is owned by rank ``k % comm.size``.

    Args:
        mesh: The one mesh: 3-D, first-order geometry; serial, or distributed as
            ``dolfinx.io.gmsh`` reads it (it is then gathered whole onto every rank).
        material: The material of every part.
        parts: ``"auto"`` (the cut that puts the candidate surfaces in reach into a small
            part, or one part if none is in reach or the cut saves nothing); a number of
            parts (see ``partitioner``); cell MeshTags (a part per tag value); or
            cut planes, a list of ``(point, normal)`` (a part per side pattern).
        contacts: The candidate contact surfaces (:class:`ContactCandidate`).
        margin: A candidate facet gets a contact interface if one of its nodes comes within
            ``margin`` of its obstacle at one of ``times`` (undeformed body, the obstacle
            moved by its ``motion``). Default: :data:`DEFAULT_MARGIN` of the mesh's
            bounding-box diagonal. Make it cover the body's own motion.
        times: The times of the run at which the obstacles' positions are checked.
        kappa: Dimensionless tie penalty of the interface (default DEFAULT_KAPPA).
        epsilon: Absolute tie penalty instead.
        layers: For ``parts="auto"``: cell layers between the contact surfaces and the cut.
        partitioner: For a number of parts: ``"bisection"``, ``"scotch"``, ``"kahip"`` (dolfinx's
            graph partitioners), or ``"auto"``: bisection or SCOTCH, whichever cuts fewer facets.
        name: Parts are named ``name`` + their number (or tag value).
        comm: Communicator of the scene (default ``mesh.comm``; give ``MPI.COMM_WORLD``
            when every rank passes its own serial copy of the mesh).

    Returns:
        A :class:`DecomposedScene`; ``scene.decomposition`` lists what was built and left out.
    """
    comm = mesh.comm if comm is None and isinstance(mesh, dolfinx.mesh.Mesh) else comm
    arguments.instance(comm, MPI.Comm, "decompose: comm")
    arguments.instance(material, Material, "decompose: material")
    arguments.name(name, "decompose")
    if isinstance(contacts, ContactCandidate):
        raise InputError("decompose: contacts must be a list, e.g. contacts=[candidate]")
    for c in contacts:
        arguments.instance(c, ContactCandidate, "decompose: contacts")
    times = tuple(arguments.real(t, "decompose: times") for t in times)
    if not times:
        raise InputError("decompose: times must hold at least one time, e.g. times=[0.0]")
    whole = partition.whole_mesh(mesh)
    x = whole.mesh.geometry.x
    if margin is None:
        margin = DEFAULT_MARGIN * float(np.linalg.norm(np.ptp(x, axis=0)))
    elif not arguments.real(margin, "decompose: margin") >= 0:
        raise InputError(f"decompose: margin must be >= 0, got {margin}")
    reach = [_reach(whole, c, float(margin), times) for c in contacts]
    _warn_unreachable(contacts, reach)
    contact_cells = partition.cells_behind(whole.mesh, [r.facets for r in reach])
    pairs = any(c.partner is not None for c in contacts)
    part, suffixes, method, description = _parts(
        whole, parts, contact_cells, layers, pairs, partitioner
    )
    part = bcast_from_root(comm, part)  # the same parts on every rank, whatever the partitioner
    decomposition = Decomposition(mesh, whole, method, description, {}, {})
    decomposition.margin, decomposition.times = float(margin), times
    decomposition.left_out = [o for r in reach for o in r.left]
    subdomains = _subdomains(whole, part, [name + s for s in suffixes], material, decomposition)
    interface = _interface(whole, part, subdomains, kappa, epsilon, decomposition)
    built = _contacts(whole, subdomains, contacts, reach, decomposition)
    return DecomposedScene(comm, subdomains, interface, built, decomposition)


def _warn_unreachable(contacts: Sequence[ContactCandidate], reach: list) -> None:
    """Warn about each obstacle that none of its candidate surfaces can reach."""
    obstacles: dict[int, tuple[Obstacle, list[str], int]] = {}
    for c, r in zip(contacts, reach, strict=True):
        if c.obstacle is None:
            continue  # a pair
        obstacle, names, count = obstacles.get(id(c.obstacle), (c.obstacle, [], 0))
        obstacles[id(c.obstacle)] = (obstacle, [*names, c.name], count + r.facets.size)
    for obstacle, names, count in obstacles.values():
        if count == 0:
            warn(
                f"decompose: no facet of the candidate surface(s) {names} comes within the "
                f"margin of their obstacle {type(obstacle).__name__}: no contact is built "
                "with it; enlarge margin or times if it should touch",
                UnreachableObstacleWarning,
            )


def _subdomains(
    whole: Whole, part: np.ndarray, names: list[str], material: Material, d: Decomposition
) -> list[Subdomain]:
    """A subdomain per part, its mesh cut from the whole mesh on this rank."""
    subdomains = []
    for k, name in enumerate(names):
        cells = np.flatnonzero(part == k).astype(np.int32)
        if cells.size == 0:
            raise InputError(f"decompose: part {name!r} has no cells; use fewer parts")
        sub_mesh, cell_map, _, nodes = dolfinx.mesh.create_submesh(whole.mesh, 3, cells)
        ordered = np.arange(cells.size, dtype=np.int32)
        d.cells[name] = np.asarray(cell_map.sub_topology_to_topology(ordered, inverse=False))
        d.nodes[name] = np.asarray(nodes)
        subdomains.append(Subdomain(sub_mesh, material, name))
    return subdomains


def _interface(
    whole: Whole,
    part: np.ndarray,
    subdomains: list[Subdomain],
    kappa: float | None,
    epsilon: float | None,
    d: Decomposition,
) -> Interface | None:
    """A copy of the facets between parts, tied to every part that has some; or none."""
    facets = partition.interface_facets(whole.mesh, part)
    d.interface_facets = int(facets.size)
    if facets.size == 0:
        return None
    whole.mesh.topology.create_connectivity(2, 3)
    f2c = whole.mesh.topology.connectivity(2, 3)
    tied = np.unique(part[np.concatenate([f2c.links(f) for f in facets])])
    surface = meshes.facet_surface(whole.mesh, facets, MPI.COMM_SELF)
    return Interface(surface, [subdomains[k] for k in tied], kappa=kappa, epsilon=epsilon)


def _pieces(
    whole: Whole, subdomains: list[Subdomain], facets: np.ndarray, d: Decomposition
) -> dict[str, np.ndarray]:
    """Facets of the whole mesh as facets of the parts that hold them, by part name."""
    keys = partition.facet_keys(whole.mesh, facets) if facets.size else np.zeros((0, 3))
    pieces = {}
    for sub in subdomains:
        lookup = partition.exterior_keys(sub.mesh, d.nodes[sub.name])
        found = np.array(sorted(lookup[tuple(k)] for k in keys if tuple(k) in lookup))
        if found.size:
            pieces[sub.name] = found.astype(np.int32)
    return pieces


def _contacts(
    whole: Whole,
    subdomains: list[Subdomain],
    candidates: Sequence[ContactCandidate],
    reach: list[_Reached],
    d: Decomposition,
) -> list[ContactInterface | ContactPair]:
    """A contact interface per candidate and part on the facets in reach; or a pair."""
    built: list[ContactInterface | ContactPair] = []
    by_name = {s.name: s for s in subdomains}
    for candidate, reached in zip(candidates, reach, strict=True):
        pieces = _pieces(whole, subdomains, reached.facets, d)
        if reached.partner is not None:
            if pieces:
                others = _pieces(whole, subdomains, reached.partner, d)
                built.append(_pair(candidate, pieces, others, by_name, d))
            continue
        for part_name, part_facets in pieces.items():
            name = candidate.name if len(pieces) == 1 else f"{candidate.name}_{part_name}"
            built.append(
                ContactInterface.from_boundary(
                    by_name[part_name],
                    part_facets,
                    candidate.obstacle,
                    name=name,
                    **candidate.options,
                )
            )
            d.contacts.append((name, part_name, int(part_facets.size)))
    return built


def _pair(
    candidate: ContactCandidate,
    pieces: dict[str, np.ndarray],
    others: dict[str, np.ndarray],
    by_name: dict[str, Subdomain],
    d: Decomposition,
) -> ContactPair:
    """The contact pair of a candidate whose two sides each lie in one part."""
    name = candidate.name
    if len(pieces) != 1 or len(others) != 1 or set(pieces) == set(others):
        raise InputError(
            f"ContactCandidate {name!r}: its two sides lie in parts {sorted(pieces)} and "
            f"{sorted(others)}; a pair needs each side in one part and the two in different "
            "parts (self-contact is not supported): use parts='bodies' or cell tags"
        )
    sides = []
    for side, found in (("a", pieces), ("b", others)):
        ((part_name, facets),) = found.items()
        sides.append(
            ContactInterface.from_boundary(by_name[part_name], facets, None, name=f"{name}_{side}")
        )
        d.contacts.append((f"{name}_{side}", part_name, int(facets.size)))
    return ContactPair(sides[0], sides[1], name=name, **candidate.options)
