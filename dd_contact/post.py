"""Post-processing: stresses, output fields, support reactions, contact results, energy.

Units are those of the input: with SI input (m, Pa, N, kg, s) forces are in N, stresses and
contact pressure in Pa, areas in m^2, gaps in m and energies in J.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import scipy.sparse as sp
import ufl

from dd_contact.assembly import ContactZone, Model
from dd_contact.blocks import Block
from dd_contact.contact import ContactOperator
from dd_contact.forms import stress
from dd_contact.impact import BlockProducts
from dd_contact.iteration import STATE_BAND
from dd_contact.parallel import gather_to_root, gathered
from dd_contact.scene import ContactBoundary, ContactInterface, Interface, Scene, Where
from dd_contact.subdomains import Subdomain

__all__ = [
    "MeshFields",
    "Reactions",
    "Results",
    "boundary_average",
    "carrying_points",
    "cell_stress",
    "contact_area",
    "energy",
    "gather_contact_fields",
    "output_fields",
    "part_fields",
    "von_mises",
]


def cell_stress(sub: Subdomain) -> np.ndarray:
    """Stress at each cell's midpoint, shape ``(num_cells, 3, 3)``."""
    Q = fem.functionspace(sub.mesh, ("DG", 0, (3, 3)))
    sigma = fem.Function(Q)
    sigma.interpolate(fem.Expression(stress(sub.u, sub.material), Q.element.interpolation_points))
    return sigma.x.array.reshape(-1, 3, 3)


def von_mises(sub: Subdomain) -> fem.Function:
    """Cell-wise von Mises stress as a DG0 function (for plots and output)."""
    s = cell_stress(sub)
    dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3.0
    W = fem.functionspace(sub.mesh, ("DG", 0))
    out = fem.Function(W, name=f"von_mises_{sub.name}")
    out.x.array[:] = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
    return out


def boundary_average(sub: Subdomain, where: Where) -> np.ndarray:
    """Area-averaged displacement over a boundary region of a subdomain."""
    facets = sub.locate_facets(where)
    tags = dolfinx.mesh.meshtags(sub.mesh, 2, facets, np.ones_like(facets))
    ds = ufl.Measure("ds", domain=sub.mesh, subdomain_data=tags)
    area = fem.assemble_scalar(fem.form(fem.Constant(sub.mesh, 1.0) * ds(1)))
    return np.array([fem.assemble_scalar(fem.form(sub.u[i] * ds(1))) / area for i in range(3)])


def energy(
    model: Model,
    x: Mapping[str, np.ndarray],
    velocities: Mapping[Block, np.ndarray],
    zones: Sequence[ContactZone],
    products: BlockProducts | None = None,
) -> dict[str, float]:
    """This rank's part of the kinetic, elastic (with ties) and contact-penalty energy.

    Sum the parts over the ranks for the model's energy
    (:meth:`dd_contact.TransientProblem.energy` does).

    Args:
        model: This rank's assembled pieces (stiffness and tie blocks, mass matrices).
        x: Every block's displacement (``u:``, ``v:`` and ``w:`` blocks).
        velocities: Velocity of every owned subdomain block.
        zones: This rank's contact zones (their surface displacement is read from the scene).
        products: Where the block rows of ``K x`` are taken (and kept for the next step's
            start forces); by default computed here.

    Returns:
        ``"kinetic"``, ``"elastic"``, ``"contact"`` (the penalties' stored energy, friction's
        tangential one in) and ``"dissipated"`` (friction's work over the last step, >= 0).
    """
    product = products.row if products else model.system.row_product
    rows = sorted({block for pair in model.system.matrices for block in pair})
    # x K x / 2 row by row: each off-diagonal piece is read from both its blocks' rows
    elastic = 0.5 * sum(float(x[row] @ product(row, x)) for row in rows)
    for tie in model.system.stiff_ties:  # the ties' penalty above KAPPA_SPLIT
        elastic += 0.5 * tie.sigma * sum(float(x[b] @ f) for b, f in tie.jump(x).items())
    kinetic = 0.0
    for block, v in velocities.items():
        if block in model.mass:
            kinetic += 0.5 * float(v @ (model.mass[block] @ v))
    contact = float(sum(z.operator.energy(z.published()) for z in zones))
    frictions = [f for z in zones if (f := getattr(z.operator, "friction", None)) is not None]
    dissipated = float(sum(f.dissipation for f in frictions))
    return {"kinetic": kinetic, "elastic": elastic, "contact": contact, "dissipated": dissipated}


def friction_unfit(scene) -> tuple[str, ...]:
    """The algorithms the friction of ``scene`` rules out (its unsymmetric blocks).

    v-u where a subdomain's own boundary has friction: the subdomain would be unsymmetric.
    """
    own = any(getattr(c, "friction", 0.0) > 0.0 and c.block.kind == "u" for c in scene.contacts)
    return ("v-u",) if own else ()


def frictional(scene) -> bool:
    """Whether some contact of ``scene`` has friction (on every rank alike)."""
    return any(getattr(c, "friction", 0.0) > 0.0 for c in scene.regions)


@dataclass
class MeshFields:
    """The output Functions of one mesh and how to bring the derived ones up to date.

    Attributes:
        stem: File name stem (the mesh's displacement Function's name, e.g. ``u_left``).
        functions: What is written: the solution Functions and the derived ones.
        refresh: ``refresh(t)`` recomputes the derived Functions from the solution at ``t``.
    """

    stem: str
    functions: list[fem.Function]
    refresh: Callable[[float], None]


def _subdomain_fields(sub: Subdomain, dynamic: bool) -> MeshFields:
    """Displacement (velocity, acceleration), cell stress tensor, von Mises stress (DG0)."""
    tensor = fem.functionspace(sub.mesh, ("DG", 0, (3, 3)))
    sigma = fem.Function(tensor, name=f"stress_{sub.name}")
    mises = fem.Function(fem.functionspace(sub.mesh, ("DG", 0)), name=f"von_mises_{sub.name}")
    expression = fem.Expression(stress(sub.u, sub.material), tensor.element.interpolation_points)

    def refresh(t: float) -> None:
        sigma.interpolate(expression)
        s = sigma.x.array.reshape(-1, 3, 3)
        dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3.0
        mises.x.array[:] = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))

    motion = [sub.velocity, sub.acceleration] if dynamic else []
    return MeshFields(sub.u.name, [sub.u, *motion, sigma, mises], refresh)


def _contact_fields(contact: ContactInterface | ContactBoundary) -> MeshFields:
    """w, nodal pressure, gap ``s - w . n`` at the nodes and the active nodes (1 or 0).

    With friction also the accumulated slip, the tangential traction on the body and the
    stick/slip map (0 open, 1 stick, 2 slip; a node's points averaged with quadrature).

    A node is active where its pressure is positive: with contact checked at the nodes
    (the default) these are exactly the active points of the contact iteration.
    """
    scalars = contact.pressure.function_space
    gap = fem.Function(scalars, name=f"gap_{contact.name}")
    active = fem.Function(scalars, name=f"active_{contact.name}")
    n = scalars.dofmap.index_map.size_local
    x = scalars.tabulate_dof_coordinates()[:n]

    friction = getattr(contact, "friction_law", None)  # set at assembly where mu > 0
    slip, traction, state = (
        fem.Function(space, name=f"{what}_{contact.name}")
        for space, what in ((contact.V, "slip"), (contact.V, "traction"), (scalars, "stick"))
    )

    def refresh(t: float) -> None:
        if contact.obstacle is not None:  # a pair side's gap is the pair's, not a field
            s, normal = contact.obstacle.gap_normal(x, t)
            w = contact.w.x.array[: 3 * n].reshape(n, 3)
            gap.x.array[:n] = s - np.einsum("ij,ij->i", w, normal)
        active.x.array[:n] = contact.pressure.x.array[:n] > 0.0
        if friction is not None:  # a pair side's: what that side feels
            for field, values in zip((slip, traction, state), friction.fields(), strict=True):
                field.x.array[: values.size] = values.ravel()

    extra = [] if friction is None else [slip, traction, state]
    gaps = [] if contact.obstacle is None else [gap]
    fields = [contact.w, contact.pressure, *gaps, active, *extra]
    return MeshFields(contact.w.name, fields, refresh)


def part_fields(
    part: Subdomain | Interface | ContactInterface | ContactBoundary, dynamic: bool
) -> MeshFields:
    """The output of one part of a scene (a subdomain, the interface, a contact region)."""
    if isinstance(part, Subdomain):
        return _subdomain_fields(part, dynamic)
    if isinstance(part, Interface):
        return MeshFields(part.v.name, [part.v], lambda t: None)
    return _contact_fields(part)


def output_fields(scene: Scene, rank: int, dynamic: bool) -> list[MeshFields]:
    """The output of every mesh rank ``rank`` owns (the interface is rank 0's).

    Args:
        scene: The scene.
        rank: This rank.
        dynamic: Include velocity and acceleration of the subdomains.
    """
    parts: list = [s for k, s in enumerate(scene.subdomains) if scene.owner(k) == rank]
    if scene.interface is not None and rank == 0:
        parts.append(scene.interface)
    parts += [c for c in scene.contacts if scene.contact_owner(c) == rank]
    return [part_fields(part, dynamic) for part in parts]


class Reactions:
    """Total reaction force of the supports (Dirichlet conditions) of each owned subdomain.

    At the prescribed dofs equilibrium reads ``M a + K x + tie forces = f + R``; the
    reaction R is summed per component. Only the rows of the prescribed dofs are kept, so
    a step costs a product with those rows.

    Args:
        model: This rank's assembled pieces (unconstrained matrices, mass, Dirichlet dofs).
    """

    def __init__(self, model: Model):
        self.model = model
        self.rows: dict[Block, list[tuple[Block, sp.csr_array]]] = {}
        self.mass: dict[Block, sp.csr_array] = {}
        self._summed: dict[Block, tuple[np.ndarray, np.ndarray | None]] = {}
        for block, (dofs, _) in model.dirichlet.items():
            self.rows[block] = [
                (col, sp.csr_array(sp.csr_array(A)[dofs]))
                for col, A in model.system.block_row(block)
            ]
            if block in model.mass:
                self.mass[block] = sp.csr_array(model.mass[block][dofs])

    def _reduced(self, block: Block, basis, q: np.ndarray, a: np.ndarray | None) -> np.ndarray:
        """A reduced block's ``A[D] T q + M[D] T a`` summed per component.

        Its reaction rows summed per component once (3 rows): a step's product with them is
        then 3 x (boundary + m), not one row per support dof.
        """
        if block not in self._summed:
            S = sp.csr_array(
                (np.ones(len(basis.fixed)), (basis.fixed % 3, np.arange(len(basis.fixed)))),
                shape=(3, len(basis.fixed)),
            )
            mass = basis.reaction_mass
            self._summed[block] = (S @ basis.reaction_rows, None if mass is None else S @ mass)
        rows, mass = self._summed[block]
        return rows @ q + (mass @ a if mass is not None and a is not None else 0.0)

    def of(
        self,
        x: Mapping[str, np.ndarray],
        loads: Mapping[str, np.ndarray],
        accelerations: Mapping[str, np.ndarray],
        supports: Mapping[str, np.ndarray],
    ) -> dict[Block, np.ndarray]:
        """Reaction 3-vector per owned subdomain block (zero without supports).

        Args:
            x: Every block's displacement.
            loads: The external load vector of each owned subdomain block.
            accelerations: Acceleration of each owned block (empty for statics).
            supports: Each owned reduced block's load on its prescribed dofs (its ``loads``
                entry is in reduced coordinates, without them).
        """
        out: dict[Block, np.ndarray] = {}
        for block, basis in self.model.reduced.items():  # in reduced coordinates
            out[block] = self._reduced(block, basis, x[block], accelerations.get(block))
            out[block] -= np.bincount(basis.fixed % 3, weights=supports[block], minlength=3)
        for block, rows in self.rows.items():
            if block in self.model.reduced:
                continue
            dofs = self.model.dirichlet[block][0]
            r = -loads[block][dofs] if block in loads else np.zeros(len(dofs))
            for column, A in rows:
                r = r + A @ x[column]
            if block in self.mass and block in accelerations:
                r = r + self.mass[block] @ accelerations[block]
            for tie in self.model.system.stiff_ties:
                if tie.u == block:
                    r = r + tie.sigma * tie.jump(x)[block][dofs]
            out[block] = np.bincount(dofs % 3, weights=r, minlength=3)
        return out


def contact_area(zone: ContactZone, active: np.ndarray) -> float:
    """Area of a contact region's active points (their lumped or quadrature weights)."""
    return float(zone.operator.points.weight[active].sum())


def contact_force(zone: ContactZone, w: np.ndarray, active: np.ndarray) -> np.ndarray:
    """Total force the obstacle exerts on the body (3-vector), as the iteration decided.

    ``ContactOperator.force`` less the points the iteration kept out of contact with a
    penetration within round-off of zero (:data:`dd_contact.iteration.STATE_BAND`): the
    solve put no force on them. Counted, their round-off unbalanced the pin joint's
    quasi-static run where its load crosses zero (4.4e-3 N from hundreds of points within
    5e-18 m of their pins, 2.2e-7 of the load's amplitude; the solve's own force 2e-12 N).
    """
    op = zone.operator
    force = op.force(w)  # with friction's tangential tractions, if any
    if type(op).force is not ContactOperator.force:  # a pair's (its own sum): as it is
        return force
    kept_out = ~active & (op.penetration(w) <= STATE_BAND * zone.length)
    pressure = op.point_pressure(w)[kept_out] * op.points.weight[kept_out]
    return force + (pressure[:, None] * op.normal[kept_out]).sum(axis=0)


def carrying_points(zone: ContactZone, w: np.ndarray, active: np.ndarray) -> tuple[float, bool]:
    """How many nodes' worth of surface carry a region's force, and whether all points do.

    With the points' pressures ``p`` and areas ``a``, the effective contact area
    ``(sum p a)^2 / sum p^2 a`` (the active area when the pressure is uniform, less when a
    few points take most of the force) over the force-weighted lumped area of the nodes
    that carry it: the count of active nodes when they carry alike, 1 when one carries all,
    the same for nodal and quadrature contact points. The flag says every point of the
    region is active (a flat face pressed whole: no contact edge inside the surface).
    """
    op = zone.operator
    p = op.point_pressure(w)
    force = p * op.points.weight
    spread = float(np.dot(force, p))
    if spread <= 0:
        return 0.0, bool(active.all())
    nodal = op.points.N.T @ force
    node_area = float(np.dot(nodal, op.points.lumped)) / float(nodal.sum())
    area = float(force.sum()) ** 2 / spread
    return area / node_area, bool(active.all())


class Results:
    """The results of each solve, agreed by every rank, so reading them never communicates.

    Agreed where the ranks meet anyway: the penalties and initial counts when built, the
    rest in one allgather at the end of each solve (:meth:`agree`).

    Args:
        comm: Communicator of the problem.
        scene: The scene.
        model: This rank's assembled pieces.
        alpha: This rank's contact state changes per owned region.
    """

    def __init__(self, comm, scene: Scene, model: Model, alpha: Mapping[str, int]):
        self.comm, self.scene, self.zones = comm, scene, model.zones
        self.reactions = Reactions(model)
        owned = [k for k in range(len(scene.subdomains)) if scene.owner(k) == comm.rank]
        self.names = {scene.subdomains[k].block: scene.subdomains[k].name for k in owned}
        #: Absolute penalty of every tie and contact, from all ranks.
        self.penalties = gathered(comm, model.system.penalties)
        #: Contact state changes per region, from all ranks.
        self.alpha = gathered(comm, alpha)
        #: The last solve's record (empty before the first).
        self.latest: dict = {}
        #: Per region, the last solve's effective number of points carrying its force and
        #: whether every point was active (:func:`carrying_points`).
        self.carrying: dict[str, tuple[float, bool]] = {}

    def agree(
        self,
        x: Mapping[str, np.ndarray],
        loads: Mapping[str, np.ndarray],
        accelerations: Mapping[str, np.ndarray],
        supports: Mapping[str, np.ndarray],
        active: Mapping[str, np.ndarray],
        alpha: Mapping[str, int],
    ) -> dict:
        """Collective (one allgather): this solve's results, the same on every rank.

        Contact force, active points and area per region, support reaction per subdomain;
        also refreshes :attr:`alpha`.
        """
        local: dict[tuple[str, str], Any] = {}
        for z in self.zones:
            name = z.contact.name
            local[("alpha", name)] = alpha[name]
            local[("force", name)] = contact_force(z, z.gather(x), active[name]).tolist()
            local[("active", name)] = int(active[name].sum())
            local[("contact_area", name)] = contact_area(z, active[name])
            local[("carrying", name)] = carrying_points(z, z.gather(x), active[name])
        for block, reaction in self.reactions.of(x, loads, accelerations, supports).items():
            local[("reaction", self.names[block])] = reaction.tolist()
        agreed = gathered(self.comm, local)
        contacts = [c.name for c in self.scene.regions]
        self.alpha = {n: agreed[("alpha", n)] for n in contacts}
        self.carrying = {n: agreed[("carrying", n)] for n in contacts}
        out = {
            k: {n: agreed[(k, n)] for n in contacts} for k in ("force", "active", "contact_area")
        }
        out["reaction"] = {s.name: agreed[("reaction", s.name)] for s in self.scene.subdomains}
        return out

    def vectors(self, kind: str, names: Sequence[str]) -> dict[str, np.ndarray]:
        """The last solve's ``kind`` (``"force"`` or ``"reaction"``) per name (zero before)."""
        found = self.latest.get(kind, {})
        return {n: np.array(found.get(n, np.zeros(3))) for n in names}


def gather_contact_fields(scene: Scene, root: int = 0) -> None:
    """Collective: copy every contact surface's w and pressure from its owner to ``root``.

    To draw or write them all there; the other ranks keep theirs.
    """
    comm = scene.comm
    if comm.size == 1:
        return
    mine = {
        c.name: (c.w.x.array.copy(), c.pressure.x.array.copy())
        for c in scene.contacts
        if scene.contact_owner(c) == comm.rank
    }
    everything = gather_to_root(comm, mine, root=root)
    if comm.rank == root:
        assert everything is not None  # gathered here
        fields = {name: pair for part in everything for name, pair in part.items()}
        for c in scene.contacts:
            c.w.x.array[:], c.pressure.x.array[:] = fields[c.name]
