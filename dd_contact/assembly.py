"""From a scene to the block system (14): the blocks each rank owns, as scipy matrices.

Block rows are named ``u:<subdomain>`` and ``v:<interface>`` (later ``w:<contact>``). A
rank holds only the pieces it owns; contributions to another rank's rows (the interface
mass P_DI4 and the lifted right-hand side) travel when the system is handed to PETSc.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact import coupling, forms
from dd_contact.scene import InputError, Scene

__all__ = ["BlockSystem", "assemble_static"]


@dataclass
class BlockSystem:
    """The local pieces of a symmetric block system ``A x = b``.

    Attributes:
        sizes: Size of every block, in block order (same on all ranks).
        owners: Rank that owns every block's rows.
        matrices: ``(row_block, col_block) -> matrix`` contributions; an off-diagonal pair
            is stored once and stands for its transpose too. Contributions with the same key
            from different ranks are added.
        rhs: ``block -> vector`` contributions, added like the matrices.
        penalties: ``(subdomain, surface) -> eps`` of every tie this rank assembled.
    """

    sizes: dict[str, int]
    owners: dict[str, int]
    matrices: dict[tuple[str, str], sp.csr_array] = field(default_factory=dict)
    rhs: dict[str, np.ndarray] = field(default_factory=dict)
    penalties: dict[tuple[str, str], float] = field(default_factory=dict)

    def add(self, row: str, col: str, matrix: sp.sparray) -> None:
        """Add a matrix contribution to block (row, col)."""
        matrix = sp.csr_array(matrix)
        key = (row, col)
        self.matrices[key] = self.matrices[key] + matrix if key in self.matrices else matrix

    def add_rhs(self, row: str, vector: np.ndarray) -> None:
        """Add a right-hand-side contribution to block ``row``."""
        self.rhs[row] = self.rhs[row] + vector if row in self.rhs else np.array(vector)

    def constrain(self, block: str, dofs: np.ndarray, values: np.ndarray) -> None:
        """Eliminate prescribed dofs of ``block`` (symmetric: rows, columns and lifting).

        The owner of ``block`` must hold every contribution that touches it.
        """
        if dofs.size == 0:
            return
        g = np.zeros(self.sizes[block])
        g[dofs] = values
        keep = np.ones(self.sizes[block])
        keep[dofs] = 0.0
        mask = sp.diags_array(keep)
        for (row, col), A in list(self.matrices.items()):
            if row == block and col == block:
                self.add_rhs(block, -(A @ g))
                A = mask @ A @ mask + sp.diags_array(1.0 - keep)
            elif row == block:
                self.add_rhs(col, -(A.T @ g))
                A = mask @ A
            elif col == block:
                self.add_rhs(row, -(A @ g))
                A = A @ mask
            else:
                continue
            self.matrices[(row, col)] = sp.csr_array(A)
        rhs = self.rhs.get(block, np.zeros(self.sizes[block]))
        self.rhs[block] = np.where(keep > 0, rhs, g)


def _tie(system: BlockSystem, scene: Scene, k: int) -> np.ndarray:
    """Penalty terms of (9)-(10) between subdomain k and the interface; returns coverage."""
    sub, surface = scene.subdomains[k], scene.interface
    ops = coupling.tie_operators(sub.V, surface.V, tolerance=surface.tolerance)
    if ops.area == 0.0:
        raise InputError(
            f"interface {surface.name!r} does not touch subdomain {sub.name!r}: no cell of it "
            "lies on that subdomain's boundary within the tolerance; move the surface mesh onto "
            "the boundary, raise Interface(tolerance=...), or drop the subdomain from the "
            "interface's list"
        )
    eps = surface.penalty.epsilon_for(ops.height, sub.material.E)
    u, v = f"u:{sub.name}", f"v:{surface.name}"
    system.add(u, u, coupling.blocked(ops.P1) / eps)
    system.add(u, v, -coupling.blocked(ops.P2) / eps)
    system.add(v, v, coupling.blocked(ops.P4) / eps)
    system.penalties[(sub.name, surface.name)] = eps
    return ops.covered_area / ops.cell_area


def _check_interface_covered(scene: Scene, coverage: np.ndarray) -> None:
    """Every interface cell must lie on some subdomain's boundary (else it ties nothing)."""
    total = np.empty_like(coverage)
    scene.comm.Allreduce(coverage, total, op=MPI.MAX)
    coverage = total
    loose = np.flatnonzero(coverage < 0.999)
    if loose.size:
        surface = scene.interface
        nodes = surface.mesh.geometry.x[surface.mesh.geometry.dofmaps[0][loose[0]]]
        raise InputError(
            f"interface {surface.name!r}: {loose.size} of its {coverage.size} cells do not lie "
            f"on a subdomain boundary (cell {loose[0]} near {np.round(nodes.mean(axis=0), 6)} is "
            f"{100 * (1 - coverage[loose[0]]):.1f}% uncovered); the surface mesh must lie on the "
            "boundary it ties to: move it, trim it to the shared face, or raise its tolerance"
        )


def assemble_static(scene: Scene) -> BlockSystem:
    """This rank's pieces of the static block system: K_D + P_DI1, -P_DI2, K_DI; loads."""
    rank = scene.comm.rank
    sizes = {f"u:{s.name}": s.num_dofs for s in scene.subdomains}
    owners = {f"u:{s.name}": scene.owner(k) for k, s in enumerate(scene.subdomains)}
    if scene.interface is not None:
        sizes[f"v:{scene.interface.name}"] = scene.interface.num_dofs
        owners[f"v:{scene.interface.name}"] = 0
    system = BlockSystem(sizes, owners)
    tied = scene.interface.subdomains if scene.interface is not None else []
    coverage = np.zeros(scene.interface.mesh.topology.index_map(2).size_local if tied else 0)
    for k, sub in enumerate(scene.subdomains):
        if scene.owner(k) != rank:
            continue
        u = f"u:{sub.name}"
        system.add(u, u, forms.assemble_stiffness(sub))
        system.add_rhs(u, forms.assemble_load(sub))
        if any(sub is t for t in tied):
            coverage = np.maximum(coverage, _tie(system, scene, k))
        system.constrain(u, *sub.dirichlet)
    if tied:
        _check_interface_covered(scene, coverage)
    return system
