"""What is modelled: penalties, the interface, the contacts and the scene that holds them.

Each subdomain (:mod:`dd_contact.subdomains`) is an independent dolfinx mesh on a
communicator of size one (one rank owns a whole subdomain); the interface is an independent
surface mesh with its own displacement v, tied to its subdomains by penalties (eqs. 6, 9, 10).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
from scipy.spatial import cKDTree

from dd_contact import arguments, meshes
from dd_contact.arguments import Region
from dd_contact.blocks import Block
from dd_contact.bodies import Body
from dd_contact.errors import InputError
from dd_contact.obstacles import Obstacle
from dd_contact.parallel import allgathered, owner_of, share_cores
from dd_contact.subdomains import Subdomain

__all__ = [
    "CONTACT_POINTS",
    "DEFAULT_KAPPA",
    "ContactBoundary",
    "ContactInterface",
    "ContactPair",
    "Interface",
    "Penalty",
    "Scene",
]

#: Where a contact's penalty is evaluated: at the surface nodes (lumped weights) or at
#: the quadrature points of the surface cells.
CONTACT_POINTS = ("nodes", "quadrature")

#: Default dimensionless penalty kappa = h / (E * eps): ties 1e6 times stiffer than the
#: elements behind them, so the penalty gap costs about 1e-6 of the response.
DEFAULT_KAPPA = 1.0e6

#: Ties stiffer than KAPPA_SPLIT are assembled at KAPPA_ASSEMBLED (matching facets) or
#: KAPPA_ASSEMBLED_PROJECTED, the rest of their penalty carried by an augmented-Lagrangian
#: iteration (dd_contact.solvers.stiff_ties; docs/solvers.md, "Stiff ties": why these).
KAPPA_SPLIT = 1.0e6
KAPPA_ASSEMBLED = 1.0e3
KAPPA_ASSEMBLED_PROJECTED = 1.0e5

#: Dimensionless tie penalties over which the results are verified to 1e-8 (``dd-contact
#: verify --case extremes``, docs/accuracy.md); a tie outside gets a PenaltyRangeWarning.
KAPPA_VERIFIED: tuple[float, float] = (1.0e0, 1.0e14)

#: A boundary region (:data:`dd_contact.arguments.Region`), under the name post.py uses.
Where = Region


@dataclass(frozen=True)
class Penalty:
    """A penalty, dimensionless or absolute.

    Give ``kappa`` (penalty stiffness relative to the element stiffness E/h, so
    ``eps = h / (E * kappa)``) or ``epsilon`` (the paper's absolute eps, traction = (1/eps) *
    displacement jump), not both.
    """

    kappa: float | None = None
    epsilon: float | None = None

    def __post_init__(self):
        if self.kappa is not None and self.epsilon is not None:
            raise InputError("Penalty: give kappa or epsilon, not both")
        for name in ("kappa", "epsilon"):
            value = getattr(self, name)
            if value is None:
                continue
            if not (arguments.is_real(value) and math.isfinite(value) and value > 0):
                raise InputError(
                    f"Penalty: {name} must be a positive finite number, got {value!r}; "
                    f"a stiffer tie needs a larger kappa or a smaller epsilon"
                )

    def kappa_for(self, h: float, E: float) -> float:
        """The dimensionless kappa for element height ``h`` and Young's modulus ``E``."""
        if self.epsilon is not None:
            return h / (E * self.epsilon)
        return DEFAULT_KAPPA if self.kappa is None else self.kappa

    def epsilon_for(self, h: float, E: float) -> float:
        """The absolute eps for element height ``h`` and Young's modulus ``E``."""
        if self.epsilon is not None:
            return self.epsilon
        kappa = DEFAULT_KAPPA if self.kappa is None else self.kappa
        return h / (E * kappa)


def _surface(
    subdomain: Subdomain,
    where: Region,
    resolution: tuple[int, int] | None,
    cell_type: str,
    what: str,
) -> dolfinx.mesh.Mesh:
    """The surface mesh ``from_boundary`` builds: a copy of the region or a remeshed rectangle."""
    arguments.instance(subdomain, Subdomain, f"{what}: subdomain")
    if resolution is not None:
        if not isinstance(resolution, Sequence) or len(resolution) != 2:
            raise InputError(f"{what}: resolution must be (n1, n2) cell counts or None")
        n1, n2 = (arguments.positive_int(n, f"{what}: resolution") for n in resolution)
        resolution = (n1, n2)
    if cell_type not in ("quadrilateral", "triangle"):
        raise InputError(
            f"{what}: cell_type must be 'quadrilateral' or 'triangle', got {cell_type!r}"
        )
    facets = subdomain.locate_facets(where, f"{what} where")
    try:
        return meshes.surface_from_facets(
            subdomain.mesh, facets, resolution, cell_type, comm=MPI.COMM_SELF
        )
    except ValueError as err:  # a region that cannot be remeshed: the message says why
        raise InputError(f"{what}: {err}") from None


class Interface:
    """The interface Gamma_I: an independent surface mesh with displacement v.

    It is tied by a penalty to every subdomain in ``subdomains`` wherever it overlaps that
    subdomain's boundary (eqs. 6, 9, 10).

    Args:
        mesh: A surface mesh (topological dimension 2) in 3-D on a communicator of size one.
        subdomains: The subdomains it glues.
        kappa: Dimensionless penalty h / (E eps) (default :data:`DEFAULT_KAPPA`).
        epsilon: Absolute penalty eps instead of kappa.
        tolerance: Largest surface-to-boundary distance still counted as touching (default
            5% of each surface cell's size).
        name: Name in messages and output.
    """

    def __init__(
        self,
        mesh: dolfinx.mesh.Mesh,
        subdomains: Sequence[Subdomain],
        kappa: float | None = None,
        epsilon: float | None = None,
        tolerance: float | None = None,
        name: str = "interface",
    ):
        arguments.name(name, "Interface")
        arguments.one_rank_mesh(
            mesh,
            2,
            f"interface {name!r}",
            "build it with dd_contact.meshes.surface_mesh(MPI.COMM_SELF, ...) or "
            "Interface.from_boundary",
        )
        if isinstance(subdomains, Subdomain) or len(subdomains) == 0:
            raise InputError(f"interface {name!r}: give the list of subdomains it ties")
        for s in subdomains:
            arguments.instance(s, Subdomain, f"interface {name!r}: subdomains")
        arguments.tolerance(tolerance, f"interface {name!r}")
        self.mesh, self.subdomains, self.tolerance = mesh, list(subdomains), tolerance
        self.penalty, self.name = Penalty(kappa=kappa, epsilon=epsilon), name
        self.V = fem.functionspace(mesh, ("Lagrange", 1, (3,)))
        self.v = fem.Function(self.V, name=f"v_{name}")

    @classmethod
    def from_boundary(
        cls,
        subdomain: Subdomain,
        where: Region,
        subdomains: Sequence[Subdomain],
        resolution: tuple[int, int] | None = None,
        cell_type: str = "quadrilateral",
        **kwargs,
    ) -> Interface:
        """An interface generated on a region of ``subdomain``'s boundary.

        Args:
            subdomain: The subdomain whose boundary region is meshed.
            where: The region: a locator ``x -> bool``, facet indices, a facet MeshTags, or
                ``(meshtags, value)``.
            subdomains: The subdomains the interface ties.
            resolution: Cells along the two edges of a planar rectangular region, or
                ``None`` for a copy of the region's facets.
            cell_type: ``"quadrilateral"`` or ``"triangle"``.
            **kwargs: Passed to :class:`Interface`.
        """
        mesh = _surface(subdomain, where, resolution, cell_type, "Interface.from_boundary")
        return cls(mesh, subdomains, **kwargs)

    @property
    def num_dofs(self) -> int:
        """Number of displacement dofs (3 per node)."""
        return self.V.dofmap.index_map.size_local * 3

    @property
    def block(self) -> Block:
        """The interface's block of unknowns v in system (14)."""
        return Block("v", self.name)


class _ContactBase:
    """What every contact region has: an obstacle, a contact penalty, a scheme, a surface."""

    def _setup_contact(
        self,
        mesh: dolfinx.mesh.Mesh,
        subdomain: Subdomain,
        obstacle,
        contact_kappa: float | None,
        contact_epsilon: float | None,
        points: str,
        name: str,
        friction: float = 0.0,
    ) -> None:
        arguments.name(name, "contact")
        arguments.instance(subdomain, Subdomain, f"contact {name!r}: subdomain")
        arguments.one_rank_mesh(
            mesh,
            2,
            f"contact {name!r}",
            "build it with ContactInterface.from_boundary or dd_contact.meshes.surface_mesh",
        )
        if mesh.geometry.cmaps[0].degree != 1:
            raise InputError(f"contact {name!r}: the surface mesh must be first order")
        if obstacle is None and isinstance(self, ContactInterface):
            pass  # a side of a ContactPair: the Scene checks that it is in one
        elif not isinstance(obstacle, Obstacle):
            raise InputError(
                f"contact {name!r}: obstacle must be a dd_contact.obstacles.Obstacle (Plane, "
                f"Sphere, Cylinder or UserObstacle), got {type(obstacle).__name__}"
            )
        arguments.choice(points, CONTACT_POINTS, f"contact {name!r}: points")
        self.mesh = mesh
        self.subdomain = subdomain
        self.obstacle = obstacle
        self.contact_penalty = Penalty(kappa=contact_kappa, epsilon=contact_epsilon)
        self.friction = arguments.friction(friction, f"contact {name!r}", obstacle is None)
        self.points = points
        self.name = name
        self.V = fem.functionspace(mesh, ("Lagrange", 1, (3,)))
        self.w = fem.Function(self.V, name=f"w_{name}")
        self.pressure = fem.Function(
            fem.functionspace(mesh, ("Lagrange", 1)), name=f"pressure_{name}"
        )

    @property
    def num_dofs(self) -> int:
        """Number of displacement dofs of the contact surface (3 per node)."""
        return self.V.dofmap.index_map.size_local * 3


class ContactInterface(_ContactBase):
    """A contact interface Gamma_C^(k): an independent surface mesh with displacement w.

    It is tied to ``subdomain`` by a penalty eps_CI (eqs. 7, 9, 11) and pressed against a
    rigid ``obstacle`` by the exterior penalty eps_C (eq. 5), or, with ``obstacle=None``,
    against another body's contact interface through a :class:`ContactPair`.

    Args:
        mesh: A first-order surface mesh in 3-D on a communicator of size one, lying on the
            subdomain's boundary.
        subdomain: The subdomain it is tied to.
        obstacle: The rigid obstacle (:mod:`dd_contact.obstacles`), or ``None`` for a side
            of a :class:`ContactPair`.
        kappa: Dimensionless tie penalty h / (E eps_CI) (default :data:`DEFAULT_KAPPA`).
        epsilon: Absolute tie penalty eps_CI instead of kappa.
        contact_kappa: Dimensionless contact penalty h / (E eps_C) (default DEFAULT_KAPPA).
        contact_epsilon: Absolute contact penalty eps_C instead.
        points: Where contact is checked, ``"nodes"`` or ``"quadrature"``
            (see :mod:`dd_contact.contact`).
        friction: The Coulomb coefficient mu against the obstacle (docs/contact.md).
        tolerance: Largest surface-to-boundary distance still counted as touching.
        name: Name in messages and output.
    """

    def __init__(
        self,
        mesh: dolfinx.mesh.Mesh,
        subdomain: Subdomain,
        obstacle,
        kappa: float | None = None,
        epsilon: float | None = None,
        contact_kappa: float | None = None,
        contact_epsilon: float | None = None,
        points: str = "nodes",
        tolerance: float | None = None,
        name: str = "contact",
        friction: float = 0.0,
    ):
        arguments.tolerance(tolerance, f"contact {name!r}")
        self._setup_contact(
            mesh, subdomain, obstacle, contact_kappa, contact_epsilon, points, name, friction
        )
        self.penalty = Penalty(kappa=kappa, epsilon=epsilon)
        self.tolerance = tolerance

    @property
    def block(self) -> Block:
        """The contact interface's block of unknowns w in system (14)."""
        return Block("w", self.name)

    @classmethod
    def from_boundary(
        cls,
        subdomain: Subdomain,
        where: Region,
        obstacle,
        resolution: tuple[int, int] | None = None,
        cell_type: str = "quadrilateral",
        **kwargs,
    ) -> ContactInterface:
        """A contact interface generated on a region of ``subdomain``'s boundary.

        Args:
            subdomain: The subdomain it belongs to.
            where: The region: a locator ``x -> bool``, facet indices, a facet MeshTags, or
                ``(meshtags, value)``.
            obstacle: The rigid obstacle.
            resolution: Cells along the edges of a planar rectangular region, or ``None``
                for a copy of the region's facets.
            cell_type: ``"quadrilateral"`` or ``"triangle"`` (with ``resolution``).
            **kwargs: Passed to :class:`ContactInterface`.
        """
        mesh = _surface(subdomain, where, resolution, cell_type, "ContactInterface.from_boundary")
        return cls(mesh, subdomain, obstacle, **kwargs)


class ContactBoundary(_ContactBase):
    """Contact directly on a region of a subdomain's boundary, without a contact interface.

    The contact term acts on the subdomain's own boundary dofs, so the subdomain matrix
    changes with the contact state: the classical approach (FULL) and the v-u order.

    Args:
        subdomain: The subdomain (first-order Lagrange displacement).
        where: The region: a locator ``x -> bool``, facet indices, a facet MeshTags, or
            ``(meshtags, value)``.
        obstacle: The rigid obstacle.
        contact_kappa: Dimensionless contact penalty h / (E eps_C) (default DEFAULT_KAPPA).
        contact_epsilon: Absolute contact penalty eps_C instead.
        points: ``"nodes"`` or ``"quadrature"`` (see :mod:`dd_contact.contact`).
        friction: The Coulomb coefficient mu against the obstacle (docs/contact.md).
        name: Name in messages and output.
    """

    def __init__(
        self,
        subdomain: Subdomain,
        where: Region,
        obstacle,
        contact_kappa: float | None = None,
        contact_epsilon: float | None = None,
        points: str = "nodes",
        name: str = "contact",
        friction: float = 0.0,
    ):
        arguments.instance(subdomain, Subdomain, f"contact {name!r}: subdomain")
        if subdomain.V.element.basix_element.degree != 1:
            raise InputError(
                f"contact {name!r}: contact directly on a boundary needs a degree-1 subdomain; "
                "use a ContactInterface for higher degrees"
            )
        self.facets = subdomain.locate_facets(where)
        mesh = meshes.facet_surface(subdomain.mesh, self.facets, MPI.COMM_SELF)
        self._setup_contact(
            mesh, subdomain, obstacle, contact_kappa, contact_epsilon, points, name, friction
        )
        # Surface node -> subdomain node, matched by position (the copy has the same nodes).
        volume_x = subdomain.V.tabulate_dof_coordinates()
        surface_x = self.V.tabulate_dof_coordinates()[: self.V.dofmap.index_map.size_local]
        distance, self.node_map = cKDTree(volume_x).query(surface_x)
        assert np.all(distance < 1e-10 * (1 + np.abs(volume_x).max()))

    @property
    def block(self) -> Block:
        """The block holding the contact surface's displacement: the subdomain's own."""
        return self.subdomain.block


class ContactPair:
    """Contact between two deformable bodies: two contact interfaces pressed on each other.

    Each side is a :class:`ContactInterface` with ``obstacle=None`` tied to its subdomain;
    the pair penalises the gap between them, integrated over the surfaces' intersection
    (segment to segment), with normals, projection and gap of the undeformed geometry
    (docs/contact.md, "Contact between bodies"). Self-contact is not supported.

    Args:
        a: The first side (the slave: its points are projected onto ``b``).
        b: The second side, a contact interface of another subdomain.
        kappa: Dimensionless contact penalty h / (E eps_C), h and E of the stiffer side
            (default :data:`DEFAULT_KAPPA`).
        epsilon: Absolute contact penalty eps_C instead.
        points: ``"nodes"`` (the gap weighted over each node of ``a``, mortar style) or
            ``"quadrature"`` (the intersection's Gauss points).
        unbiased: Both ways (a onto b, b onto a), half the penalty each: no master/slave.
        tolerance: Largest initial gap at which points of the two surfaces face each other
            (default: the mean cell size of ``a``); farther apart they never touch.
        name: Name in messages and output (default ``"<a>-<b>"``).
        friction: The Coulomb coefficient mu between the two surfaces (docs/contact.md).
    """

    def __init__(
        self,
        a: ContactInterface,
        b: ContactInterface,
        kappa: float | None = None,
        epsilon: float | None = None,
        points: str = "nodes",
        unbiased: bool = False,
        tolerance: float | None = None,
        name: str | None = None,
        friction: float = 0.0,
    ):
        name = f"{getattr(a, 'name', '?')}-{getattr(b, 'name', '?')}" if name is None else name
        arguments.name(name, "ContactPair")
        for side in (a, b):
            if not isinstance(side, ContactInterface) or side.obstacle is not None:
                raise InputError(
                    f"ContactPair {name!r}: both sides must be ContactInterfaces without an "
                    f"obstacle, got {type(side).__name__}; build each with ContactInterface."
                    "from_boundary(subdomain, where, None) (contact boundaries cannot pair yet)"
                )
        if a is b or a.subdomain is b.subdomain:
            raise InputError(
                f"ContactPair {name!r}: both sides belong to subdomain {a.subdomain.name!r}; "
                "self-contact (a body touching itself) is not supported: pair surfaces of two "
                "different subdomains"
            )
        arguments.choice(points, CONTACT_POINTS, f"ContactPair {name!r}: points")
        arguments.tolerance(tolerance, f"ContactPair {name!r}")
        self.friction = arguments.pair_friction(friction, f"ContactPair {name!r}", points, unbiased)
        self.a, self.b, self.name, self.points, self.tolerance = a, b, name, points, tolerance
        self.unbiased = bool(unbiased)
        self.contact_penalty = Penalty(kappa=kappa, epsilon=epsilon)
        self.subdomain, self.sides = a.subdomain, (a, b)  # owned by side a's rank


class Scene:
    """Subdomains and (optionally) one interface: everything the solvers need.

    Under MPI every rank holds every mesh (they are small compared with the work), and
    subdomain k is *owned* by rank ``k % comm.size``: only its owner assembles, couples and
    factorises it. The interface is owned by rank 0.

    Args:
        comm: Communicator of the analysis.
        subdomains: The subdomains, in order.
        interface: The interface, if the body is decomposed.
        contacts: Contact interfaces, contact boundaries and contact pairs; each belongs to
            one subdomain and is owned by that subdomain's rank (a pair and both its sides:
            by the rank of its side ``a``). A pair's sides need not be listed apart.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        subdomains: Sequence[Subdomain],
        interface: Interface | None = None,
        contacts: Sequence[ContactInterface | ContactBoundary | ContactPair] = (),
    ):
        arguments.instance(comm, MPI.Comm, "Scene: comm")
        if isinstance(subdomains, Subdomain) or len(subdomains) == 0:
            raise InputError("Scene: give a list of at least one subdomain")
        for s in subdomains:
            arguments.instance(s, Subdomain, "Scene: subdomains")
        if interface is not None:
            arguments.instance(interface, Interface, "Scene: interface")
        if isinstance(contacts, _ContactBase):
            raise InputError("Scene: contacts must be a list, e.g. contacts=[zone]")
        for c in contacts:
            arguments.instance(
                c, (ContactInterface, ContactBoundary, ContactPair), "Scene: contacts"
            )
        contacts, self.pairs = _split_pairs(contacts)
        names = [s.name for s in subdomains]
        if len(set(names)) != len(names):
            raise InputError(f"Scene: subdomain names must be unique, got {names}")
        if interface is not None:
            for s in interface.subdomains:
                if all(s is not t for t in subdomains):
                    raise InputError(
                        f"Scene: interface {interface.name!r} ties subdomain {s.name!r}, "
                        "which is not in the scene's subdomain list"
                    )
        contact_names = [c.name for c in contacts] + [p.name for p in self.pairs]
        if len(set(contact_names)) != len(contact_names):
            raise InputError(f"Scene: contact names must be unique, got {contact_names}")
        for c in contacts:
            if all(c.subdomain is not t for t in subdomains):
                raise InputError(
                    f"Scene: contact {c.name!r} belongs to subdomain {c.subdomain.name!r}, "
                    "which is not in the scene's subdomain list"
                )
        self.comm = comm
        self.subdomains = list(subdomains)
        self.interface = interface
        self.contacts = list(contacts)
        self._check_same_on_every_rank()
        share_cores(comm)  # ranks that share a node share its cores (BLAS threads)

    def _check_same_on_every_rank(self) -> None:
        """Collective: refuse meshes that differ between ranks (each rank builds them all).

        Caught here, with the mesh named, before any collective of the solvers could hang or
        abort on arrays of different sizes.
        """
        if self.comm.size == 1:
            return
        meshes = [(f"subdomain {s.name!r}", s.mesh) for s in self.subdomains]
        if self.interface is not None:
            meshes.append((f"interface {self.interface.name!r}", self.interface.mesh))
        meshes += [(f"contact {c.name!r}", c.mesh) for c in self.contacts]
        mine = [(what, _mesh_digest(mesh)) for what, mesh in meshes]
        for rank, theirs in enumerate(allgathered(self.comm, mine)):
            for (what, digest), (_, other) in zip(mine, theirs, strict=True):
                if digest != other:
                    raise InputError(
                        f"Scene: the mesh of {what} on rank {self.comm.rank} differs from the "
                        f"one on rank {rank}; every rank must build the same meshes (the same "
                        "script, inputs and mesh generator settings on every rank)"
                    )

    def index(self, subdomain: Subdomain) -> int:
        """Position of a subdomain in the scene."""
        return next(k for k, s in enumerate(self.subdomains) if s is subdomain)

    def contact_owner(self, contact: ContactInterface | ContactBoundary | ContactPair) -> int:
        """Rank that owns a contact region: its subdomain's owner (a pair's, for its sides)."""
        for pair in self.pairs:
            if contact is pair.b:
                return self.contact_owner(pair)
        return self.owner(self.index(contact.subdomain))

    @property
    def regions(self) -> list[ContactInterface | ContactBoundary | ContactPair]:
        """The contact regions: the contacts with an obstacle, then the pairs."""
        return [c for c in self.contacts if c.obstacle is not None] + list(self.pairs)

    def owner(self, k: int) -> int:
        """Rank that owns subdomain ``k``."""
        return owner_of(k, self.comm)

    def bodies(self) -> list[Body]:
        """The bodies: the subdomains tied through the interface, and each other subdomain."""
        tied = list(self.interface.subdomains) if self.interface is not None else []
        groups = [tied] if tied else []
        groups += [[s] for s in self.subdomains if all(s is not t for t in tied)]
        return [Body.of(group) for group in groups]

    def check_static_supports(self) -> None:
        """Raise if some part of the body can move rigidly (a singular static problem).

        Subdomains tied through the interface form one body; each body's Dirichlet conditions
        must stop all six rigid-body motions, or contact must (checked at every solve, see
        :class:`Body`).
        """
        for body in self.bodies():
            if any(c.subdomain is s for c in self.contacts for s in body.subdomains):
                continue  # contact may hold it: the contact iteration checks each active set
            if body.free.shape[1]:
                names = ", ".join(repr(s.name) for s in body.subdomains)
                raise InputError(
                    f"static scene: subdomain(s) {names} can move as a rigid body "
                    f"({body.describe()}): they have too few Dirichlet conditions and are not "
                    "tied to a supported subdomain; add Subdomain.fix(...) or tie them through "
                    "the interface, or solve a dynamic problem"
                )


def _mesh_digest(mesh) -> tuple[int, int, str]:
    """Cells, nodes and a hash of the node coordinates and connectivity of a mesh."""
    x = np.ascontiguousarray(mesh.geometry.x)
    cells = np.ascontiguousarray(mesh.geometry.dofmaps[0])
    digest = hashlib.sha256(x.tobytes() + cells.tobytes()).hexdigest()
    return cells.shape[0], x.shape[0], digest


def _split_pairs(contacts) -> tuple[list, list[ContactPair]]:
    """The contact surfaces (a pair's sides once) and the pairs; refuse a surface left alone."""
    pairs = [c for c in contacts if isinstance(c, ContactPair)]
    surfaces = [c for c in contacts if not isinstance(c, ContactPair)]
    for pair in pairs:
        surfaces += [side for side in pair.sides if all(side is not c for c in surfaces)]
    for c in surfaces:
        if c.obstacle is None and all(c is not side for p in pairs for side in p.sides):
            raise InputError(
                f"Scene: contact interface {c.name!r} has no obstacle and is in no ContactPair; "
                "give it an obstacle or put it in a ContactPair in the scene's contacts"
            )
    return surfaces, pairs
