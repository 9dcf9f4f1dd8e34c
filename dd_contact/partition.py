"""One mesh cut into parts: the whole mesh on one rank, its cell partitions, facets by nodes.

What :func:`dd_contact.decompose` builds a scene from. A mesh distributed over the ranks is
first copied whole onto every rank (:func:`whole_mesh`), so that every rank holds every part,
as every rank holds every subdomain of a scene. Cells are assigned to parts by cell tags,
by recursive coordinate bisection or a graph partitioner (SCOTCH, KaHIP) into a number of
parts, by cut planes, or by the cut
that puts given cells into a small part (:func:`contact_cut`, the ``"auto"`` cut). Facets
of two meshes that share nodes are matched by their nodes (:func:`facet_keys`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mpi4py import MPI

import basix.ufl
import dolfinx.graph
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import ufl

from dd_contact import arguments
from dd_contact.errors import InputError
from dd_contact.parallel import allgathered

__all__ = [
    "Whole",
    "bisection",
    "bodies",
    "by_planes",
    "by_tags",
    "cell_midpoints",
    "cells_behind",
    "contact_cut",
    "dual_graph",
    "exterior_keys",
    "facet_keys",
    "fewest_facets",
    "graph_partition",
    "interface_facets",
    "whole_mesh",
]


@dataclass
class Whole:
    """The user's mesh, whole on this rank.

    Attributes:
        mesh: The user's mesh if it lives on one rank; else a copy of it on ``MPI.COMM_SELF``
            (the same on every rank).
        source: The user's mesh.
    """

    mesh: dolfinx.mesh.Mesh
    source: dolfinx.mesh.Mesh

    @property
    def copied(self) -> bool:
        """Whether :attr:`mesh` is a copy (the user's mesh is distributed)."""
        return self.mesh is not self.source

    def tags(self, tags: dolfinx.mesh.MeshTags, argument: str) -> dolfinx.mesh.MeshTags:
        """MeshTags of the user's mesh as MeshTags of :attr:`mesh` (collective if copied)."""
        if not isinstance(tags, dolfinx.mesh.MeshTags):
            raise InputError(f"{argument}: needs a dolfinx MeshTags, got {type(tags).__name__}")
        if tags.topology is not self.source.topology._cpp_object:
            raise InputError(f"{argument}: the MeshTags belong to another mesh; tag this mesh")
        if not self.copied:
            return tags
        source, mesh = self.source, self.mesh
        nodes = dolfinx.mesh.entities_to_geometry(source, tags.dim, tags.indices)
        ids = source.geometry.input_global_indices[nodes]
        everyone = allgathered(source.comm, (np.sort(ids, axis=1), tags.values))
        keys = np.concatenate([k for k, _ in everyone])
        values = np.concatenate([v for _, v in everyone])
        mesh.topology.create_connectivity(tags.dim, mesh.topology.dim)
        count = mesh.topology.index_map(tags.dim).size_local
        here = facet_keys(mesh, np.arange(count, dtype=np.int32), tags.dim, global_ids=True)
        lookup = {tuple(k): i for i, k in enumerate(here)}
        entities = np.array([lookup[tuple(k)] for k in keys], dtype=np.int32)
        entities, first = np.unique(entities, return_index=True)
        return dolfinx.mesh.meshtags(mesh, tags.dim, entities, values[first].astype(np.int32))


def whole_mesh(mesh: dolfinx.mesh.Mesh) -> Whole:
    """The user's mesh whole on every rank (collective if it is distributed).

    A distributed mesh (as :func:`dolfinx.io.gmsh.read_from_msh` gives) is gathered: its
    cells in their original order and its nodes by their input index, then built again on
    ``MPI.COMM_SELF``.
    """
    arguments.instance(mesh, dolfinx.mesh.Mesh, "decompose: mesh")
    if mesh.topology.dim != 3 or mesh.geometry.dim != 3:
        raise InputError(
            f"decompose: needs a 3-D volume mesh, got topological dimension "
            f"{mesh.topology.dim} in {mesh.geometry.dim}-D"
        )
    arguments.finite(mesh.geometry.x, "decompose: mesh coordinates")
    if mesh.comm.size == 1:
        return Whole(mesh, mesh)
    cells_local = mesh.topology.index_map(3).size_local
    ids = mesh.geometry.input_global_indices
    dofmap = mesh.geometry.dofmaps[0][:cells_local]
    mine = (
        mesh.topology.original_cell_index[:cells_local],
        ids[dofmap],
        ids,
        mesh.geometry.x,
    )
    parts = allgathered(mesh.comm, mine)
    order = np.concatenate([p[0] for p in parts])
    cells = np.concatenate([p[1] for p in parts])[np.argsort(order)]
    node_ids = np.concatenate([p[2] for p in parts])
    x = np.zeros((int(node_ids.max()) + 1, 3))
    x[node_ids] = np.concatenate([p[3] for p in parts])
    cmap = mesh.geometry.cmaps[0]
    element = basix.ufl.element("Lagrange", mesh.topology.cell_name(), cmap.degree, shape=(3,))
    copy = dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells.astype(np.int64), ufl.Mesh(element), x)
    return Whole(copy, mesh)


def facet_keys(
    mesh: dolfinx.mesh.Mesh,
    entities: npt.NDArray[np.int32],
    dim: int = 2,
    node_map: npt.NDArray[np.int32] | None = None,
    global_ids: bool = False,
) -> np.ndarray:
    """Each entity's geometry nodes, sorted: a key that names it in any mesh sharing the nodes.

    Args:
        mesh: The mesh.
        entities: Its entities (facets by default).
        dim: Their dimension.
        node_map: This mesh's nodes as nodes of another mesh (a submesh's parent nodes).
        global_ids: Name the nodes by their input index instead.
    """
    nodes = np.asarray(dolfinx.mesh.entities_to_geometry(mesh, dim, entities), dtype=np.int64)
    if node_map is not None:
        nodes = np.asarray(node_map[nodes], dtype=np.int64)
    if global_ids:
        nodes = mesh.geometry.input_global_indices[nodes]
    return np.sort(nodes, axis=1)


def cell_midpoints(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """The mean of each cell's nodes, shape ``(num_cells, 3)`` (this rank's cells)."""
    cells = mesh.topology.index_map(mesh.topology.dim).size_local
    return mesh.geometry.x[mesh.geometry.dofmaps[0][:cells]].mean(axis=1)


def interface_facets(mesh: dolfinx.mesh.Mesh, part: np.ndarray) -> np.ndarray:
    """The interior facets whose two cells lie in different parts (``part`` per cell)."""
    mesh.topology.create_connectivity(2, 3)
    f2c = mesh.topology.connectivity(2, 3)
    offsets = f2c.offsets
    two = np.flatnonzero(np.diff(offsets) == 2).astype(np.int32)
    a, b = f2c.array[offsets[two]], f2c.array[offsets[two] + 1]
    return two[part[a] != part[b]]


def dual_graph(mesh: dolfinx.mesh.Mesh) -> scipy.sparse.csr_array:
    """The cells' dual graph: an edge (both ways) between two cells that share a facet."""
    mesh.topology.create_connectivity(2, 3)
    f2c = mesh.topology.connectivity(2, 3)
    offsets = f2c.offsets
    two = np.flatnonzero(np.diff(offsets) == 2)
    a, b = f2c.array[offsets[two]], f2c.array[offsets[two] + 1]
    num = mesh.topology.index_map(3).size_local
    edges = (np.ones(2 * len(a)), (np.r_[a, b], np.r_[b, a]))
    return scipy.sparse.coo_array(edges, shape=(num, num)).tocsr()


def bodies(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """A part per body: the connected components of cells that share a facet."""
    _, part = scipy.sparse.csgraph.connected_components(dual_graph(mesh), directed=False)
    return part.astype(np.int64)


def graph_partition(mesh: dolfinx.mesh.Mesh, n: int, method: str = "scotch") -> np.ndarray:
    """``n`` parts of the cells' dual graph by dolfinx's graph partitioner (SCOTCH or KaHIP).

    Fewer facets between parts than :func:`bisection` on unstructured meshes, and parts
    that hang together (``benchmarks/decompose_partitioner.py``); cell counts within a few
    per cent of equal.
    """
    make = getattr(dolfinx.graph, f"partitioner_{method}", None)
    if make is None:
        raise InputError(
            f"decompose: this dolfinx was built without the {method} graph partitioner; "
            "use partitioner='bisection'"
        )
    _check_count(len(cell_midpoints(mesh)), n)
    graph = dual_graph(mesh)
    adjacency = dolfinx.graph.adjacencylist(
        graph.indices.astype(np.int64), graph.indptr.astype(np.int32)
    )
    dest = make()(MPI.COMM_SELF, n, adjacency._cpp_object, False)
    part = np.asarray(dest.array, dtype=np.int64)
    if len(np.unique(part)) < n:  # possible on a tiny graph
        raise InputError(
            f"decompose: the {method} partitioner left a part with no cells ({n} parts of "
            f"{len(part)} cells); ask for fewer parts or use partitioner='bisection'"
        )
    return part


def fewest_facets(mesh: dolfinx.mesh.Mesh, n: int) -> tuple[np.ndarray, str]:
    """Bisection or SCOTCH, whichever leaves fewer facets between parts (bisection on a tie).

    Both take milliseconds to a tenth of a second at 50k cells, far below a factorisation;
    bisection wins on structured boxes (it cuts along layers), SCOTCH on unstructured meshes.
    """
    part = bisection(cell_midpoints(mesh), n)
    if n == 1 or getattr(dolfinx.graph, "partitioner_scotch", None) is None:
        return part, "bisection"
    try:
        graph = graph_partition(mesh, n, "scotch")
    except InputError:
        return part, "bisection"
    if len(interface_facets(mesh, graph)) < len(interface_facets(mesh, part)):
        return graph, "scotch"
    return part, "bisection"


def by_tags(tags: dolfinx.mesh.MeshTags, num_cells: int) -> tuple[np.ndarray, list[int]]:
    """Parts from cell tags: one part per tag value (sorted); every cell must be tagged."""
    if tags.dim != 3:
        raise InputError(
            f"decompose: parts given as MeshTags must tag cells (dimension 3), got dimension "
            f"{tags.dim}; facet tags name regions (fix, add_traction, ContactCandidate)"
        )
    part = np.full(num_cells, -1, dtype=np.int64)
    values = sorted({int(v) for v in tags.values})
    index = {v: k for k, v in enumerate(values)}
    part[tags.indices] = [index[int(v)] for v in tags.values]
    missing = int(np.count_nonzero(part < 0))
    if missing:
        raise InputError(
            f"decompose: {missing} of {num_cells} cells carry no cell tag; tag every cell "
            "(e.g. one gmsh physical volume per part) or give a number of parts"
        )
    return part, values


def _check_count(num: int, n: int) -> None:
    if n > num:
        raise InputError(
            f"decompose: {n} parts of a mesh of {num} cells would leave parts with no cells; "
            f"ask for at most {num} parts"
        )


def bisection(midpoints: np.ndarray, n: int) -> np.ndarray:
    """``n`` parts of about equal cell counts by recursive coordinate bisection.

    Each cut is across the longest extent of its cells' midpoints, at a coordinate that no
    midpoint crosses, so a structured mesh is cut along a layer of its facets.
    """
    num = len(midpoints)
    _check_count(num, n)
    part = np.zeros(num, dtype=np.int64)

    def split(cells: np.ndarray, n: int, first: int) -> None:
        if n == 1:
            part[cells] = first
            return
        x = midpoints[cells]
        axis = int(np.argmax(np.ptp(x, axis=0)))
        coord = x[:, axis]
        order = np.argsort(coord, kind="stable")
        n_left = n // 2
        k = round(len(cells) * n_left / n)
        # Cut between midpoints: below the k-th smallest, or up to it, whichever is nearer k.
        c = coord[order[k - 1]]
        below, upto = coord < c - 1e-12 * (1 + abs(c)), coord <= c + 1e-12 * (1 + abs(c))
        counts = [int(below.sum()), int(upto.sum())]
        left = below if abs(counts[0] - k) < abs(counts[1] - k) else upto
        if left.sum() < n_left or (~left).sum() < n - n_left:  # a plane of equal midpoints
            left = np.zeros(len(cells), dtype=bool)
            left[order[:k]] = True
        split(cells[left], n_left, first)
        split(cells[~left], n - n_left, first + n_left)

    split(np.arange(num), n, 0)
    return part


def by_planes(midpoints: np.ndarray, planes: Sequence) -> np.ndarray:
    """Parts cut by planes ``(point, normal)``: cells on the same side of every plane.

    Parts are numbered by their side pattern; a plane that leaves every cell on one side is
    an error.
    """
    if isinstance(planes, (str, bytes)) or len(planes) == 0:
        raise InputError("decompose: cut planes must be a list of (point, normal) pairs")
    code = np.zeros(len(midpoints), dtype=np.int64)
    for i, plane in enumerate(planes):
        if not isinstance(plane, Sequence) or len(plane) != 2:
            raise InputError(
                f"decompose: cut plane {i} must be a (point, normal) pair, got {plane!r}"
            )
        point = arguments.vector(plane[0], f"decompose: cut plane {i} point")
        normal = arguments.vector(plane[1], f"decompose: cut plane {i} normal")
        if not np.linalg.norm(normal) > 0:
            raise InputError(f"decompose: cut plane {i} has a zero normal")
        side = (midpoints - point) @ normal > 0
        if side.all() or not side.any():
            raise InputError(
                f"decompose: cut plane {i} (point {point}, normal {normal}) leaves every cell "
                "on one side: it would make a part with no cells; move it into the mesh or "
                "drop it"
            )
        code += side.astype(np.int64) << i
    _, part = np.unique(code, return_inverse=True)
    return part.astype(np.int64)


def contact_cut(
    midpoints: np.ndarray, sizes: np.ndarray, contact_cells: np.ndarray, layers: float = 1.0
) -> tuple[np.ndarray, str] | None:
    """Two parts: a small one holding ``contact_cells``, cut across a coordinate axis.

    For each axis and each end the cut is placed ``layers + 1/2`` mean cell sizes beyond the
    contact cells' midpoints (between two layers of a structured mesh); the smallest part
    wins. ``None`` if that part would hold more than half the cells (a cut then saves
    nothing: the whole mesh is one part).

    Args:
        midpoints: Cell midpoints, ``(num_cells, 3)``.
        sizes: Mean cell extent along x, y and z.
        contact_cells: The cells that must lie in the small part.
        layers: Cell layers between the contact cells and the cut.

    Returns:
        The part of each cell (0: the contact part, 1: the rest) and a description.
    """
    best: tuple[int, np.ndarray, str] | None = None
    for axis in range(3):
        for sign in (1.0, -1.0):
            coord = sign * midpoints[:, axis]
            cut = np.max(coord[contact_cells]) + (layers + 0.5) * sizes[axis]
            small = coord < cut
            if small.all():
                continue
            if best is None or small.sum() < best[0]:
                where = f"{'xyz'[axis]} {'<' if sign > 0 else '>'} {sign * cut:.6g}"
                best = (int(small.sum()), small, where)
    if best is None or best[0] > len(midpoints) // 2:
        return None
    count, small, where = best
    return np.where(small, 0, 1).astype(np.int64), (
        f"contact part {where}: {count} of {len(midpoints)} cells"
    )


def exterior_keys(mesh: dolfinx.mesh.Mesh, nodes: np.ndarray) -> dict[tuple, int]:
    """A part's exterior facets by their keys: their nodes as nodes of the whole mesh."""
    mesh.topology.create_connectivity(2, 3)
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    keys = facet_keys(mesh, exterior, node_map=nodes)
    return {tuple(k): int(f) for k, f in zip(keys, exterior, strict=True)}


def cells_behind(mesh: dolfinx.mesh.Mesh, facet_sets: list[np.ndarray]) -> np.ndarray:
    """The cells behind boundary facets."""
    facets = np.concatenate([*facet_sets, np.zeros(0, dtype=np.int32)]).astype(np.int32)
    mesh.topology.create_connectivity(2, 3)
    f2c = mesh.topology.connectivity(2, 3)
    return np.unique(f2c.array[f2c.offsets[facets]]).astype(np.int64)
