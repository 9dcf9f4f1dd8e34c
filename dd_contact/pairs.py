"""Contact between two deformable surfaces: the gap of a contact pair and its penalty term.

A :class:`~dd_contact.scene.ContactPair` presses contact interface ``a`` (displacement w_a)
on contact interface ``b`` (w_b) of another body. Small deformation, as for obstacles: for a
point x of a, pi(x) is its closest point on b, n the unit normal of b at pi(x) pointing into
b (a's outward direction) and s = (pi(x) - x) . n the initial gap. The penetration is linear
in the pair's displacement ``z = [w_a; w_b]`` (surface dofs of a, then of b)::

    g(x) = (w_a(x) - w_b(pi(x))) . n - s   (g > 0: the surfaces overlap)

Where it is integrated (extensions.md section 1): over the *intersection* of a's cells with
b's cells projected on them, with the Gauss rules the ties use (:mod:`dd_contact.coupling`:
the same clipping, the same distortion-driven degrees), so that a uniform pressure crosses a
flat non-matching contact exactly (the contact patch test). The contact points are

``"nodes"`` (default)
    The nodes of a, each with its weighted gap ``g_i = (1/a_i) int N_i g`` over the
    intersection (``a_i = int N_i``), as mortar methods do: one point per node of a, a node
    in contact or not, like an obstacle's nodes.
``"quadrature"``
    The Gauss points of the intersection themselves.

With ``unbiased=True`` the term is taken both ways (a onto b and b onto a), each with half
the penalty: no master/slave choice. The matrix ``P = (1/eps) G^T diag(weight_A) G`` and
right-hand side are :class:`~dd_contact.contact.ContactOperator`'s, with this G.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import dolfinx.fem as fem
import numpy as np
import scipy.sparse as sp

from dd_contact import coupling
from dd_contact.contact import ContactOperator, ContactPoints, mean_cell_size, outward_normals
from dd_contact.errors import InputError
from dd_contact.friction import SLIP, TANGENTIAL_PENALTY, Friction
from dd_contact.scene import ContactPair

__all__ = [
    "PairFriction",
    "PairOperator",
    "PairQuadrature",
    "SideFriction",
    "check_pair_geometry",
    "pair_operator",
]

#: Cosine between the two sides' outward normals above which cells do not face each other
#: (facing cells have opposite normals: a cosine near -1).
FACING_COSINE = -0.7


@dataclass
class PairQuadrature:
    """Gauss points of the intersection of side a with side b projected on it.

    Attributes:
        x: Points on a, shape ``(q, 3)``.
        weight: Their weights (area), shape ``(q,)``.
        Na: Shape values of a's nodes at the points, ``(q, nodes_a)``.
        Nb: Shape values of b's nodes at the projections pi(x), ``(q, nodes_b)``.
        normal: Unit normal of b at pi(x), pointing into b, ``(q, 3)``.
        gap: Initial gap ``(pi(x) - x) . normal``, ``(q,)``.
    """

    x: np.ndarray
    weight: np.ndarray
    Na: sp.csr_array
    Nb: sp.csr_array
    normal: np.ndarray
    gap: np.ndarray


def _shape_matrix(phi: np.ndarray, dofs: np.ndarray, nodes: int) -> sp.csr_array:
    """``N[q, node]`` from basis values ``(q, k)`` and each point's cell dofs ``(q, k)``."""
    rows = np.repeat(np.arange(len(phi)), phi.shape[1])
    return sp.csr_array((phi.ravel(), (rows, dofs.ravel())), shape=(len(phi), nodes))


def pair_quadrature(
    Sa: fem.FunctionSpace,
    volume_a,
    Sb: fem.FunctionSpace,
    volume_b,
    tolerance: float,
) -> PairQuadrature:
    """The Gauss points of a's cells intersected with b's cells that face them.

    Args:
        Sa: The P1 vector space of side a (its scalar basis is used).
        volume_a: The mesh of a's body (to orient the normals outwards).
        Sb: The P1 vector space of side b.
        volume_b: The mesh of b's body.
        tolerance: Largest distance between a cell of a and the plane of a cell of b that
            still counts as facing it.
    """
    surf_a, surf_b = Sa.mesh, Sb.mesh
    a_nodes, b_nodes = surf_a.geometry.dofmaps[0], surf_b.geometry.dofmaps[0]
    side_a = coupling._polygons(surf_a.geometry.x, a_nodes)
    side_b = coupling._polygons(surf_b.geometry.x, b_nodes)
    out_a, out_b = outward_normals(surf_a, volume_a), outward_normals(surf_b, volume_b)
    si, fj = coupling._facing_pairs(side_a, side_b, np.full(len(a_nodes), float(tolerance)))
    facing = np.einsum("nd,nd->n", out_a[si], out_b[fj]) < FACING_COSINE
    si, fj = si[facing], fj[facing]
    e1, e2 = coupling._in_plane_basis(side_a.vertices, side_a.normal)
    _, _, (fans, fan_a, fan_b) = coupling._intersections(side_a, e1, e2, side_b.vertices, si, fj)
    if not fans:
        return PairQuadrature(
            np.zeros((0, 3)),
            np.zeros(0),
            sp.csr_array((0, Sa.dofmap.index_map.size_local)),
            sp.csr_array((0, Sb.dofmap.index_map.size_local)),
            np.zeros((0, 3)),
            np.zeros(0),
        )
    rules = coupling._Rules(
        surf_a, a_nodes, side_a.centre, e1, e2, surf_b, b_nodes, side_b.centre, side_b.normal
    )
    tri, tri_a, tri_b, degree = rules.pick(
        np.concatenate(fans), np.concatenate(fan_a), np.concatenate(fan_b)
    )
    x, w, q_a, q_b = coupling._gauss_points(tri, tri_a, tri_b, degree, side_a.centre, e1, e2)
    phi_a, dofs_a = coupling._basis_at(Sa, q_a, x)
    phi_b, dofs_b = coupling._basis_at(Sb, q_b, x)  # pulled back: the closest point of b
    nodes_a, nodes_b = Sa.dofmap.index_map.size_local, Sb.dofmap.index_map.size_local
    Nb = _shape_matrix(phi_b, dofs_b, nodes_b)
    projection = Nb @ Sb.tabulate_dof_coordinates()[:nodes_b]
    normal = -out_b[q_b]
    gap = np.einsum("qd,qd->q", projection - x, normal)
    return PairQuadrature(x, w, _shape_matrix(phi_a, dofs_a, nodes_a), Nb, normal, gap)


def _point_operator(q: PairQuadrature) -> sp.csr_array:
    """``G_q`` of the Gauss points: the penetration ``G_q z - s`` at each point."""
    N = sp.hstack([q.Na, -q.Nb], format="coo")
    rows = np.repeat(N.row, 3)
    cols = (3 * N.col[:, None] + np.arange(3)).ravel()
    values = np.repeat(N.data, 3) * q.normal[rows, cols % 3]
    return sp.csr_array((values, (rows, cols)), shape=(N.shape[0], 3 * N.shape[1]))


def _relative(N: sp.sparray) -> sp.csr_array:
    """Scalar point values ``N`` (points x nodes) as 3-vectors: rows 3 p + c, dofs 3 k + c."""
    return sp.csr_array(sp.kron(N, sp.eye_array(3), format="csr"))


def _points(q: PairQuadrature, Sa: fem.FunctionSpace, scheme: str):
    """The contact points of one way under ``scheme``.

    Returns ``(points, G, gap, normal, to_gauss, relative)``: ``to_gauss`` interpolates a
    value of the points to the Gauss points, ``relative`` gives each point's displacement
    relative to b's (3 rows a point; friction's slip).
    """
    G = _point_operator(q)
    jump = sp.hstack([q.Na, -q.Nb], format="csr")
    if scheme == "quadrature":
        points = ContactPoints(q.x, q.weight, q.Na, q.Na.T @ q.weight)
        eye = sp.eye_array(len(q.weight), format="csr")
        return points, G, q.gap, q.normal, eye, _relative(jump)
    lumped = q.Na.T @ q.weight  # a_i = int N_i over the intersection
    nodes = np.flatnonzero(lumped > 1e-12 * lumped.max(initial=0.0))
    # D = diag(1/a_i) N_i^T diag(w): the weighted average over each node's support
    D = sp.diags_array(1.0 / lumped[nodes]) @ sp.csr_array(q.Na.T)[nodes] @ sp.diags_array(q.weight)
    normal = D @ q.normal
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    x = Sa.tabulate_dof_coordinates()[nodes]
    pick = sp.csr_array(
        (np.ones(len(nodes)), (np.arange(len(nodes)), nodes)), shape=(len(nodes), len(lumped))
    )
    points = ContactPoints(x, lumped[nodes], pick, lumped)
    to_gauss = sp.csr_array(q.Na)[:, nodes]
    return points, sp.csr_array(D @ G), D @ q.gap, normal, to_gauss, _relative(D @ jump)


class PairOperator(ContactOperator):
    """The contact matrices of a pair: :class:`ContactOperator` with the pair's own G.

    Its geometry is fixed (small deformation): :meth:`update` changes nothing. The pair's
    dofs are ``[w_a; w_b]``, ``split`` of them a's.

    Args:
        ways: Per way (a onto b; and b onto a if unbiased): the Gauss points, the contact
            points, G (columns in the pair's order), gap, normal, ``to_gauss`` and the
            relative displacement (columns in the pair's order).
        epsilon: The contact penalty eps_C.
        split: Number of a's dofs.
    """

    def __init__(self, ways: list, epsilon: float, split: int):
        share = 1.0 / len(ways)  # unbiased: half the penalty each way
        self.epsilon, self.split, self.t = float(epsilon), split, 0.0
        self.ways = [(q, to_gauss) for q, _, _, _, _, to_gauss, _ in ways]
        self.points = ContactPoints(
            np.concatenate([p.x for _, p, *_ in ways]),
            share * np.concatenate([p.weight for _, p, *_ in ways]),
            sp.csr_array(sp.block_diag([p.N for _, p, *_ in ways])),
            np.concatenate([p.lumped for _, p, *_ in ways]),
        )
        self.G = sp.csr_array(sp.vstack([G for _, _, G, *_ in ways]))
        self.gap = np.concatenate([gap for *_, gap, _, _, _ in ways])
        self.normal = np.concatenate([n for *_, n, _, _ in ways])
        #: Each point's displacement relative to the other side's (3 rows a point)
        self.relative = sp.csr_array(sp.vstack([r for *_, r in ways]))
        self.num_points, self.num_dofs = self.G.shape

    def update(self, t: float) -> None:
        """Nothing moves: the pair's geometry is the undeformed one."""
        self.t = t

    def pattern(self) -> sp.csr_array:
        """Every entry the contact matrix can fill (all points active; friction's too)."""
        S = sp.csr_array(self.G, copy=True)
        if self.friction is not None:  # its blocks couple every component of a point's nodes
            rows = sp.kron(sp.eye_array(self.num_points), np.ones((1, 3)))
            S = sp.csr_array(rows @ abs(self.relative))
        S.data[:] = 1.0
        return sp.csr_array(S.T @ S)

    def force(self, w: np.ndarray) -> np.ndarray:
        """Total force b exerts on a (3-vector): the nodal contact forces on a, summed."""
        p = self.point_pressure(w) * self.points.weight
        nodal = -(self.G.T @ p)
        if self.friction is not None:  # the tangential tractions on the points' sides
            t = self.points.weight[:, None] * self.friction.tractions(w)
            nodal = nodal + self.relative.T @ t.ravel()
        return nodal[: self.split].reshape(-1, 3).sum(axis=0)

    def side_pressures(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nodal contact pressure on a and on b (compression positive)."""
        a, b = self.side_values(self.point_pressure(w)[:, None])
        return a[:, 0], b[:, 0]

    def side_values(self, values: np.ndarray, opposite: float = 1.0) -> list[np.ndarray]:
        """Point values ``(points, k)`` at each side's nodes: a's, then b's.

        Interpolated to the Gauss points and averaged over each node's support (both ways
        together when unbiased); on the side a way projects onto, times ``opposite`` (-1
        for a traction or a slip: what one side feels, the other feels reversed).
        """
        force: list = [0.0, 0.0]
        area: list = [0.0, 0.0]
        start = 0
        for i, (q, to_gauss) in enumerate(self.ways):
            v = to_gauss @ values[start : start + to_gauss.shape[1]]
            start += to_gauss.shape[1]
            first, second = (0, 1) if i == 0 else (1, 0)
            for side, N, sign in ((first, q.Na, 1.0), (second, q.Nb, opposite)):
                force[side] = force[side] + N.T @ (sign * q.weight[:, None] * v)
                area[side] = area[side] + N.T @ q.weight
        return [f / np.maximum(s, 1e-300)[:, None] for f, s in zip(force, area, strict=True)]


class PairFriction(Friction):
    """Coulomb friction between the two sides of a pair: the slip is relative.

    Each point's slip is its displacement relative to the other side's at its projection
    (``PairOperator.relative``), so the tangential terms couple both w blocks; the penalty
    weights are the points', as the normal term's. Nodal points taken one way only
    (``arguments.pair_friction``). Nothing moves the other side rigidly: no obstacle work.
    """

    def __init__(self, operator: PairOperator, mu: float, epsilon: float):
        super().__init__(operator, mu, epsilon)
        self._E, self._nodal = operator.relative, False

    def _moved(self) -> np.ndarray:
        return np.zeros(3)

    def _made(self, active: np.ndarray) -> tuple[sp.csr_array, np.ndarray]:
        """:meth:`Friction._made`, a slipping point pressed by the pair's own penetration.

        The base presses a slipping point with ``n . (E z)``; a pair's penetration is
        ``G z`` (each Gauss point's normal weighted over the point's support), which the
        pressure and the law read: the difference is put back.
        """
        matrix, rhs = super()._made(active)
        op = self.operator
        slip = self._law(active) == SLIP
        if not slip.any():
            return matrix, rhs
        k = np.where(slip, op.points.weight * self.mu / op.epsilon, 0.0)
        p = len(k)
        along = sp.csr_array(
            ((k[:, None] * self.direction).ravel(), (np.arange(3 * p), np.repeat(np.arange(p), 3))),
            shape=(3 * p, p),
        )
        normal = sp.csr_array(
            (op.normal.ravel(), (np.repeat(np.arange(p), 3), np.arange(3 * p))), shape=(p, 3 * p)
        )
        pressed = sp.csr_array(normal @ self._E) - op.G
        return sp.csr_array(matrix + self._E.T @ along @ pressed), rhs


class SideFriction:
    """One side's view of a pair's friction: its output fields (slip, traction, stick/slip).

    The traction is the one on that side, the slip that side's relative to the other.
    """

    def __init__(self, operator: PairOperator, side: int):
        self.operator, self.side = operator, side

    def fields(self) -> list[np.ndarray]:
        """The side's nodal slip, tangential traction and stick/slip map."""
        f = self.operator.friction
        assert f is not None
        state = f.state.astype(float)[:, None]
        values = [self.operator.side_values(v, -1.0) for v in (f.slip, f.traction)]
        return [
            values[0][self.side],
            values[1][self.side],
            self.operator.side_values(state)[self.side],
        ]


def _swap(G: sp.csr_array, first: int) -> sp.csr_array:
    """Columns ``[b; a]`` of a G taken b onto a (``first``: b's dofs), in the order ``[a; b]``."""
    G = sp.csc_array(G)
    return sp.csr_array(sp.hstack([G[:, first:], G[:, :first]]))


def pair_operator(pair: ContactPair, epsilon: float) -> PairOperator:
    """The pair's penalty term (both ways, half the penalty each, if unbiased).

    Raises:
        InputError: The two surfaces do not face each other anywhere within the tolerance.
    """
    a, b = pair.sides
    tol = mean_cell_size(a.mesh) if pair.tolerance is None else pair.tolerance
    ways = []
    for first, second in [(a, b)] + ([(b, a)] if pair.unbiased else []):
        q = pair_quadrature(first.V, first.subdomain.mesh, second.V, second.subdomain.mesh, tol)
        if not len(q.weight):
            raise InputError(
                f"ContactPair {pair.name!r}: the surfaces {first.name!r} and {second.name!r} do "
                f"not face each other: no cell of {first.name!r} has a cell of {second.name!r} "
                f"within {tol:.3g} in front of it with opposite outward normals; pair surfaces "
                "that face each other across the contact, or raise the pair's tolerance"
            )
        points, G, gap, normal, to_gauss, relative = _points(q, first.V, pair.points)
        if first is b:
            G, relative = _swap(G, b.num_dofs), _swap(relative, b.num_dofs)
        ways.append((q, points, G, gap, normal, to_gauss, relative))
    operator = PairOperator(ways, epsilon, a.num_dofs)
    if pair.friction > 0.0:
        operator.friction = PairFriction(operator, pair.friction, TANGENTIAL_PENALTY * epsilon)
        for i, side in enumerate(pair.sides):  # what their output fields read
            cast(Any, side).friction_law = SideFriction(operator, i)
    return operator


def check_pair_geometry(operator: PairOperator, name: str, tolerance: float) -> None:
    """Refuse a pair whose surfaces overlap at the start by more than ``tolerance``."""
    worst = int(np.argmin(operator.gap))
    if operator.gap[worst] < -tolerance:
        raise InputError(
            f"ContactPair {name!r}: the two surfaces overlap by {-operator.gap[worst]:.4g} at "
            f"{np.round(operator.points.x[worst], 6)} at the start (tolerance {tolerance:.3g}); "
            "move the bodies so that they at most touch at the start"
        )
