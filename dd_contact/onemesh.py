"""Results back on the one mesh: the parts' fields of a decomposed scene as Functions on it.

After a solve every rank holds every subdomain's displacement and velocity, so the fields
are assembled on each rank without communication, into the user's mesh as it is (serial,
or the rank's cells and ghosts of a distributed mesh), or into the whole mesh on this rank.
Nodes and cells are matched through the decomposition's maps (a part's nodes and cells as
those of the whole mesh; the whole mesh's as the distributed mesh's by their input index),
never by position, so bodies that touch at coincident nodes are told apart. A node on a cut
belongs to two or more parts, whose values differ by the tie's penalty gap (about 1/kappa of
the displacement): it gets their mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np

from dd_contact.decomposition import DecomposedScene, Decomposition
from dd_contact.errors import InputError
from dd_contact.post import cell_stress

__all__ = ["OneMeshFields", "fields_on_mesh"]


@dataclass
class OneMeshFields:
    """A decomposed scene's fields on its one mesh.

    Attributes:
        u: Displacement (vector Lagrange, degree 1).
        velocity: Velocity (vector Lagrange, degree 1; zero in a static problem).
        stress: Cauchy stress at each cell's midpoint (DG0, 3 x 3).
        von_mises: Von Mises stress of each cell (DG0).
    """

    u: fem.Function
    velocity: fem.Function
    stress: fem.Function
    von_mises: fem.Function

    def as_list(self) -> list[fem.Function]:
        """The four Functions, for a writer (``dolfinx.io.VTXWriter`` takes them by space)."""
        return [self.u, self.velocity, self.stress, self.von_mises]


def _functions(mesh: dolfinx.mesh.Mesh) -> OneMeshFields:
    V = fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    T = fem.functionspace(mesh, ("DG", 0, (3, 3)))
    W = fem.functionspace(mesh, ("DG", 0))
    return OneMeshFields(
        fem.Function(V, name="u"),
        fem.Function(V, name="velocity"),
        fem.Function(T, name="stress"),
        fem.Function(W, name="von_mises"),
    )


def _node_of_dof(V: fem.FunctionSpace) -> np.ndarray:
    """The geometry node of each (blocked) dof of a degree-1 space on a first-order mesh."""
    mesh = V.mesh
    nodes = np.full(V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts, -1)
    nodes[V.dofmap.list] = mesh.geometry.dofmaps[0]
    return nodes


def _to_whole(d: Decomposition, mesh: dolfinx.mesh.Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Each geometry node and each cell of ``mesh`` as a node and cell of the whole mesh."""
    whole = d.whole.mesh
    if mesh is whole:
        return np.arange(len(whole.geometry.x)), np.arange(len(whole.geometry.dofmaps[0]))
    if mesh is not d.mesh:
        raise InputError(
            "fields_on_mesh: mesh must be the one mesh (Decomposition.mesh) or the whole mesh "
            "on this rank (Decomposition.whole.mesh)"
        )
    ids = whole.geometry.input_global_indices
    node = np.full(int(ids.max()) + 1, -1)
    node[ids] = np.arange(len(ids))
    original = whole.topology.original_cell_index
    cell = np.full(int(original.max()) + 1, -1)
    cell[original] = np.arange(len(original))
    return node[mesh.geometry.input_global_indices], cell[mesh.topology.original_cell_index]


def fields_on_mesh(
    scene: DecomposedScene,
    out: OneMeshFields | None = None,
    mesh: dolfinx.mesh.Mesh | None = None,
) -> OneMeshFields:
    """The parts' u, velocity, stress and von Mises stress as Functions on the one mesh.

    Rank-local: call it on every rank after a solve (or a time step) to fill the rank's part
    of a distributed mesh; pass ``out`` to fill the same Functions again (a series).

    Args:
        scene: A scene made by :func:`dd_contact.decompose`.
        out: Functions from an earlier call, to be overwritten.
        mesh: The mesh to fill (default the one mesh, ``scene.decomposition.mesh``), or
            ``scene.decomposition.whole.mesh``, the whole one mesh on this rank, to draw a
            distributed mesh's fields on one rank.

    Returns:
        The fields on the one mesh.
    """
    if not isinstance(scene, DecomposedScene):
        raise InputError(
            f"fields_on_mesh: needs a scene made by dd_contact.decompose, got "
            f"{type(scene).__name__}; a hand-built scene has no one mesh"
        )
    d = scene.decomposition
    if mesh is None:
        mesh = d.mesh if out is None else out.u.function_space.mesh
    fields = _functions(mesh) if out is None else out
    whole_node, whole_cell = _to_whole(d, mesh)
    # Whole node -> this mesh's dof; whole cell -> this mesh's cell.
    node_of_dof = _node_of_dof(fields.u.function_space)
    dof_of = np.full(len(d.whole.mesh.geometry.x), -1)
    dof_of[whole_node[node_of_dof]] = np.arange(len(node_of_dof))
    cell_of = np.full(len(d.whole.mesh.geometry.dofmaps[0]), -1)
    cell_of[whole_cell] = np.arange(len(whole_cell))
    _nodal(scene, fields, dof_of)
    _cellwise(scene, fields, cell_of, len(whole_cell))
    return fields


def _nodal(scene: DecomposedScene, fields: OneMeshFields, dof_of: np.ndarray) -> None:
    """Displacement and velocity: each dof the mean over the parts that hold its node."""
    size = len(fields.u.x.array) // 3
    total_u, total_v, count = np.zeros((size, 3)), np.zeros((size, 3)), np.zeros(size)
    for sub in scene.subdomains:
        mine = dof_of[scene.decomposition.nodes[sub.name][_node_of_dof(sub.V)]]
        hit = mine >= 0  # nodes of other ranks' cells of a distributed mesh are not here
        np.add.at(total_u, mine[hit], sub.u.x.array.reshape(-1, 3)[hit])
        np.add.at(total_v, mine[hit], sub.velocity.x.array.reshape(-1, 3)[hit])
        np.add.at(count, mine[hit], 1.0)
    if np.any(count == 0):
        raise InputError("fields_on_mesh: some nodes of the mesh lie in no part")
    fields.u.x.array[:] = (total_u / count[:, None]).ravel()
    fields.velocity.x.array[:] = (total_v / count[:, None]).ravel()


def _cellwise(scene: DecomposedScene, fields: OneMeshFields, cell_of: np.ndarray, cells: int):
    """Stress and von Mises stress: each of the ``cells`` cells' from the part that holds it."""
    stress = np.full((cells, 3, 3), np.nan)
    for sub in scene.subdomains:
        mine = cell_of[scene.decomposition.cells[sub.name]]
        dofs = fem.functionspace(sub.mesh, ("DG", 0, (3, 3))).dofmap.list[:, 0]
        hit = mine >= 0
        stress[mine[hit]] = cell_stress(sub)[dofs[hit]]
    if np.isnan(stress).any():
        raise InputError("fields_on_mesh: some cells of the mesh lie in no part")
    dev = stress - np.trace(stress, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3.0
    tensor = fields.stress.x.array.reshape(-1, 3, 3)
    tensor[fields.stress.function_space.dofmap.list[:, 0]] = stress
    scalar = fields.von_mises.function_space.dofmap.list[:, 0]
    fields.von_mises.x.array[scalar] = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
