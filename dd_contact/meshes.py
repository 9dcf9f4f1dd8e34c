"""Meshes for scenes: box subdomains and independent surface meshes.

Every subdomain belongs to one MPI rank (see :class:`dd_contact.scene.Scene`), so the helpers
here default to ``MPI.COMM_SELF``.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from types import ModuleType

from mpi4py import MPI

import basix.ufl
import dolfinx.io.gmsh
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

__all__ = [
    "HEMISPHERE_CURVED",
    "HEMISPHERE_SYMMETRY_X",
    "HEMISPHERE_SYMMETRY_Y",
    "HEMISPHERE_TOP",
    "box",
    "cylinder_surface",
    "face_tags",
    "facet_surface",
    "hemisphere",
    "hole_block",
    "rectangle_grid",
    "surface_from_boundary",
    "surface_from_facets",
    "surface_mesh",
]

#: Facet tag of the curved (spherical) surface of :func:`hemisphere`.
HEMISPHERE_CURVED = 1
#: Facet tag of the flat top face ``z = radius`` of :func:`hemisphere`.
HEMISPHERE_TOP = 2
#: Facet tag of the symmetry plane ``x = 0`` of a quarter :func:`hemisphere`.
HEMISPHERE_SYMMETRY_X = 3
#: Facet tag of the symmetry plane ``y = 0`` of a quarter :func:`hemisphere`.
HEMISPHERE_SYMMETRY_Y = 4

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


def rectangle_grid(
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


def facet_surface(
    volume: dolfinx.mesh.Mesh, facets: npt.NDArray[np.int32], comm: MPI.Comm | None = None
) -> dolfinx.mesh.Mesh:
    """A surface mesh that is a conforming copy of some boundary facets of a volume mesh.

    Args:
        volume: The volume mesh.
        facets: Indices of its (boundary) facets to copy.
        comm: Communicator of the new mesh (default ``volume.comm``).
    """
    comm = volume.comm if comm is None else comm
    tdim = volume.topology.dim
    nodes = dolfinx.mesh.entities_to_geometry(volume, tdim - 1, facets)
    used, cells = np.unique(nodes, return_inverse=True)
    facet_type = volume.topology.entity_types[tdim - 1][0].name
    return surface_mesh(comm, volume.geometry.x[used], cells.reshape(nodes.shape), facet_type)


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
    with ``n1 x n2`` cells of ``cell_type``, independently of the volume mesh, and its cells'
    normals point out of the volume.

    Args:
        volume: The volume mesh.
        locator: ``locator(x) -> bool array`` selecting boundary facets (all vertices of a
            facet must satisfy it), like :func:`dolfinx.mesh.locate_entities_boundary`.
        resolution: Cells along the rectangle's two edges, or ``None``.
        cell_type: ``"quadrilateral"`` or ``"triangle"`` (used with ``resolution``).
        comm: Communicator of the new mesh (default ``volume.comm``).
    """
    tdim = volume.topology.dim
    volume.topology.create_connectivity(tdim - 1, tdim)
    facets = dolfinx.mesh.locate_entities_boundary(volume, tdim - 1, locator)
    if facets.size == 0:
        raise ValueError(
            "surface_from_boundary: the locator selects no boundary facet of the volume mesh; "
            "check the locator against the mesh's bounding box"
        )
    return surface_from_facets(volume, facets, resolution, cell_type, comm)


def surface_from_facets(
    volume: dolfinx.mesh.Mesh,
    facets: npt.NDArray[np.int32],
    resolution: tuple[int, int] | None = None,
    cell_type: str = "quadrilateral",
    comm: MPI.Comm | None = None,
) -> dolfinx.mesh.Mesh:
    """:func:`surface_from_boundary` for given boundary facets instead of a locator."""
    comm = volume.comm if comm is None else comm
    tdim = volume.topology.dim
    if resolution is None:
        return facet_surface(volume, facets, comm)

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
    normal = _outward(volume, facets[0], axes[2])
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
    points, cells = rectangle_grid(
        origin,
        (p1.max() - p1.min()) * e1,
        (p2.max() - p2.min()) * e2,
        int(resolution[0]),
        int(resolution[1]),
        cell_type,
    )
    return surface_mesh(comm, points, cells, cell_type)


def _outward(volume: dolfinx.mesh.Mesh, facet: int, normal: np.ndarray) -> np.ndarray:
    """``normal`` or its opposite, whichever points out of the volume at boundary ``facet``."""
    tdim = volume.topology.dim
    volume.topology.create_connectivity(tdim - 1, tdim)
    cell = volume.topology.connectivity(tdim - 1, tdim).links(facet)[0]
    inside = volume.geometry.x[volume.geometry.dofmaps[0][cell]].mean(axis=0)
    on_facet = volume.geometry.x[
        dolfinx.mesh.entities_to_geometry(volume, tdim - 1, np.array([facet], np.int32))[0]
    ].mean(axis=0)
    return normal if (on_facet - inside) @ normal > 0 else -normal


@contextlib.contextmanager
def _gmsh_model(what: str, options: dict[str, float]) -> Iterator[ModuleType]:
    """Gmsh, with a new current model for ``what`` and ``options`` set; then Gmsh as it was.

    Gmsh is an optional dependency: without it, an error names the extra to install. It is
    initialised and finalised here unless the caller has initialised it; then the model is
    removed, the caller's current model restored, and the options too.
    """
    try:
        import gmsh
    except ModuleNotFoundError as err:
        raise ModuleNotFoundError(
            f"{what} needs the Gmsh Python module: pip install dd_contact[mesh]", name="gmsh"
        ) from err
    owner = not gmsh.isInitialized()  # then this call must finalise it
    if owner:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    saved = {option: gmsh.option.getNumber(option) for option in options}
    previous_model = None if owner else gmsh.model.getCurrent()
    try:
        for option, value in options.items():
            gmsh.option.setNumber(option, value)
        gmsh.model.add(f"dd_contact_{what}")
        yield gmsh
    finally:
        if owner:
            gmsh.finalize()
        else:
            gmsh.model.remove()
            if previous_model:
                gmsh.model.setCurrent(previous_model)
            for option, value in saved.items():
                gmsh.option.setNumber(option, value)


def hemisphere(
    comm: MPI.Comm,
    radius: float,
    contact_radius: float,
    h_contact: float,
    h_far: float,
    quarter: bool | str = True,
    order: int = 1,
    grading: float = 0.1,
) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """A tetrahedral mesh of a solid hemisphere (or a quarter of one) for a Hertz contact test.

    The sphere has centre ``(0, 0, radius)``; the hemisphere is its lower half
    ``0 <= z <= radius``, so its pole touches the plane ``z = 0`` at the origin and its flat
    face is ``z = radius``. With ``quarter`` only ``x >= 0, y >= 0`` is kept, bounded by the
    symmetry planes ``x = 0`` and ``y = 0``. The pole is always a mesh node.

    The mesh size is ``h_contact`` within a distance ``1.5 * contact_radius`` of the pole (on
    the curved surface and inside) and grows linearly, by ``grading`` per unit distance, up to
    ``h_far``. The geometry is built with the OpenCASCADE kernel, so the nodes of the curved
    surface lie on the sphere. The sphere is rotated so that its parametric poles and seam lie
    on the rim ``z = radius``, away from the contact zone.

    The Gmsh model is generated on rank 0 of ``comm`` only and distributed by dolfinx. Gmsh
    is initialised and finalised here unless the caller has already initialised it; then a
    temporary model is used and removed, and the options changed here are restored.

    Args:
        comm: Communicator (``MPI.COMM_SELF`` for a subdomain).
        radius: Sphere radius ``R``.
        contact_radius: Expected Hertz contact radius ``a``: sets the refined zone.
        h_contact: Mesh size near the pole.
        h_far: Mesh size far from the pole.
        quarter: Keep only the quarter ``x >= 0, y >= 0`` (``"half"``: only ``y >= 0``).
        order: Geometry order of the tetrahedra (1 or 2).
        grading: Growth of the mesh size per unit distance beyond the refined zone (0.1: a
            size ratio of about 1.1 between neighbouring elements). Smaller is smoother and
            costs more nodes.

    Returns:
        The mesh and its facet tags: :data:`HEMISPHERE_CURVED`, :data:`HEMISPHERE_TOP` and,
        with ``quarter``, :data:`HEMISPHERE_SYMMETRY_X` (not ``"half"``) and
        :data:`HEMISPHERE_SYMMETRY_Y`.

    Raises:
        ValueError: If a length or ``grading`` is not positive, or ``order`` is not 1 or 2.
        ModuleNotFoundError: If Gmsh is not installed (``pip install dd_contact[mesh]``).
    """
    if min(radius, contact_radius, h_contact, h_far, grading) <= 0:
        raise ValueError(
            "hemisphere: radius, contact_radius, h_contact, h_far and grading must be positive, "
            f"got {radius=}, {contact_radius=}, {h_contact=}, {h_far=}, {grading=}"
        )
    if order not in (1, 2):
        raise ValueError(f"hemisphere: order must be 1 or 2, got {order}")
    rank = 0
    if comm.rank != rank:  # Only ``rank`` holds the Gmsh model; the others receive cells.
        data = dolfinx.io.gmsh.model_to_mesh(None, comm, rank, gdim=3)
        assert data.facet_tags is not None  # the model has physical facet groups
        return data.mesh, data.facet_tags

    options = {
        "General.Terminal": 0,
        "Mesh.MeshSizeExtendFromBoundary": 0,
        "Mesh.MeshSizeFromPoints": 0,
        "Mesh.MeshSizeFromCurvature": 0,
        "Mesh.MeshSizeMin": min(h_contact, h_far),
        "Mesh.MeshSizeMax": max(h_contact, h_far),
    }
    with _gmsh_model("hemisphere", options) as gmsh:
        _hemisphere_model(gmsh, radius, contact_radius, h_contact, h_far, quarter, order, grading)
        data = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, rank, gdim=3)
    assert data.facet_tags is not None
    data.facet_tags.name = "hemisphere_facets"
    return data.mesh, data.facet_tags


#: Names of the physical groups of :func:`hemisphere`'s facet tags.
_HEMISPHERE_NAMES = {
    HEMISPHERE_CURVED: "curved",
    HEMISPHERE_TOP: "top",
    HEMISPHERE_SYMMETRY_X: "symmetry_x",
    HEMISPHERE_SYMMETRY_Y: "symmetry_y",
}


def _hemisphere_model(
    gmsh: ModuleType,
    radius: float,
    contact_radius: float,
    h_contact: float,
    h_far: float,
    quarter: bool | str,
    order: int,
    grading: float,
) -> None:
    """Build and mesh the Gmsh model of :func:`hemisphere` in the current model."""
    volume_dimtag = _hemisphere_volume(gmsh.model.occ, radius, quarter)
    eps = 1e-6 * radius  # faces and the pole are found by their exact geometry, within eps
    groups = _hemisphere_faces(gmsh, volume_dimtag, radius, quarter, eps)
    pole = _hemisphere_pole(gmsh, volume_dimtag, groups[HEMISPHERE_CURVED][0], eps)
    for tag, surfaces in groups.items():
        gmsh.model.addPhysicalGroup(2, surfaces, tag, _HEMISPHERE_NAMES[tag])
    gmsh.model.addPhysicalGroup(3, [volume_dimtag[1]], 1, "hemisphere")

    fields = gmsh.model.mesh.field
    distance = fields.add("Distance")
    fields.setNumbers(distance, "PointsList", [pole])
    threshold = fields.add("Threshold")
    dist_min = 1.5 * contact_radius
    fields.setNumber(threshold, "InField", distance)
    fields.setNumber(threshold, "SizeMin", h_contact)
    fields.setNumber(threshold, "SizeMax", h_far)
    fields.setNumber(threshold, "DistMin", dist_min)
    fields.setNumber(threshold, "DistMax", dist_min + abs(h_far - h_contact) / grading)
    fields.setAsBackgroundMesh(threshold)

    gmsh.model.mesh.generate(3)
    if order > 1:
        gmsh.model.mesh.setOrder(order)


def _hemisphere_volume(occ: ModuleType, radius: float, quarter: bool | str) -> tuple[int, int]:
    """The OCC volume of the hemisphere (or its quarter), synchronised: its (dim, tag)."""
    sphere = occ.addSphere(0.0, 0.0, radius, radius)
    # OCC's sphere has its parametric poles on its z axis and its seam in the half-plane
    # y = 0, x > 0. Turn the poles to (-1, 1, 0)/sqrt(2) and (1, -1, 0)/sqrt(2) about the
    # centre: poles and seam then lie on the rim z = radius, outside the quarter, and the
    # contact zone is meshed where the parametrisation is regular.
    occ.rotate([(3, sphere)], 0.0, 0.0, radius, 1.0, 0.0, 0.0, np.pi / 2)
    occ.rotate([(3, sphere)], 0.0, 0.0, radius, 0.0, 0.0, 1.0, np.pi / 4)
    lo, y_lo = (0.0 if quarter is True else -1.1 * radius), (0.0 if quarter else -1.1 * radius)
    cut = occ.addBox(lo, y_lo, -0.1 * radius, 1.1 * radius - lo, 1.1 * radius - y_lo, 1.1 * radius)
    (volume_dimtag,), _ = occ.intersect([(3, sphere)], [(3, cut)])
    if quarter == "half":  # the pole, on the arc y = 0, split it there (not embedded: 0-volume)
        volume_dimtag = occ.fragment([volume_dimtag], [(0, occ.addPoint(0, 0, 0))])[0][0]
    occ.synchronize()
    return volume_dimtag


def _hemisphere_faces(
    gmsh: ModuleType, volume_dimtag: tuple[int, int], radius: float, quarter: bool | str, eps: float
) -> dict[int, list[int]]:
    """The hemisphere's boundary surfaces by facet tag (:data:`HEMISPHERE_CURVED`, ...).

    Faces are classified by their exact geometry, not by ``getBoundingBox``: OCC pads
    bounding boxes by its absolute shape tolerance (1e-7), so a flat face of a small
    hemisphere is not thinner than a tolerance relative to ``radius``.
    """
    cos_tol = 1e-6  # of unit normals
    planes = {HEMISPHERE_TOP: (2, radius)}  # tag: (axis of the normal, coordinate on it)
    groups: dict[int, list[int]] = {HEMISPHERE_CURVED: [], HEMISPHERE_TOP: []}
    if quarter:  # a half has no plane x = 0
        planes[HEMISPHERE_SYMMETRY_Y] = (1, 0.0)
        planes |= {HEMISPHERE_SYMMETRY_X: (0, 0.0)} if quarter is True else {}
        groups |= {tag: [] for tag in planes if tag != HEMISPHERE_TOP}
    for _, surface in gmsh.model.getBoundary([volume_dimtag], oriented=False):
        group = HEMISPHERE_CURVED
        if gmsh.model.getType(2, surface) == "Plane":
            lower, upper = gmsh.model.getParametrizationBounds(2, surface)
            uv = 0.5 * (np.asarray(lower) + np.asarray(upper))
            normal = gmsh.model.getNormal(surface, uv)
            point = gmsh.model.getValue(2, surface, uv)  # On the face's plane.
            for tag, (axis, value) in planes.items():
                if abs(abs(normal[axis]) - 1.0) < cos_tol and abs(point[axis] - value) < eps:
                    group = tag
                    break
        groups[group].append(surface)
    if any(not surfaces for surfaces in groups.values()):  # pragma: no cover
        raise RuntimeError(f"hemisphere: unexpected faces in the Gmsh model: {groups}")
    return groups


def _hemisphere_pole(
    gmsh: ModuleType, volume_dimtag: tuple[int, int], curved: int, eps: float
) -> int:
    """The Gmsh point at the pole (the origin), so that it is always a mesh node.

    The pole is a vertex of the quarter, found from the exact vertex coordinates; in the
    full hemisphere it is added and embedded in the ``curved`` surface.
    """
    vertices = gmsh.model.getBoundary([volume_dimtag], combined=False, recursive=True)
    poles = [
        tag
        for dim, tag in vertices
        if dim == 0 and np.linalg.norm(gmsh.model.getValue(0, tag, [])) < eps
    ]
    if poles:
        return poles[0]
    pole = gmsh.model.occ.addPoint(0.0, 0.0, 0.0)
    gmsh.model.occ.synchronize()
    gmsh.model.mesh.embed(0, [pole], 2, curved)
    return pole


def face_tags(
    mesh: dolfinx.mesh.Mesh, regions: dict[int, Callable[[np.ndarray], np.ndarray]]
) -> dolfinx.mesh.MeshTags:
    """Facet tags of a volume mesh's boundary: ``regions[tag]`` locates the facets of ``tag``.

    A facet selected by two locators gets the first tag; boundary facets no locator selects
    stay untagged.
    """
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    tagged: dict[int, int] = {}
    for tag, locator in regions.items():
        for facet in dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, locator):
            tagged.setdefault(int(facet), tag)
    facets = np.array(sorted(tagged), dtype=np.int32)
    values = np.array([tagged[f] for f in facets], dtype=np.int32)
    return dolfinx.mesh.meshtags(mesh, tdim - 1, facets, values)


def cylinder_surface(
    comm: MPI.Comm,
    centre: Sequence[float],
    radius: float,
    height: float,
    n_around: int,
    n_along: int,
    phase: float = 0.0,
) -> dolfinx.mesh.Mesh:
    """A quadrilateral mesh of the cylinder wall about the z axis through ``centre``.

    The wall runs from ``centre[2]`` to ``centre[2] + height``; its nodes lie on the circle,
    ``n_around`` cells around (the first node at angle ``phase`` of a cell from +x) and
    ``n_along`` along z. Cells are ordered so that their normal points to the axis: out of
    a body around the hole.
    """
    angles = 2 * np.pi * (phase + np.arange(n_around)) / n_around
    z = centre[2] + height * np.linspace(0.0, 1.0, n_along + 1)
    ring = np.column_stack(
        [centre[0] + radius * np.cos(angles), centre[1] + radius * np.sin(angles)]
    )
    points = np.column_stack([np.tile(ring, (n_along + 1, 1)), np.repeat(z, n_around)])
    i2, k2 = np.meshgrid(np.arange(n_around), np.arange(n_along), indexing="ij")
    i, k = i2.ravel(), k2.ravel()
    a, b = k * n_around + i, k * n_around + (i + 1) % n_around
    # (z along e1, angle along e2): e1 x e2 = z x tangent = -radial, towards the axis.
    cells = np.column_stack([a, a + n_around, b, b + n_around])
    return surface_mesh(comm, points, cells, "quadrilateral")


def hole_block(
    comm: MPI.Comm,
    lower: Sequence[float],
    side: float,
    radius: float,
    thickness: float,
    cells_side: int,
    cells_radial: int,
    layers: int,
) -> dolfinx.mesh.Mesh:
    """Hexahedra of a square plate block with a centred round hole: an O-grid made by gmsh.

    The block is ``[lower, lower + (side, side, thickness)]`` with a hole of ``radius``
    through its thickness; four transfinite patches join the hole's quarter arcs to the
    block's sides along the diagonals: ``cells_side`` cells along each side and quarter arc,
    ``cells_radial`` from the hole to the side, ``layers`` through the thickness
    (``4 cells_side cells_radial layers`` hexahedra).

    Raises:
        ValueError: If the hole does not fit in the block or a count is not positive.
        ModuleNotFoundError: If Gmsh is not installed (``pip install dd_contact[mesh]``).
    """
    if not 0.0 < radius < side / 2 or thickness <= 0.0:
        raise ValueError(
            f"hole_block: need 0 < radius < side / 2 and thickness > 0, got {radius=}, "
            f"{side=}, {thickness=}"
        )
    if min(cells_side, cells_radial, layers) < 1:
        raise ValueError(
            f"hole_block: cell counts must be positive, got {cells_side=}, {cells_radial=}, "
            f"{layers=}"
        )
    with _gmsh_model("hole_block", {"General.Terminal": 0}) as gmsh:
        _hole_block_model(gmsh, lower, side, radius, thickness, cells_side, cells_radial, layers)
        mesh = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3).mesh
    return mesh


def _hole_block_model(
    gmsh: ModuleType,
    lower: Sequence[float],
    side: float,
    radius: float,
    thickness: float,
    cells_side: int,
    cells_radial: int,
    layers: int,
) -> None:
    """Build and mesh the O-grid of :func:`hole_block` in the current gmsh model."""
    geo = gmsh.model.geo
    cx, cy, z0 = lower[0] + side / 2, lower[1] + side / 2, lower[2]
    centre = geo.addPoint(cx, cy, z0)
    angles = np.pi / 4 + np.arange(4) * np.pi / 2
    corner = side / np.sqrt(2.0)
    inner = [geo.addPoint(cx + radius * np.cos(a), cy + radius * np.sin(a), z0) for a in angles]
    outer = [geo.addPoint(cx + corner * np.cos(a), cy + corner * np.sin(a), z0) for a in angles]
    arcs = [geo.addCircleArc(inner[i], centre, inner[(i + 1) % 4]) for i in range(4)]
    sides = [geo.addLine(outer[i], outer[(i + 1) % 4]) for i in range(4)]
    spokes = [geo.addLine(inner[i], outer[i]) for i in range(4)]
    for curve in arcs + sides:
        geo.mesh.setTransfiniteCurve(curve, cells_side + 1)
    for curve in spokes:
        geo.mesh.setTransfiniteCurve(curve, cells_radial + 1)
    patches = []
    for i in range(4):
        loop = geo.addCurveLoop([arcs[i], spokes[(i + 1) % 4], -sides[i], -spokes[i]])
        patch = geo.addPlaneSurface([loop])
        geo.mesh.setTransfiniteSurface(patch)
        geo.mesh.setRecombine(2, patch)
        patches.append((2, patch))
    extruded = geo.extrude(patches, 0, 0, thickness, numElements=[layers], recombine=True)
    geo.synchronize()
    gmsh.model.addPhysicalGroup(3, [tag for dim, tag in extruded if dim == 3], 1)
    gmsh.model.mesh.generate(3)
