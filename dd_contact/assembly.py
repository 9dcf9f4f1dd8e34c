"""From a scene to the block system (14): the blocks each rank owns, as scipy matrices.

Block rows are :class:`~dd_contact.blocks.Block` s: ``u:<subdomain>``, ``v:<interface>`` and
``w:<contact interface>``. A
rank holds only the pieces it owns; contributions to another rank's rows (the interface
mass P_DI4 and the lifted right-hand side) travel when the system is handed to PETSc.

The contact terms (A8, A9) are not in the block system: they change with the contact state.
Each contact region becomes a :class:`ContactZone` that says which block and dofs its
surface displacement lives in, so every solver can add P_C where it belongs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu
from scipy.spatial import cKDTree

from dd_contact import coupling, forms
from dd_contact.blocks import Block, BlockKeyed, BlockSystem, ContactRegion, StiffTie
from dd_contact.contact import (
    ContactOperator,
    contact_operator,
    largest_turn,
    mean_cell_size,
    patch_average,
)
from dd_contact.errors import InputError, PenaltyRangeWarning, SurfaceResolutionWarning, warn
from dd_contact.pairs import PairOperator, pair_operator
from dd_contact.parallel import elementwise_max
from dd_contact.scene import (
    KAPPA_ASSEMBLED,
    KAPPA_ASSEMBLED_PROJECTED,
    KAPPA_SPLIT,
    KAPPA_VERIFIED,
    ContactBoundary,
    ContactInterface,
    ContactPair,
    Scene,
)

__all__ = ["ContactZone", "Lifting", "Model", "PairZone", "assemble"]


def _tie_operators(surface, sub, what: str) -> coupling.TieOperators:
    """Tie operators between a subdomain and a surface; refuse a surface that misses it."""
    ops = coupling.tie_operators(sub.V, surface.V, tolerance=surface.tolerance)
    if ops.area == 0.0:
        raise InputError(
            f"{what} {surface.name!r} does not touch subdomain {sub.name!r}: no cell of it "
            "lies on that subdomain's boundary within the tolerance; move the surface mesh onto "
            "the boundary, raise its tolerance, or tie it to the right subdomain"
        )
    if not _is_facet_copy(surface, sub, ops):
        ops = _projected(ops)
    return ops


def _add_tie(system: BlockSystem, sub, surface, ops: coupling.TieOperators) -> None:
    """Penalty tie terms (9)-(11): P1 on u, -P2 between u and s, P4 on s, all over eps.

    Stiffer than KAPPA_SPLIT: assembled at KAPPA_ASSEMBLED (KAPPA_ASSEMBLED_PROJECTED if
    not matching), the rest a :class:`StiffTie`; records eps and kappa, warns outside range.
    """
    E, h = sub.material.E, ops.height
    eps, kappa = surface.penalty.epsilon_for(h, E), surface.penalty.kappa_for(h, E)
    stiff = kappa > KAPPA_SPLIT
    matching = not (stiff and ops.projected) or coupling.matching(ops, sub.mesh, surface.mesh)
    split = KAPPA_ASSEMBLED if matching else KAPPA_ASSEMBLED_PROJECTED
    assembled, u, s = ops.height / (E * split) if stiff else eps, sub.block, surface.block
    P1, P2, P4 = (coupling.blocked(P) for P in (ops.P1, ops.P2, ops.P4))
    system.add(u, u, P1 / assembled)
    system.add(u, s, -P2 / assembled)
    system.add(s, s, P4 / assembled)
    if stiff:
        name = f"{surface.name!r} on {sub.name!r}"
        rho, sigma = 1.0 / assembled, 1.0 / eps - 1.0 / assembled
        system.stiff_ties.append(StiffTie(name, u, s, P1, P2, P4, rho, sigma))
    system.penalties[(sub.name, surface.name)] = eps
    system.kappas[(sub.name, surface.name)] = kappa
    low, high = KAPPA_VERIFIED
    if not low <= kappa <= high:
        warn(
            f"the tie of {surface.name!r} to subdomain {sub.name!r} has kappa = {kappa:.3g}, "
            f"outside the verified range [{low:g}, {high:g}]: its results are not verified "
            "(each solve's residual check still guards against a wrong solution); choose "
            "kappa (or epsilon = h / (E kappa)) inside the range",
            PenaltyRangeWarning,
        )


def _is_facet_copy(surface, sub, ops: coupling.TieOperators) -> bool:
    """Whether a surface mesh is the tied facets' (same cells, nodes, positions)."""
    surface_x = surface.mesh.geometry.x
    cells = surface.mesh.topology.index_map(2).size_local
    wall = np.unique(dolfinx.mesh.entities_to_geometry(sub.mesh, 2, ops.facets))
    if len(ops.facets) != cells or len(wall) != len(surface_x):
        return False
    distance, _ = cKDTree(sub.mesh.geometry.x[wall]).query(surface_x)
    return bool(np.all(distance <= 1e-9 * ops.height))


def _projected(ops: coupling.TieOperators) -> coupling.TieOperators:
    """The tie with P1 = P2 P4^-1 P2^T: the surface is tied to the wall's projection on it.

    The penalty tie holds the surface field to the wall displacement u pointwise; on a mesh
    that does not match the wall it also penalises what the surface cannot represent, which
    locks the wall (a block pressed on a pin carried 2.9-3.6x the force, a gmsh pin hole gave
    4-200x the peak pressure, a non-matching bent bar came out 2.5 % stiff). The projected
    tie penalises ``|s - Pi u|`` with ``Pi = P4^-1 P2^T`` over the surface nodes above this
    subdomain instead (a mortar projection): rigid and linear fields stay exact, nothing
    locks. P1 is dense over the tied wall nodes.
    """
    wall = np.unique(sp.coo_array(ops.P2).row)
    covered = np.flatnonzero(ops.P4.diagonal() > 0)  # surface nodes over this subdomain
    P2 = sp.csr_array(ops.P2)[wall][:, covered]
    P4 = sp.csc_array(sp.csr_array(ops.P4)[covered][:, covered])
    X = splu(P4).solve(P2.T.toarray())
    block = P2 @ X
    rows, cols = np.meshgrid(wall, wall, indexing="ij")
    n = ops.P1.shape[0]
    P1 = sp.csr_array((block.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n))
    return dataclasses.replace(ops, P1=P1, projected=True)


def _check_covered(surface, what: str, coverage: np.ndarray, comm: MPI.Comm | None) -> None:
    """Every surface cell must lie on a subdomain boundary (else it ties nothing).

    ``coverage`` is each cell's covered fraction; with ``comm`` it is first maximised over
    the ranks (each rank ties only its own subdomains).
    """
    if comm is not None:
        coverage = elementwise_max(comm, coverage)
    loose = np.flatnonzero(coverage < 0.999)
    if loose.size:
        nodes = surface.mesh.geometry.x[surface.mesh.geometry.dofmaps[0][loose[0]]]
        raise InputError(
            f"{what} {surface.name!r}: {loose.size} of its {coverage.size} cells do not lie "
            f"on a subdomain boundary (cell {loose[0]} near {np.round(nodes.mean(axis=0), 6)} is "
            f"{100 * (1 - coverage[loose[0]]):.1f}% uncovered); the surface mesh must lie on the "
            "boundary it ties to: move it, trim it to the shared face, or raise its tolerance"
        )


#: Node-to-node swing of the recovered pressure (fraction of its peak, ContactZone._swing)
#: above which a contact surface is reported as unresolved by its wall: it separates the
#: accurate surfaces from those finer than their wall (docs/validation.md, "Surfaces finer
#: than their wall", has the measurements).
OSCILLATION_LIMIT = 0.075

#: Cell size of a curved wall along its curvature over its contact surface's above which the
#: surface counts as finer than its wall (resolution_warning; the ratios measured accurate
#: and inaccurate are in docs/validation.md).
FINER_LIMIT = 1.1
#: Turn between neighbouring wall facets [rad] below which a wall counts as flat: its
#: facets then lie within h * turn / 8 (1e-4 h) of any surface on it.
FLAT_TURN = 1e-3

#: Penetration (fraction of the contact surface's cell size) above which a contact penalty
#: counts as too soft: the answer then carries that much penalty error, which a stiffer
#: contact_kappa removes (the bar impact's sinking against contact_kappa: docs/validation.md).
SINKING_LIMIT = 0.05


@dataclass
class ContactZone:
    """A contact region as the solvers see it.

    Attributes:
        contact: The ContactInterface or ContactBoundary.
        block: Block that holds the contact surface's displacement (``w:`` or ``u:``).
        dofs: Block dof of every surface dof (3 per surface node).
        operator: Gap, normals and the contact matrices.
        free: Surface dofs that are not prescribed (a prescribed dof takes no contact term).
        prescribed: Prescribed value of every surface dof (zero where free).
        length: Mean cell size of the contact surface: the zone's length scale.
        recovery: Pressure recovery of a surface that does not copy its wall (None for
            facet copies and contact boundaries, whose nodal pressure is the wall's own).
        wall: The subdomain dofs on the facets the contact acts through (its own surface
            dofs for a contact boundary, the tied facets' dofs for a contact interface).
        check_resolution: Whether :meth:`pressure` checks the recovered pressure's swing.
            Off in time stepping with inertia: an impact's pressure is rough from node to
            node on any surface, a facet copy's too (the bar: 1.01 MPa between 0.28 and
            0.48), and the check is calibrated on static pressure. A surface finer than its
            curved wall is reported at assembly in any problem (:func:`resolution_warning`).
    """

    contact: ContactInterface | ContactBoundary | ContactPair
    block: Block
    dofs: np.ndarray
    operator: ContactOperator
    free: np.ndarray
    prescribed: np.ndarray
    length: float
    recovery: sp.csr_array | None = None
    wall: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    check_resolution: bool = True
    warned: bool = field(default=False, repr=False)
    sank: bool = field(default=False, repr=False)

    def pressure(self, w: np.ndarray) -> np.ndarray:
        """Nodal contact pressure of the surface displacement ``w`` (compression positive).

        Warns once if points sink into the obstacle deeper than SINKING_LIMIT of a cell
        (the contact penalty is too soft), and, on a recovered surface, once if the pressure
        still swings from node to node by more than OSCILLATION_LIMIT of its peak.
        """
        depth = float(self.operator.penetration(w).max(initial=0.0))
        if not self.sank and depth > SINKING_LIMIT * self.length:
            self.sank = True
            warn(
                f"contact {self.contact.name!r}: points sink {depth:.3g} into the obstacle, "
                f"{depth / self.length:.0%} of a cell: the contact penalty is too soft and the "
                "results carry that error; raise contact_kappa (the default is stiff)",
                PenaltyRangeWarning,
            )
        raw = self.operator.nodal_pressure(w)
        if self.recovery is None:
            return raw
        p = self.recovery @ raw
        # below a strain of 1e-9 the pressure is round-off (an unloaded wall that touches)
        negligible = 1e-9 * self.contact.subdomain.material.E
        if self.check_resolution and not self.warned and p.max() > negligible:
            swing = self._swing(p)
            if swing > OSCILLATION_LIMIT:
                self.warned = True
                warn(
                    f"contact interface {self.contact.name!r}: the contact pressure swings "
                    f"by {swing:.0%} of its peak from node to node, which the wall it is tied "
                    "to does not resolve (a contact surface finer than its wall?): its peak "
                    "is unreliable (measured 5-170 % high) and the surface can stiffen the "
                    "wall (force +5.6 % under a prescribed displacement); mesh the contact "
                    "surface no finer than the wall, or use ContactInterface.from_boundary",
                    SurfaceResolutionWarning,
                )
        return p

    def _swing(self, p: np.ndarray) -> float:
        """The node-to-node part of the recovered pressure, over its peak.

        ``d = p - R p`` is the pressure's local curvature; ``d - R d`` keeps what of it
        changes sign from node to node (a smooth field leaves little: fourth differences).
        Taken at nodes whose two rings of neighbours have pressure, so the contact edge and
        an inactive node inside the area both show.
        """
        R = self.recovery
        assert R is not None  # swings only after a recovery
        near = (R != 0).astype(float)
        inside = (p > 0) & (near @ (p <= 0).astype(float) == 0)
        inside &= near @ (~inside).astype(float) == 0
        d = p - R @ p
        return float(np.abs(d - R @ d)[inside].max() / p.max()) if inside.any() else 0.0

    @property
    def parts(self) -> list[tuple[Block, np.ndarray]]:
        """``(block, dofs)`` of the surface displacement, in the contact matrix's order."""
        return [(self.block, self.dofs)]

    @property
    def sides(self) -> list:
        """The contact surfaces whose displacement this zone reads (one; a pair's two)."""
        return [self.contact]

    @property
    def subdomains(self) -> list:
        """The subdomains whose bodies this zone's points hold."""
        return [side.subdomain for side in self.sides]

    def gather(self, x: BlockKeyed[np.ndarray]) -> np.ndarray:
        """The zone's surface displacement (contact matrix numbering) from the blocks ``x``."""
        parts = self.parts
        if len(parts) == 1:
            return x[parts[0][0]][parts[0][1]]
        return np.concatenate([x[block][dofs] for block, dofs in parts])

    def scatter(self, vector: np.ndarray, sizes: BlockKeyed[int]) -> dict[str, np.ndarray]:
        """A vector in contact matrix numbering as block vectors (zero elsewhere)."""
        out: dict[str, np.ndarray] = {}
        start = 0
        for block, dofs in self.parts:
            out[block] = np.zeros(sizes[block])
            np.add.at(out[block], dofs, vector[start : start + len(dofs)])
            start += len(dofs)
        return out

    @property
    def wall_parts(self) -> list[tuple[Block, np.ndarray]]:
        """``(subdomain block, wall dofs)`` of each side: the dofs its contact acts through."""
        return [(self.contact.subdomain.block, self.wall)]

    def published(self) -> np.ndarray:
        """The surface displacement last published in the sides' Functions."""
        return np.concatenate([side.w.x.array[: side.num_dofs] for side in self.sides])

    def publish(self, x: Mapping[str, np.ndarray]) -> None:
        """Put the nodal contact pressure of the solution ``x`` in the sides' Functions."""
        self.sides[0].pressure.x.array[:] = self.pressure(self.gather(x))

    def contribution(self, active: np.ndarray) -> tuple[sp.csr_array, np.ndarray]:
        """Contact matrix and right-hand side in surface dof numbering (prescribed dofs out)."""
        C = self.operator.matrix(active)
        rhs = self.operator.rhs(active) - C @ self.prescribed
        free = None if self.free.all() else sp.diags_array(self.free.astype(float))  # all: as is
        return (C, rhs) if free is None else (sp.csr_array(free @ C @ free), rhs * self.free)

    @property
    def region(self) -> ContactRegion:
        """What a solver reserves for this zone: its block, dofs and matrix pattern."""
        return self.operator.region(self.contact.name, self.block, self.dofs, self.free)


@dataclass
class PairZone(ContactZone):
    """A contact pair as the solvers see it: one region over the two sides' w blocks.

    ``block``/``dofs`` are side a's, ``partner``/``partner_dofs`` side b's; the operator
    (:class:`~dd_contact.pairs.PairOperator`) acts on ``[w_a; w_b]``.
    """

    partner: Block = field(default_factory=lambda: Block("w", ""))
    partner_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    walls: list[np.ndarray] = field(default_factory=list)

    @property
    def wall_parts(self) -> list[tuple[Block, np.ndarray]]:
        """Each side's subdomain and the dofs of the facets it is tied to."""
        return [(s.subdomain.block, w) for s, w in zip(self.sides, self.walls, strict=True)]

    @property
    def parts(self) -> list[tuple[Block, np.ndarray]]:
        """Side a's block and dofs, then side b's."""
        return [(self.block, self.dofs), (self.partner, self.partner_dofs)]

    @property
    def sides(self) -> list:
        """The pair's two contact interfaces."""
        assert isinstance(self.contact, ContactPair)
        return list(self.contact.sides)

    def publish(self, x: Mapping[str, np.ndarray]) -> None:
        """Each side's nodal contact pressure (the sinking check as for an obstacle)."""
        z = self.gather(x)
        self.pressure(z)  # warns once if the penalty lets the surfaces sink
        assert isinstance(self.operator, PairOperator)
        for side, p in zip(self.sides, self.operator.side_pressures(z), strict=True):
            side.pressure.x.array[:] = p

    @property
    def region(self) -> ContactRegion:
        """Both blocks' region (a's dofs, then b's; its point rows; friction: unsymmetric)."""
        a, b, plain = self.block, self.partner, self.operator.friction is None
        parts = (self.contact.name, a, self.dofs, self.operator.pattern(), b, self.partner_dofs)
        return ContactRegion(*parts, plain, not plain, self.operator.point_rows(self.free))


@dataclass
class Lifting:
    """What prescribed values put on the right-hand side of the eliminated system.

    For values g on the dofs D of a block: ``-A[:, D] g`` on every row, and g itself on
    the rows of D (the identity after elimination), with A the matrix before elimination.
    The matrix does not depend on g: a new value is a new right-hand side, never a new
    factorisation.

    Attributes:
        sizes: Size of every block.
        dofs: The prescribed dofs of every owned subdomain block.
        columns: Per prescribed block, ``(row block, A[rows, D])`` of every coupled block.
    """

    sizes: dict[Block, int]
    dofs: dict[Block, np.ndarray]
    columns: dict[Block, list[tuple[Block, sp.csr_array]]]

    def __call__(self, values: dict[Block, np.ndarray]) -> dict[Block, np.ndarray]:
        """This rank's right-hand-side contributions for the values of every owned block."""
        rhs: dict[Block, np.ndarray] = {}
        for block, parts in self.columns.items():
            for row, columns in parts:
                lifted = -(columns @ values[block])
                rhs[row] = rhs[row] + lifted if row in rhs else lifted
        for block, dofs in self.dofs.items():
            if dofs.size:
                rhs.setdefault(block, np.zeros(self.sizes[block]))[dofs] = values[block]
        return rhs


@dataclass
class Model:
    """This rank's assembled pieces of a scene, before any time discretisation.

    Attributes:
        system: K_D with the tie terms, unconstrained, and no loads.
        mass: M_D of every owned subdomain block.
        dirichlet: Prescribed (dofs, values) of every owned subdomain block.
        zones: The owned contact regions.
        reduced: The owned reduced subdomains' bases once ``reduce_model`` replaced their
            pieces; ``massless_reduced`` every reduced block's massless coordinates.
    """

    system: BlockSystem
    mass: dict[Block, sp.csr_array]
    dirichlet: dict[Block, tuple[np.ndarray, np.ndarray]]
    zones: list[ContactZone]
    reduced: dict[Block, Any] = field(default_factory=dict)
    massless_reduced: dict[Block, np.ndarray] = field(default_factory=dict)

    def lifting(self, mass_coefficient: float) -> Lifting:
        """The right-hand side of prescribed values in :meth:`effective`'s system, for any g."""
        columns = {}
        for block, (dofs, _) in self.dirichlet.items():
            columns[block] = self.system.prescribed_columns(block, dofs)
            if mass_coefficient and block in self.mass:
                mass = sp.csc_array(self.mass[block])[:, dofs]
                columns[block].append((block, sp.csr_array(mass_coefficient * mass)))
        prescribed = {block: dofs for block, (dofs, _) in self.dirichlet.items()}
        return Lifting(self.system.sizes, prescribed, columns)

    def effective(self, mass_coefficient: float) -> BlockSystem:
        """``K + c M`` with the Dirichlet conditions eliminated; rhs = their lifting."""
        system = self.system.copy()
        if mass_coefficient:
            for block, M in self.mass.items():
                system.add(block, block, mass_coefficient * M)
        for block, (dofs, values) in self.dirichlet.items():
            system.constrain(block, dofs, values)
        return system

    def free(self, block: Block) -> np.ndarray:
        """1.0 on the free dofs of an owned block, 0.0 on prescribed ones."""
        mask = np.ones(self.system.sizes[block])
        if block in self.dirichlet:
            mask[self.dirichlet[block][0]] = 0.0
        return mask


def resolution_warning(
    contact: ContactInterface, volume: dolfinx.mesh.Mesh, facets: np.ndarray
) -> bool:
    """Warn (and say so) if a contact interface is finer than its curved wall.

    A surface with more cells along a wall's curvature than the wall has gives pressures
    5-170 % high (docs/validation.md). Geometry alone decides, so the check holds in dynamics,
    where an impact's pressure is rough on any surface: cells turn from one to the next by
    the curvature times their size across it (:func:`contact.largest_turn`), so the wall's
    turn over the surface's is how many surface cells lie along one wall cell.
    """
    wall = largest_turn(volume.geometry.x, dolfinx.mesh.entities_to_geometry(volume, 2, facets))
    surface = largest_turn(contact.mesh.geometry.x, contact.mesh.geometry.dofmaps[0])
    if wall < FLAT_TURN or wall <= FINER_LIMIT * surface:
        return False
    warn(
        f"contact interface {contact.name!r} is finer than its wall along the wall's "
        f"curvature ({wall / max(surface, 1e-300):.2g} of its cells along one wall facet, "
        f"whose neighbours turn by {np.degrees(wall):.3g} degrees): its pressure peaks are "
        "unreliable (measured 5-170 % high) and it can stiffen the wall (force +5.6 % under a "
        "prescribed displacement); mesh the contact surface no finer than the wall along the "
        "curvature, or use ContactInterface.from_boundary",
        SurfaceResolutionWarning,
    )
    return True


def _contact_zone(
    scene: Scene, system: BlockSystem, contact: ContactInterface | ContactBoundary, k: int
) -> tuple[ContactZone | None, np.ndarray | None, tuple[float, np.ndarray]]:
    """Tie a contact interface (or map a contact boundary) into the system.

    Returns its zone (``None`` for a side of a contact pair: the pair makes the zone), its
    cells' coverage, and the height of the cells behind it with the wall's dofs.
    """
    sub = scene.subdomains[k]
    u = sub.block
    if isinstance(contact, ContactBoundary):
        height = coupling.facet_height(sub.mesh, contact.facets)
        block = u
        dofs = (3 * contact.node_map[:, None] + np.arange(3)).ravel()
        coverage = recovery = None
        wall = dofs
        reported = False
    else:
        ops = _tie_operators(contact, sub, "contact interface")
        block = contact.block
        _add_tie(system, sub, contact, ops)
        dofs = np.arange(contact.num_dofs)
        coverage = ops.covered_area / ops.cell_area
        height = ops.height
        # A surface that does not copy its wall carries a node-to-node pressure oscillation
        # that the wall does not feel (measured up to +25 % on tetrahedra): recover it.
        recovery = patch_average(ops.P4) if ops.projected else None
        reported = ops.projected and resolution_warning(contact, sub.mesh, ops.facets)
        nodes = dolfinx.fem.locate_dofs_topological(sub.V, 2, ops.facets)
        wall = (3 * nodes[:, None] + np.arange(3)).ravel()
    if contact.obstacle is None:  # a side of a pair
        return None, coverage, (height, wall)
    eps_c = contact.contact_penalty.epsilon_for(height, sub.material.E)
    system.penalties[(sub.name, f"contact:{contact.name}")] = eps_c
    operator = contact_operator(contact, eps_c)
    free, prescribed = np.ones(len(dofs), bool), np.zeros(len(dofs))
    if block == u:  # contact on the subdomain's own dofs: some may be prescribed
        fixed, values = sub.dirichlet
        prescribed_full = np.zeros(sub.num_dofs)
        prescribed_full[fixed] = values
        free, prescribed = ~np.isin(dofs, fixed), prescribed_full[dofs]
    length = mean_cell_size(contact.mesh)
    zone = ContactZone(contact, block, dofs, operator, free, prescribed, length, recovery, wall)
    zone.warned = reported  # the pressure-swing check need not say it again
    return zone, coverage, (height, wall)


def _pair_zone(system: BlockSystem, pair: ContactPair, tied: dict[str, tuple]) -> PairZone:
    """The zone of a contact pair: its penalty from the stiffer side (E / h), its operator.

    ``tied``: each side tied on this rank's (height, wall dofs); the others' are found here.
    """

    def stiffness(side: ContactInterface) -> float:
        if side.name not in tied:  # tied on another rank: its height and wall found here too
            ops = _tie_operators(side, side.subdomain, "contact interface")
            nodes = dolfinx.fem.locate_dofs_topological(side.subdomain.V, 2, ops.facets)
            tied[side.name] = (ops.height, (3 * nodes[:, None] + np.arange(3)).ravel())
        return side.subdomain.material.E / tied[side.name][0]

    stiffer = max(pair.sides, key=stiffness)
    eps = pair.contact_penalty.epsilon_for(tied[stiffer.name][0], stiffer.subdomain.material.E)
    a, b = pair.sides
    system.penalties[(a.subdomain.name, f"contact:{pair.name}")] = eps
    operator = pair_operator(pair, eps)
    n = operator.num_dofs
    return PairZone(
        pair,
        a.block,
        np.arange(a.num_dofs),
        operator,
        np.ones(n, bool),
        np.zeros(n),
        mean_cell_size(a.mesh),
        partner=b.block,
        partner_dofs=np.arange(b.num_dofs),
        walls=[tied[side.name][1] for side in pair.sides],
    )


def assemble(scene: Scene) -> Model:
    """This rank's pieces of system (14) without time discretisation and contact terms."""
    rank = scene.comm.rank
    sizes = {s.block: s.num_dofs for s in scene.subdomains}
    owners = {s.block: scene.owner(k) for k, s in enumerate(scene.subdomains)}
    if scene.interface is not None:
        sizes[scene.interface.block] = scene.interface.num_dofs
        owners[scene.interface.block] = 0
    for c in scene.contacts:
        if not isinstance(c, ContactBoundary):
            sizes[c.block] = c.num_dofs
            owners[c.block] = scene.contact_owner(c)
    system = BlockSystem(sizes, owners)
    model = Model(system, {}, {}, [])
    iface = scene.interface
    tied = iface.subdomains if iface is not None else []
    coverage = np.zeros(
        iface.mesh.topology.index_map(2).size_local if iface is not None and tied else 0
    )
    for k, sub in enumerate(scene.subdomains):
        if scene.owner(k) != rank:
            continue
        u = sub.block
        system.add(u, u, forms.assemble_stiffness(sub))
        if sub.material.rho > 0:
            model.mass[u] = forms.assemble_mass(sub)
        model.dirichlet[u] = sub.dirichlet
        if any(sub is t for t in tied):
            ops = _tie_operators(iface, sub, "interface")
            _add_tie(system, sub, iface, ops)
            coverage = np.maximum(coverage, ops.covered_area / ops.cell_area)
    if tied:
        _check_covered(iface, "interface", coverage, scene.comm)
    walls: dict[str, tuple] = {}
    for c in scene.contacts:
        k = scene.index(c.subdomain)
        if scene.owner(k) != rank:
            continue
        zone, cover, walls[c.name] = _contact_zone(scene, system, c, k)
        if cover is not None:
            _check_covered(c, "contact interface", cover, None)
        if zone is not None:
            model.zones.append(zone)
    for pair in scene.pairs:
        if scene.contact_owner(pair) == rank:
            model.zones.append(_pair_zone(system, pair, walls))
    return model
