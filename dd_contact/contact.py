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
"""

from __future__ import annotations

import hashlib
import warnings
from dataclasses import dataclass

import basix
import dolfinx.fem as fem
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from dd_contact.errors import ContactCycleWarning, ContactIterationError
from dd_contact.obstacles import Obstacle

__all__ = [
    "SCHEMES",
    "ContactIteration",
    "ContactOperator",
    "ContactPoints",
    "ContactSettings",
    "contact_points",
    "digest",
]

#: Where the contact condition is checked.
SCHEMES = ("nodes", "quadrature")

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
    X, w_ref = basix.make_quadrature(cell, _QUADRATURE_DEGREE[name])
    element = S.element.basix_element
    tab = element.tabulate(1, X)[..., 0]  # (1 + tdim, q, nodes)
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
    if scheme not in SCHEMES:
        raise ValueError(f"unknown contact scheme {scheme!r}; use one of {SCHEMES}")
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
        self.update(0.0)

    def update(self, t: float) -> None:
        """Evaluate gap and normals at time ``t`` (the obstacle may move)."""
        self.t = t
        self.gap, self.normal = self.obstacle.gap_normal(self.points.x, t)
        vals = self._g_shape * self.normal[self._g_rows, self._g_cols % 3]
        self.G = sp.csr_array(
            (vals, (self._g_rows, self._g_cols)), shape=(self.num_points, self.num_dofs)
        )

    def pattern(self) -> sp.csr_array:
        """Every entry the contact matrix can ever fill (all points active, any normal)."""
        S = sp.csr_array(
            (np.ones(len(self._g_rows)), (self._g_rows, self._g_cols)),
            shape=(self.num_points, self.num_dofs),
        )
        return sp.csr_array(S.T @ S)

    def penetration(self, w: np.ndarray) -> np.ndarray:
        """``w . n - s`` at the points (positive: the body is inside the obstacle)."""
        return self.G @ w - self.gap

    def active_set(self, w: np.ndarray) -> np.ndarray:
        """Points with positive penetration."""
        return self.penetration(w) > 0.0

    def matrix(self, active: np.ndarray) -> sp.csr_array:
        """P_C of (A8) for the active points."""
        scale = np.where(active, self.points.weight / self.epsilon, 0.0)
        return sp.csr_array(self.G.T @ (scale[:, None] * self.G))

    def rhs(self, active: np.ndarray) -> np.ndarray:
        """p_C2 of (A9) for the active points."""
        return self.G.T @ np.where(active, self.points.weight * self.gap / self.epsilon, 0.0)

    def point_pressure(self, w: np.ndarray) -> np.ndarray:
        """Contact pressure ``<w . n - s>+ / eps_C`` at the points (compression positive)."""
        return np.maximum(self.penetration(w), 0.0) / self.epsilon

    def nodal_pressure(self, w: np.ndarray) -> np.ndarray:
        """Pressure at the nodes: nodal contact force over lumped nodal area."""
        force = self.points.N.T @ (self.points.weight * self.point_pressure(w))
        return force / np.maximum(self.points.lumped, 1e-300)

    def force(self, w: np.ndarray) -> np.ndarray:
        """Total force the obstacle exerts on the body (3-vector)."""
        p = self.point_pressure(w) * self.points.weight
        return -(p[:, None] * self.normal).sum(axis=0)

    def energy(self, w: np.ndarray) -> float:
        """Penalty energy ``(1/2 eps_C) int <w . n - s>+^2``."""
        g = np.maximum(self.penetration(w), 0.0)
        return 0.5 * float(np.dot(self.points.weight, g * g)) / self.epsilon


def digest(active: np.ndarray) -> str:
    """A short fingerprint of an active set (to detect cycling)."""
    return hashlib.blake2b(np.packbits(active).tobytes(), digest_size=12).hexdigest()


@dataclass
class ContactSettings:
    """How the contact iteration runs.

    Attributes:
        max_iterations: Largest number of solves in one step (or one static solve).
        on_cycle: What to do when an active set repeats within a step: ``"union"`` (default:
            make every point of the cycle active, solve once more and go on, with a
            :class:`ContactCycleWarning` that says where; a few points may then carry a small
            tension) or ``"raise"`` (stop with a :class:`ContactIterationError` that says
            where).
        penetration_tolerance: Largest initial overlap of body and obstacle accepted at the
            start (default: 1e-3 of the mean contact-surface cell size).
    """

    max_iterations: int = 50
    on_cycle: str = "union"
    penetration_tolerance: float | None = None

    def __post_init__(self):
        if self.max_iterations < 1:
            raise ValueError("ContactSettings: max_iterations must be >= 1")
        if self.on_cycle not in ("raise", "union"):
            raise ValueError("ContactSettings: on_cycle must be 'raise' or 'union'")


class ContactIteration:
    """Active-set iteration: solve, update the active sets, repeat until none changes.

    Works with any solver offering ``set_contact(name, matrix)``, ``solve(rhs)`` (which must
    return at least the blocks of this rank's zones) and ``finish()`` (every block of the last
    solution: a decomposition solver back-substitutes the rest only once the contact state has
    settled), and with the zones of :class:`dd_contact.assembly.Model`. Every iteration in
    which some active set changed is one *contact state change* (gamma); a change on zone k
    also counts in alpha[k].

    Args:
        comm: Communicator (the zones are spread over ranks).
        zones: This rank's contact zones.
        settings: Iteration settings.
    """

    def __init__(self, comm, zones, settings: ContactSettings):
        self.comm, self.zones, self.settings = comm, zones, settings
        self.active: dict[str, np.ndarray] = {}
        self.gamma = 0
        self.alpha = {z.contact.name: 0 for z in zones}
        self.cycles_resolved = 0

    def start(self, t: float) -> None:
        """Initial active sets: the points already touching the obstacle at ``t``."""
        for z in self.zones:
            z.operator.update(t)
            self.active[z.contact.name] = z.operator.gap <= 0.0

    def solve(self, solver, rhs: dict[str, np.ndarray], t: float, where: str):
        """Solve at time ``t`` with the contact iteration; returns the solution blocks.

        Args:
            solver: The block solver.
            rhs: Right-hand side without contact terms (this rank's contributions).
            t: Time (obstacles may move).
            where: Text for messages (e.g. "step 12 (t = 0.0012)").
        """
        for z in self.zones:
            z.operator.update(t)
        seen = {self._global_digest(): 0}
        sets = [dict(self.active)]
        changes_this_solve = 0
        for iteration in range(1, self.settings.max_iterations + 1):
            x = self._solve_once(solver, rhs)
            new = {z.contact.name: z.operator.active_set(x[z.block][z.dofs]) for z in self.zones}
            changed = [n for n in new if not np.array_equal(new[n], self.active[n])]
            if not self.comm.allreduce(len(changed)):
                return solver.finish(), iteration, changes_this_solve
            self._count_change(changed)
            changes_this_solve += 1
            previous = self.active
            self.active = new
            key = self._global_digest()
            if key in seen:
                message = self._cycle_message(previous, new, seen[key], iteration, where)
                if self.settings.on_cycle == "raise":
                    raise ContactIterationError(
                        message + ". Remedies: a smaller time step or load increment, a softer "
                        "contact penalty (contact_kappa), or ContactSettings(on_cycle='union')"
                    )
                warnings.warn(
                    message + "; resolved by making every point of the cycle active",
                    ContactCycleWarning,
                    stacklevel=2,
                )
                before = dict(self.active)
                for j in range(seen[key], len(sets)):
                    for name in self.active:
                        self.active[name] = self.active[name] | sets[j][name]
                self.cycles_resolved += 1
                # The union is one more contact state (counted like any other change).
                grown = [n for n in self.active if not np.array_equal(before[n], self.active[n])]
                if self.comm.allreduce(len(grown)):
                    self._count_change(grown)
                    changes_this_solve += 1
                self._solve_once(solver, rhs)
                return solver.finish(), iteration + 1, changes_this_solve
            seen[key] = iteration
            sets.append(dict(self.active))
        raise ContactIterationError(
            f"contact iteration did not settle in {self.settings.max_iterations} iterations at "
            f"{where}; raise ContactSettings(max_iterations=...), or take a smaller time step or "
            "load increment"
        )

    def _count_change(self, zones: list[str]) -> None:
        """One contact state change of the model (gamma), on each of ``zones`` (alpha)."""
        self.gamma += 1
        for name in zones:
            self.alpha[name] += 1

    def _solve_once(self, solver, rhs):
        rhs = {name: vector.copy() for name, vector in rhs.items()}
        for z in self.zones:
            matrix, vector = z.contribution(self.active[z.contact.name])
            solver.set_contact(z.contact.name, matrix)
            if z.block not in rhs:
                rhs[z.block] = np.zeros(solver.system.sizes[z.block])
            np.add.at(rhs[z.block], z.dofs, vector)
        return solver.solve(rhs)

    def _global_digest(self) -> tuple:
        local = tuple(digest(self.active[z.contact.name]) for z in self.zones)
        return tuple(self.comm.allgather(local))

    def _cycle_message(self, previous, new, first, iteration, where) -> str:
        lines = []
        for z in self.zones:
            flips = np.flatnonzero(previous[z.contact.name] != new[z.contact.name])
            if flips.size:
                x = np.round(z.operator.points.x[flips[0]], 6)
                lines.append(
                    f"contact {z.contact.name!r}: {flips.size} point(s) flip in/out of contact, "
                    f"e.g. at {x}"
                )
        lines = [line for part in self.comm.allgather(lines) for line in part]
        return (
            f"contact iteration cycles at {where}: iteration {iteration} returns to the active "
            f"set of iteration {first}. " + "; ".join(lines)
        )
