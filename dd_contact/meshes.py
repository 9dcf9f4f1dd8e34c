"""Meshes for scenes: box subdomains and independent surface meshes.

Every subdomain belongs to one MPI rank (see :class:`dd_contact.scene.Scene`), so the helpers
here default to ``MPI.COMM_SELF``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from mpi4py import MPI

import basix.ufl
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

__all__ = ["box", "surface_from_boundary", "surface_mesh"]

_CELL_TYPES = {
    "hexahedron": dolfinx.mesh.CellType.hexahedron,
    "tetrahedron": dolfinx.mesh.CellType.tetrahedron,
    "quadrilateral": dolfinx.mesh.CellType.quadrilateral,
    "triangle": dolfinx.mesh.CellType.triangle,
}


def _cell_type(name: str | dolfinx.mesh.CellType) -> dolfinx.mesh.CellType:
    if isinstance(name, dolfinx.mesh.CellType):
        return name
    try:
        return _CELL_TYPES[name]
    except KeyError:
        raise ValueError(f"unknown cell type {name!r}; use one of {sorted(_CELL_TYPES)}") from None


def box(
    comm: MPI.Comm,
    lower: Sequence[float],
    upper: Sequence[float],
    n: Sequence[int],
    cell_type: str | dolfinx.mesh.CellType = "hexahedron",
) -> dolfinx.mesh.Mesh:
    """A structured box mesh ``[lower, upper]`` with ``n`` cells per direction.

    Args:
        comm: Communicator (``MPI.COMM_SELF`` for a subdomain).
        lower: Lower corner.
        upper: Upper corner.
        n: Number of cells in x, y, z.
        cell_type: ``"hexahedron"`` or ``"tetrahedron"``.
    """
    ct = _cell_type(cell_type)
    return dolfinx.mesh.create_box(
        comm, [np.asarray(lower, float), np.asarray(upper, float)], list(n), ct
    )


def surface_mesh(
    comm: MPI.Comm,
    points: npt.ArrayLike,
    cells: npt.ArrayLike,
    cell_type: str | dolfinx.mesh.CellType,
) -> dolfinx.mesh.Mesh:
    """A first-order surface mesh (triangles or quadrilaterals) embedded in 3-D.

    Args:
        comm: Communicator.
        points: Node coordinates, shape ``(num_nodes, 3)``.
        cells: Node indices per cell, in dolfinx (basix) ordering: quadrilateral vertices in
            tensor-product order ``(0,0), (1,0), (0,1), (1,1)``.
        cell_type: ``"triangle"`` or ``"quadrilateral"``.
    """
    ct = _cell_type(cell_type)
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"surface mesh points must have shape (n, 3), got {points.shape}")
    element = basix.ufl.element("Lagrange", ct.name, 1, shape=(3,))
    return dolfinx.mesh.create_mesh(
        comm, np.asarray(cells, dtype=np.int64), ufl.Mesh(element), points
    )


def cyclic_vertices(nodes: np.ndarray) -> np.ndarray:
    """Reorder first-order cell vertices into a cyclic polygon (quads are tensor-ordered)."""
    return nodes[:, [0, 1, 3, 2]] if nodes.shape[1] == 4 else nodes[:, :3]


def _rectangle_grid(
    origin: np.ndarray, e1: np.ndarray, e2: np.ndarray, n1: int, n2: int, cell_type: str
) -> tuple[np.ndarray, np.ndarray]:
    """Points and cells of an ``n1 x n2`` grid on the parallelogram origin + [0,1]e1 + [0,1]e2."""
    s, t = np.meshgrid(np.linspace(0, 1, n1 + 1), np.linspace(0, 1, n2 + 1), indexing="ij")
    points = origin + s.reshape(-1, 1) * e1 + t.reshape(-1, 1) * e2
    node = np.arange((n1 + 1) * (n2 + 1)).reshape(n1 + 1, n2 + 1)
    a, b = node[:-1, :-1].ravel(), node[1:, :-1].ravel()
    c, d = node[:-1, 1:].ravel(), node[1:, 1:].ravel()
    if cell_type == "quadrilateral":
        cells = np.stack([a, b, c, d], axis=1)
    else:
        cells = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    return points, cells


def surface_from_boundary(
    volume: dolfinx.mesh.Mesh,
    locator: Callable[[np.ndarray], np.ndarray],
    resolution: tuple[int, int] | None = None,
    cell_type: str = "quadrilateral",
    comm: MPI.Comm | None = None,
) -> dolfinx.mesh.Mesh:
    """A surface mesh covering a region of a volume mesh's boundary.

    With ``resolution=None`` the surface mesh is the boundary facets themselves (a conforming
    copy). With ``resolution=(n1, n2)`` the region must be a planar rectangle; it is remeshed
    with ``n1 x n2`` cells of ``cell_type``, independently of the volume mesh.

    Args:
        volume: The volume mesh.
        locator: ``locator(x) -> bool array`` selecting boundary facets (all vertices of a
            facet must satisfy it), like :func:`dolfinx.mesh.locate_entities_boundary`.
        resolution: Cells along the rectangle's two edges, or ``None``.
        cell_type: ``"quadrilateral"`` or ``"triangle"`` (used with ``resolution``).
        comm: Communicator of the new mesh (default ``volume.comm``).
    """
    comm = volume.comm if comm is None else comm
    tdim = volume.topology.dim
    volume.topology.create_connectivity(tdim - 1, tdim)
    facets = dolfinx.mesh.locate_entities_boundary(volume, tdim - 1, locator)
    if facets.size == 0:
        raise ValueError(
            "surface_from_boundary: the locator selects no boundary facet of the volume mesh; "
            "check the locator against the mesh's bounding box"
        )
    if resolution is None:
        nodes = dolfinx.mesh.entities_to_geometry(volume, tdim - 1, facets)
        used, cells = np.unique(nodes, return_inverse=True)
        points = volume.geometry.x[used]
        facet_type = volume.topology.entity_types[tdim - 1][0].name
        return surface_mesh(comm, points, cells.reshape(nodes.shape), facet_type)

    facet_nodes = dolfinx.mesh.entities_to_geometry(volume, tdim - 1, facets)
    x = volume.geometry.x[np.unique(facet_nodes)]
    centre = x.mean(axis=0)
    _, sv, axes = np.linalg.svd(x - centre)
    if sv[2] > 1e-8 * max(sv[0], 1.0):
        raise ValueError(
            "surface_from_boundary: the selected boundary region is not planar, so it cannot be "
            "remeshed at a given resolution; pass resolution=None to copy its facets"
        )
    # Align the rectangle with a facet edge (principal axes are arbitrary for a square).
    normal = axes[2]
    edge = volume.geometry.x[facet_nodes[0, 1]] - volume.geometry.x[facet_nodes[0, 0]]
    e1 = edge - (edge @ normal) * normal
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    p1, p2 = (x - centre) @ e1, (x - centre) @ e2
    # Remeshing fills the bounding rectangle: the region must be that rectangle.
    polygons = volume.geometry.x[cyclic_vertices(facet_nodes)]
    area = (
        0.5 * np.abs(np.cross(polygons, np.roll(polygons, -1, axis=1)).sum(axis=1) @ normal).sum()
    )
    rectangle = np.ptp(p1) * np.ptp(p2)
    if abs(area - rectangle) > 1e-8 * rectangle:
        raise ValueError(
            f"surface_from_boundary: the selected region (area {area:.6g}) is not the rectangle "
            f"that bounds it (area {rectangle:.6g}); pass resolution=None to copy its facets"
        )
    origin = centre + p1.min() * e1 + p2.min() * e2
    points, cells = _rectangle_grid(
        origin,
        (p1.max() - p1.min()) * e1,
        (p2.max() - p2.min()) * e2,
        int(resolution[0]),
        int(resolution[1]),
        cell_type,
    )
    return surface_mesh(comm, points, cells, cell_type)
