"""The exterior-penalty contact term (eqs. 5, 11, A8, A9) on a contact surface mesh.

A contact surface is a first-order surface mesh with a vector P1 displacement (the contact
interface's w, or a copy of a subdomain's boundary whose dofs are the subdomain's own). The
contact condition ``w . n - s <= 0`` is checked at *contact points*, one of two schemes:

``"nodes"`` (default)
    At the mesh nodes, each carrying its lumped (row-summed) area. The active set is a set of
    nodes, the contact matrix is block diagonal (one 3x3 block ``n n^T`` per active node),
    and a node is either in contact or not. This is the common choice of engineering codes:
    robust, it never lets a node sink through the obstacle between quadrature points, and the
    pressure is a nodal quantity.
``"quadrature"``
    At Gauss points of the surface cells (2x2 on quadrilaterals, 3 on triangles). The contact
    matrix couples the nodes of a cell; the contact edge is resolved more finely than the
    node spacing, but a cell can be partly in contact, and the pressure lives at points.

Both give the same matrices when a whole cell is in contact and the gap is linear on it; the
Hertz benchmark (``benchmarks/hertz_convergence.py``) measures the difference.

With the points' shape values ``N`` (points x nodes) and normals ``n_p``, the operator
``G = [N_pi n_p^T]`` (points x 3 nodes) gives the penetration ``g = G w - s``, and for the
active points ``A``::

    P_C = (1/eps_C) G^T diag(a_A) G,      p_C2 = (1/eps_C) G^T (a_A s)      (A8, A9)

where ``a`` are the points' area weights.

At the start of a run, :func:`check_contact_geometry` refuses an obstacle that overlaps the
body or whose normal points into it. The active-set iteration is in
:mod:`dd_contact.iteration`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import basix
import dolfinx.fem as fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from dd_contact.blocks import Block, ContactRegion, same_csr
from dd_contact.coupling import newell_normal
from dd_contact.errors import InputError
from dd_contact.friction import TANGENTIAL_PENALTY, Friction
from dd_contact.meshes import cyclic_vertices
from dd_contact.obstacles import Obstacle
from dd_contact.scene import CONTACT_POINTS

__all__ = [
    "ContactOperator",
    "ContactPoints",
    "check_contact_geometry",
    "contact_operator",
    "contact_points",
    "largest_turn",
    "mean_cell_size",
    "outward_normals",
]

# Gauss rules: 2x2 on quadrilaterals, 3 points on triangles (exact for the P1 mass).
_QUADRATURE_DEGREE = {"quadrilateral": 3, "triangle": 2}


@dataclass
class ContactPoints:
    """Points where the contact condition is checked.

    Attributes:
        x: Coordinates, shape ``(p, 3)``.
        weight: Area carried by each point, shape ``(p,)``.
        N: Scalar shape values, shape ``(p, num_nodes)`` (identity for the nodal scheme).
        lumped: Lumped area of every node (to turn point forces into nodal pressure).
    """

    x: npt.NDArray[np.float64]
    weight: npt.NDArray[np.float64]
    N: sp.csr_array
    lumped: npt.NDArray[np.float64]


def _gauss_points(S: fem.FunctionSpace) -> tuple[np.ndarray, np.ndarray, sp.csr_array]:
    """Physical Gauss points, weights (with the surface Jacobian) and shape values."""
    mesh = S.mesh
    name = mesh.topology.cell_type.name
    cell = getattr(basix.CellType, name)
    # basix annotates the arrays it returns as ArrayLike
    quadrature = basix.make_quadrature(cell, _QUADRATURE_DEGREE[name])
    X, w_ref = cast(tuple[np.ndarray, np.ndarray], quadrature)
    element = S.element.basix_element
    tab = cast(np.ndarray, element.tabulate(1, X))[..., 0]  # (1 + tdim, q, nodes)
    cmap = mesh.geometry.cmaps[0]
    if cmap.degree != 1:
        raise ValueError("contact surfaces must be first-order meshes")
    nodes = mesh.geometry.x[mesh.geometry.dofmaps[0]]  # (cells, nodes, 3)
    # P1 Lagrange on a first-order mesh: the geometry basis equals the field basis.
    x = np.einsum("qk,ckd->cqd", tab[0], nodes)
    J = np.einsum("tqk,ckd->cqdt", tab[1:], nodes)  # (cells, q, 3, 2)
    JtJ = np.einsum("cqdt,cqds->cqts", J, J)
    detJ = np.sqrt(np.linalg.det(JtJ))
    weight = detJ * w_ref[None, :]
    dofs = S.dofmap.list  # (cells, nodes)
    n_cells, n_q = weight.shape
    rows = np.repeat(np.arange(n_cells * n_q), dofs.shape[1])
    cols = np.repeat(dofs[:, None, :], n_q, axis=1).ravel()
    vals = np.broadcast_to(tab[0][None], (n_cells, n_q, dofs.shape[1])).ravel()
    num_nodes = S.dofmap.index_map.size_local
    N = sp.csr_array((vals, (rows, cols)), shape=(n_cells * n_q, num_nodes))
    return x.reshape(-1, 3), weight.ravel(), N


def contact_points(S: fem.FunctionSpace, scheme: str = "nodes") -> ContactPoints:
    """The contact points of a P1 surface space under ``scheme`` (see module docstring)."""
    if scheme not in CONTACT_POINTS:
        raise ValueError(f"unknown contact scheme {scheme!r}; use one of {CONTACT_POINTS}")
    x_q, w_q, N_q = _gauss_points(S)
    lumped = N_q.T @ w_q  # row sums of the P1 surface mass matrix
    if scheme == "quadrature":
        return ContactPoints(x_q, w_q, N_q, lumped)
    num_nodes = len(lumped)
    x = S.tabulate_dof_coordinates()[:num_nodes]
    return ContactPoints(x, lumped, sp.eye_array(num_nodes, format="csr"), lumped)


class ContactOperator:
    """Contact matrix and right-hand side of one contact surface for a given active set.

    Args:
        points: Where the condition is checked.
        obstacle: The rigid obstacle.
        epsilon: The contact penalty eps_C (traction = penetration / eps_C).
    """

    #: Coulomb friction at the points (:mod:`dd_contact.friction`); ``None``: frictionless
    #: (a class attribute: a pair's operator, which builds its own state, has none).
    friction: Friction | None = None
    #: Whether :meth:`matrix` may reuse its last normal part (False: a benchmark's "before").
    reuse: bool = True
    _active: np.ndarray  # the last matrix's active set (friction: what stuck() is for)
    _nodal = False  # whether N is the identity (a pair's operator: never)

    def __init__(self, points: ContactPoints, obstacle: Obstacle, epsilon: float):
        self.points = points
        self.obstacle = obstacle
        self.epsilon = float(epsilon)
        self.num_points = len(points.weight)
        self.num_dofs = 3 * points.N.shape[1]
        coo = sp.coo_array(points.N)
        # G[p, 3 i + c] = N[p, i] n_p[c]: three entries per shape value.
        self._g_rows = np.repeat(coo.row, 3)
        self._g_cols = (3 * coo.col[:, None] + np.arange(3)).ravel()
        self._g_shape = np.repeat(coo.data, 3)
        #: Nodal points (N the identity): G w is each node's w . n, taken without a sparse
        #: product (a step takes some 90 of them on the pin joint's ten walls).
        N = points.N
        square = N.shape[0] == N.shape[1] == N.nnz
        self._nodal = bool(square and np.array_equal(coo.row, coo.col) and np.all(coo.data == 1))
        self.update(0.0)

    def update(self, t: float) -> None:
        """Evaluate gap and normals at time ``t`` (the obstacle may move)."""
        self.t = t
        if self.obstacle.at_rest and getattr(self, "G", None) is not None:
            return  # the same gap, normals and G at every time (rebuilt: 0.5 ms a step, 10 walls)
        self.gap, self.normal = self.obstacle.gap_normal(self.points.x, t)
        vals = self._g_shape * self.normal[self._g_rows, self._g_cols % 3]
        self.G = sp.csr_array(
            (vals, (self._g_rows, self._g_cols)), shape=(self.num_points, self.num_dofs)
        )
        # what G w needs without G (nodal points, rows in node order), with the G it is of
        self._normals_of = (self.G, np.ascontiguousarray(self.normal)) if self._nodal else None

    def _transposed(self, name: str) -> sp.csc_array:
        """``G.T`` or ``points.N.T``, made once per matrix (each ``.T`` builds a new one)."""
        matrix = self.G if name == "G" else self.points.N
        store: dict[str, tuple] = self.__dict__.setdefault("_transposes", {})
        kept = store.get(name)
        if kept is None or kept[0] is not matrix:
            kept = store[name] = (matrix, matrix.T)
        return kept[1]

    def _times_g(self, w: np.ndarray) -> np.ndarray:
        """``G @ w``; at nodal points summed in G's order (the same bits), without scipy."""
        fast, w = getattr(self, "_normals_of", None), np.asarray(w)
        if fast is None or fast[0] is not self.G or w.ndim != 1:  # a pair's G, say
            return self.G @ w
        n, v = fast[1], w.reshape(-1, 3)
        return n[:, 0] * v[:, 0] + n[:, 1] * v[:, 1] + n[:, 2] * v[:, 2]

    def pattern(self) -> sp.csr_array:
        """Every entry the contact matrix can ever fill (all points active, any normal)."""
        S = sp.csr_array(
            (np.ones(len(self._g_rows)), (self._g_rows, self._g_cols)),
            shape=(self.num_points, self.num_dofs),
        )
        return sp.csr_array(S.T @ S)

    def penetration(self, w: np.ndarray) -> np.ndarray:
        """``w . n - s`` at the points (positive: the body is inside the obstacle)."""
        return self._times_g(w) - self.gap

    def active_set(self, w: np.ndarray) -> np.ndarray:
        """Points with positive penetration."""
        return self.penetration(w) > 0.0

    def matrix(self, active: np.ndarray) -> sp.csr_array:
        """P_C of (A8) for the active points (and friction's terms)."""
        normal = self._normal(active)
        if self.friction is None:
            return normal
        self._active = active
        return sp.csr_array(normal + self.friction.terms(active)[0])

    def _normal(self, active: np.ndarray) -> sp.csr_array:
        """The normal part of :meth:`matrix`, kept while the active set and G stay.

        A sparse product a solve saved on most steps of an impact (``reuse = False``:
        computed every time).
        """
        key, G = (active.tobytes(), self.epsilon), self.G
        kept = getattr(self, "_kept", None)
        if not (self.reuse and kept is not None and kept[0] == key and same_csr(kept[1], G)):
            scale = np.where(active, self.points.weight / self.epsilon, 0.0)
            self._kept = kept = (key, G, sp.csr_array(G.T @ (scale[:, None] * G)))
        return kept[2]

    def _normal_rhs(self, active: np.ndarray) -> np.ndarray:
        """The normal part of :meth:`rhs`, kept while the active set, G and the gap stay."""
        key, G = (active.tobytes(), self.epsilon), self.G
        kept = getattr(self, "_kept_rhs", None)
        if not (kept is not None and kept[0] == key and kept[1] is G and kept[2] is self.gap):
            scaled = np.where(active, self.points.weight * self.gap / self.epsilon, 0.0)
            self._kept_rhs = kept = (key, G, self.gap, self._transposed("G") @ scaled)
        return kept[3].copy()  # the caller's to change

    def stuck(self) -> sp.csr_array:
        """The last :meth:`matrix` with every active point sticking (friction).

        Symmetric; it differs from that matrix only at the slipping points
        (:meth:`Friction.stuck`).
        """
        assert self.friction is not None  # only friction's regions are asked
        return sp.csr_array(self._normal(self._active) + self.friction.stuck(self._active))

    def point_rows(self, free: np.ndarray) -> sp.csr_array | None:
        """Rows F with ``matrix(a)`` on the ``free`` dofs ``F^T diag(a) F`` (frictionless only)."""
        if self.friction is not None:
            return None
        scale = sp.diags_array(np.sqrt(self.points.weight / self.epsilon))
        return sp.csr_array(scale @ self.G @ sp.diags_array(free.astype(float)))

    def rhs(self, active: np.ndarray) -> np.ndarray:
        """p_C2 of (A9) for the active points (and friction's terms)."""
        normal = self._normal_rhs(active)
        return normal if self.friction is None else normal + self.friction.terms(active)[1]

    def region(
        self, name: str, block: Block, dofs: np.ndarray, free: np.ndarray | None = None
    ) -> ContactRegion:
        """What a solver reserves for this contact (friction: unsymmetric, with history).

        Its point rows on the ``free`` dofs (default all) go with it when they stay the same
        from step to step (frictionless, the obstacle's normals fixed): a change of a few
        points is then corrected point by point, not re-factorised.
        """
        plain = self.friction is None
        fixed = plain and self.obstacle.fixed_normals
        free = np.ones(self.num_dofs, bool) if free is None else free
        return ContactRegion(
            name,
            block,
            dofs,
            self.pattern(),
            symmetric=plain,
            history=not plain,
            stuck=None if plain else self.stuck,
            points=self.point_rows(free) if fixed else None,
        )

    def point_pressure(self, w: np.ndarray) -> np.ndarray:
        """Contact pressure ``<w . n - s>+ / eps_C`` at the points (compression positive)."""
        return np.maximum(self.penetration(w), 0.0) / self.epsilon

    def nodal_pressure(self, w: np.ndarray) -> np.ndarray:
        """Pressure at the nodes: nodal contact force over lumped nodal area."""
        force = self.points.weight * self.point_pressure(w)
        if not self._nodal:  # N the identity: its product would give the same values
            force = self._transposed("N") @ force
        return force / np.maximum(self.points.lumped, 1e-300)

    def force(self, w: np.ndarray) -> np.ndarray:
        """Total force the obstacle exerts on the body (3-vector)."""
        p = self.point_pressure(w) * self.points.weight
        force = -(p[:, None] * self.normal).sum(axis=0)
        if self.friction is None:
            return force
        return force + (self.points.weight[:, None] * self.friction.tractions(w)).sum(axis=0)

    def energy(self, w: np.ndarray) -> float:
        """Penalty energy ``(1/2 eps_C) int <w . n - s>+^2``."""
        g = np.maximum(self.penetration(w), 0.0)
        normal = 0.5 * float(np.dot(self.points.weight, g * g)) / self.epsilon
        return normal if self.friction is None else normal + self.friction.energy(w)


def contact_operator(contact, epsilon: float) -> ContactOperator:
    """The operator of a contact region against its obstacle (penalty eps_C), with friction."""
    operator = ContactOperator(contact_points(contact.V, contact.points), contact.obstacle, epsilon)
    if contact.friction > 0.0:
        operator.friction = Friction(operator, contact.friction, TANGENTIAL_PENALTY * epsilon)
        contact.friction_law = operator.friction  # what its output fields read
    return operator


def patch_average(mass: sp.sparray) -> sp.csr_array:
    """``R p = (M p) / (M 1)``: each node's value averaged over its cells, weighted by ``M``.

    The pressure recovery of a contact surface that does not copy the wall it is tied to
    (``docs/contact.md``, "Modelling contact"). Smooth fields keep their values to
    second order in the cell size; a node-to-node (checkerboard) oscillation is damped to a
    third of its amplitude or less. A node outside ``M`` (zero row) keeps its own value.
    """
    weight = np.asarray(mass.sum(axis=1)).ravel()
    inside = weight > 0
    scale = np.where(inside, 1.0 / np.where(inside, weight, 1.0), 0.0)
    outside = sp.diags_array((~inside).astype(float))
    return sp.csr_array(sp.diags_array(scale) @ mass + outside)


def largest_turn(x: np.ndarray, cells: np.ndarray) -> float:
    """The largest angle [rad] between the planes of two cells that share an edge.

    ``x`` are node coordinates, ``cells`` first-order triangles or tensor-ordered quads
    (node indices into ``x``). On a curved surface it is the curvature times the cell size
    across the curvature, so the ratio of two meshes' turns on the same wall is the ratio of
    their cell sizes along the curvature (along the axis of a cylinder cells do not turn).
    """
    poly = cyclic_vertices(cells)
    normal = newell_normal(x[poly])
    corners = poly.shape[1]
    edges = np.sort(np.stack([poly, np.roll(poly, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(len(poly)), corners)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    shared = np.all(edges[1:] == edges[:-1], axis=1)
    a, b = normal[owner[:-1][shared]], normal[owner[1:][shared]]
    cosine = np.clip(np.abs(np.sum(a * b, axis=1)), 0.0, 1.0)  # orientation need not agree
    return float(np.arccos(cosine).max(initial=0.0))


# -- the start of a run: refuse geometry the contact term cannot handle -------------------
def mean_cell_size(surface: dolfinx.mesh.Mesh) -> float:
    """Mean bounding-box diagonal of the cells of a surface mesh: its length scale h."""
    cells = surface.geometry.x[surface.geometry.dofmaps[0]]
    return float(np.mean(np.linalg.norm(cells.max(axis=1) - cells.min(axis=1), axis=1)))


def outward_normals(surface: dolfinx.mesh.Mesh, volume: dolfinx.mesh.Mesh) -> np.ndarray:
    """Unit normal of every cell of a contact surface, oriented out of the body ``volume``.

    Each cell's normal is checked by probing the body's mesh (a bounding-box tree) on both
    sides of the cell's centre, at growing depths (5 % ... 50 % of the cell's size): the
    normal is outward where the point behind lies in the body and the one in front does not.
    The depths matter on a curved wall meshed independently: a coarse cell's centre can lie
    off the body by more than 5 % of its size (a chord of a hole).
    """
    poly = surface.geometry.x[cyclic_vertices(surface.geometry.dofmaps[0])]
    normal = newell_normal(poly)
    centre = poly.mean(axis=1)
    size = np.linalg.norm(poly.max(axis=1) - poly.min(axis=1), axis=1)
    tree = dolfinx.geometry.bb_tree(volume, volume.topology.dim)

    def inside(points: np.ndarray) -> np.ndarray:
        candidates = dolfinx.geometry.compute_collisions_points(tree, points)
        cells = dolfinx.geometry.compute_colliding_cells(volume, candidates, points)
        return np.array([len(cells.links(i)) > 0 for i in range(len(points))])

    sign = np.zeros(len(poly))
    for depth in (0.05, 0.15, 0.3, 0.5):
        todo = sign == 0
        if not todo.any():
            break
        step = (depth * size[todo])[:, None] * normal[todo]
        behind, front = inside(centre[todo] - step), inside(centre[todo] + step)
        sign[np.flatnonzero(todo)] = np.where(
            behind & ~front, 1.0, np.where(front & ~behind, -1.0, 0.0)
        )
    sign[sign == 0] = 1.0  # undecided (not next to the body): as given
    return normal * sign[:, None]


def check_contact_geometry(
    operator: ContactOperator,
    surface: dolfinx.mesh.Mesh,
    volume: dolfinx.mesh.Mesh,
    name: str,
    tolerance: float | None = None,
    t: float = 0.0,
) -> None:
    """Refuse an obstacle that overlaps the body or whose normal points into it.

    Args:
        operator: The contact region's operator (evaluated at ``t`` here).
        surface: The contact surface mesh.
        volume: The mesh of the body (subdomain) the surface bounds.
        name: The contact region's name, for messages.
        tolerance: Largest overlap accepted (default: 1e-3 of the mean surface cell size).
        t: Time at which the obstacle is checked.

    Raises:
        InputError: The obstacle penetrates the body deeper than ``tolerance``, or its
            normal points into the body.
    """
    op = operator
    op.update(t)
    cells = surface.geometry.x[surface.geometry.dofmaps[0]]
    tol = 1e-3 * mean_cell_size(surface) if tolerance is None else tolerance
    worst = int(np.argmin(op.gap))
    if op.gap[worst] < -tol:
        raise InputError(
            f"contact {name!r}: the obstacle penetrates the body at t = {t} by "
            f"{-op.gap[worst]:.4g} at {np.round(op.points.x[worst], 6)} (tolerance "
            f"{tol:.3g}); move the obstacle or the body so they at most touch at the start"
        )
    outward = outward_normals(surface, volume)
    centres = cells.mean(axis=1)
    _, n = op.obstacle.gap_normal(centres, t)
    cosine = np.einsum("cd,cd->c", n, outward)
    bad = int(np.argmin(cosine))
    if cosine[bad] < -0.1:
        raise InputError(
            f"contact {name!r}: the obstacle's normal points into the body (at "
            f"{np.round(centres[bad], 6)} it makes "
            f"{np.degrees(np.arccos(np.clip(cosine[bad], -1.0, 1.0))):.0f}"
            " degrees with the outward normal of the surface); for a Plane give the "
            "normal pointing out of the wall towards the body, and check that the body "
            "lies outside a Sphere or around a Cylinder"
        )
