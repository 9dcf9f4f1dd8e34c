"""Results back on the one mesh: the parts' fields of a decomposed scene as Functions on it.

After a solve every rank holds every subdomain's displacement and velocity, so the fields
are assembled on each rank without communication, into the user's mesh as it is (serial,
or the rank's cells and ghosts of a distributed mesh). Nodes and cells are matched by
position: a part's node is the one mesh's node at the same point, a part's cell the one
mesh's cell with the same midpoint. A node on a cut belongs to two or more parts, whose
values differ by the tie's penalty gap (about 1/kappa of the displacement): it gets their
mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
from scipy.spatial import cKDTree

from dd_contact.decomposition import DecomposedScene
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


def _midpoints(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """Every cell's midpoint on this rank, ghosts included."""
    return mesh.geometry.x[mesh.geometry.dofmaps[0]].mean(axis=1)


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
        mesh: The mesh to fill (default the one mesh, ``scene.decomposition.mesh``); e.g.
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
    if any(s.V.element.basix_element.degree != 1 for s in scene.subdomains):
        raise InputError("fields_on_mesh: the parts must be of degree 1, as decompose builds them")
    if mesh is None:
        mesh = scene.decomposition.mesh if out is None else out.u.function_space.mesh
    fields = _functions(mesh) if out is None else out
    x = fields.u.function_space.tabulate_dof_coordinates()
    size = float(np.linalg.norm(np.ptp(scene.decomposition.whole.mesh.geometry.x, axis=0)))
    tol = 1e-9 * max(size, 1e-300)
    # Nodes: the mean over the parts that hold each one.
    total_u, total_v, count = np.zeros((len(x), 3)), np.zeros((len(x), 3)), np.zeros(len(x))
    tree = cKDTree(x)
    for sub in scene.subdomains:
        n = sub.V.dofmap.index_map.size_local
        distance, node = tree.query(sub.V.tabulate_dof_coordinates()[:n], distance_upper_bound=tol)
        hit = np.isfinite(distance)
        np.add.at(total_u, node[hit], sub.u.x.array[: 3 * n].reshape(-1, 3)[hit])
        np.add.at(total_v, node[hit], sub.velocity.x.array[: 3 * n].reshape(-1, 3)[hit])
        np.add.at(count, node[hit], 1.0)
    if np.any(count == 0):
        raise InputError("fields_on_mesh: some nodes of the one mesh lie in no part")
    fields.u.x.array[:] = (total_u / count[:, None]).ravel()
    fields.velocity.x.array[:] = (total_v / count[:, None]).ravel()
    # Cells: each belongs to one part.
    midpoints = _midpoints(mesh)
    stress = np.full((len(midpoints), 3, 3), np.nan)
    cells = cKDTree(midpoints)
    for sub in scene.subdomains:
        distance, cell = cells.query(_midpoints(sub.mesh), distance_upper_bound=tol)
        hit = np.isfinite(distance)
        dofs = fem.functionspace(sub.mesh, ("DG", 0, (3, 3))).dofmap.list[:, 0]
        stress[cell[hit]] = cell_stress(sub)[dofs[hit]]
    if np.isnan(stress).any():
        raise InputError("fields_on_mesh: some cells of the one mesh lie in no part")
    dev = stress - np.trace(stress, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3.0
    tensor = fields.stress.x.array.reshape(-1, 3, 3)
    tensor[fields.stress.function_space.dofmap.list[:, 0]] = stress
    scalar = fields.von_mises.function_space.dofmap.list[:, 0]
    fields.von_mises.x.array[scalar] = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
    return fields
