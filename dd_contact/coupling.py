"""Penalty tie operators between a volume mesh's boundary and an independent surface mesh.

A tie (eqs. 6-7, A1-A6) needs three "mass" matrices with the penalty factor left out::

    P1 = int H_D^T H_D ds,   P2 = int H_D^T H_S ds,   P4 = int H_S^T H_S ds

where H_D are the volume mesh's basis functions traced on its boundary and H_S the surface
mesh's. The two meshes do not match, so the integrand of P1 and P2 is only piecewise smooth
on a surface cell. We integrate all three exactly over the *intersections* of surface cells
and boundary facets (segment-based mortar integration): each intersection polygon is cut into
triangles carrying a Gauss rule, and the same points serve P1, P2 and P4. Two things follow:

* consistency: for u = v = constant, P1 u - P2 v = 0 exactly, so a rigid translation of the
  tied pair costs nothing (a facet integral for P1 next to point-sampled P2 would not);
* exactness: a linear field on one side transmits the exact nodal loads to the other, so the
  tied patch test holds to round-off, not just to quadrature error.

All matrices are scalar (one dof per node); :func:`blocked` expands them to 3 components.
"""

from __future__ import annotations

from dataclasses import dataclass

import basix
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from dd_contact.meshes import cyclic_vertices

__all__ = ["TieOperators", "blocked", "facet_height", "newell_normal", "pull_back", "tie_operators"]

# Gauss rule on the reference triangle, exact for degree 6 (bilinear x bilinear on a
# non-affine facet is not a polynomial in physical coordinates; degree 6 keeps that error tiny).
_TRI_POINTS, _TRI_WEIGHTS = basix.make_quadrature(basix.CellType.triangle, 6)


def _coordinate_element(mesh: dolfinx.mesh.Mesh) -> basix.finite_element.FiniteElement:
    cmap = mesh.geometry.cmaps[0]
    return basix.create_element(
        basix.ElementFamily.P,
        getattr(basix.CellType, mesh.topology.cell_type.name),
        cmap.degree,
        basix.LagrangeVariant(cmap.variant),
    )


def pull_back(
    element: basix.finite_element.FiniteElement,
    nodes: npt.NDArray[np.float64],
    x: npt.NDArray[np.float64],
    iterations: int = 20,
) -> npt.NDArray[np.float64]:
    """Reference coordinates of points, each in its own cell (Gauss-Newton, vectorised).

    For a surface cell in 3-D this finds the closest point of the cell's (possibly curved)
    geometry, so points slightly off the surface are projected onto it.

    Args:
        element: Coordinate element of the cells.
        nodes: Node coordinates of each point's cell, shape ``(n, num_nodes, 3)``.
        x: Physical points, shape ``(n, 3)``.
        iterations: Maximum Gauss-Newton iterations.

    Returns:
        Reference coordinates, shape ``(n, tdim)``.
    """
    ref = basix.geometry(element.cell_type)
    X = np.tile(ref.mean(axis=0), (x.shape[0], 1))
    for _ in range(iterations):
        tab = element.tabulate(1, X)[..., 0]  # (1 + tdim, n, num_nodes)
        residual = x - np.einsum("nk,nkd->nd", tab[0], nodes)
        J = np.einsum("tnk,nkd->ndt", tab[1:], nodes)  # (n, 3, tdim)
        JtJ = np.einsum("ndt,nds->nts", J, J)
        dX = np.linalg.solve(JtJ, np.einsum("ndt,nd->nt", J, residual)[..., None])[..., 0]
        X += dX
        if np.max(np.abs(dX)) < 1e-14:
            break
    return X


def blocked(matrix: sp.sparray, bs: int = 3) -> sp.csr_array:
    """Expand a scalar operator to ``bs`` interleaved components (dof = bs * node + c)."""
    return sp.csr_array(sp.kron(matrix, sp.eye_array(bs), format="csr"))


@dataclass
class TieOperators:
    """The geometric tie operators between one volume mesh and one surface mesh.

    Attributes:
        P1: Volume-volume operator, shape ``(n_volume_nodes, n_volume_nodes)``.
        P2: Volume-surface operator, shape ``(n_volume_nodes, n_surface_nodes)``.
        P4: Surface-surface operator, shape ``(n_surface_nodes, n_surface_nodes)``.
        covered_area: Area of each surface cell that overlaps the volume boundary.
        cell_area: Area of each surface cell.
        height: Mean height of the volume cells behind the tied facets (the ``h`` of the
            dimensionless penalty ``kappa = h / (E * eps)``).
        facets: The volume mesh's tied boundary facets.
    """

    P1: sp.csr_array
    P2: sp.csr_array
    P4: sp.csr_array
    covered_area: npt.NDArray[np.float64]
    cell_area: npt.NDArray[np.float64]
    height: float
    facets: npt.NDArray[np.int32]

    @property
    def area(self) -> float:
        """Total tied area."""
        return float(self.covered_area.sum())


def newell_normal(poly: np.ndarray) -> np.ndarray:
    """Unit normals of polygons ``(n, k, 3)`` by Newell's method (robust for warped quads)."""
    nxt = np.roll(poly, -1, axis=1)
    n = np.cross(poly, nxt).sum(axis=1)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _polygon_area(p: np.ndarray) -> float:
    """Signed area (shoelace formula), written without np.roll: it runs once per pair."""
    x, y = p[:, 0], p[:, 1]
    cross = np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1]) + x[-1] * y[0] - x[0] * y[-1]
    return 0.5 * float(cross)


def _clip(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: intersection of a polygon with a convex counter-clockwise polygon."""
    out = subject
    for i in range(len(clip)):
        if len(out) == 0:
            break
        a, b = clip[i], clip[(i + 1) % len(clip)]
        edge = b - a
        side = edge[0] * (out[:, 1] - a[1]) - edge[1] * (out[:, 0] - a[0])
        inp, res = out, []
        for j in range(len(inp)):
            p, q = inp[j], inp[(j + 1) % len(inp)]
            sp_, sq = side[j], side[(j + 1) % len(inp)]
            if sp_ >= 0:
                res.append(p)
            if (sp_ >= 0) != (sq >= 0):
                res.append(p + (q - p) * (sp_ / (sp_ - sq)))
        out = np.array(res) if res else np.zeros((0, 2))
    return out


def _boxes_overlap(lo_a, hi_a, lo_b, hi_b, chunk: int = 2048) -> tuple[np.ndarray, np.ndarray]:
    """All pairs (i, j) whose axis-aligned boxes overlap, in chunks to bound memory."""
    pairs_i, pairs_j = [], []
    for start in range(0, len(lo_a), chunk):
        sl = slice(start, start + chunk)
        hit = np.all(
            (lo_a[sl, None, :] <= hi_b[None, :, :]) & (lo_b[None, :, :] <= hi_a[sl, None, :]),
            axis=2,
        )
        i, j = np.nonzero(hit)
        pairs_i.append(i + start)
        pairs_j.append(j)
    return np.concatenate(pairs_i), np.concatenate(pairs_j)


def _boundary_facets(volume: dolfinx.mesh.Mesh) -> np.ndarray:
    tdim = volume.topology.dim
    volume.topology.create_connectivity(tdim - 1, tdim)
    return dolfinx.mesh.exterior_facet_indices(volume.topology)


def tie_operators(
    V: dolfinx.fem.FunctionSpace,
    S: dolfinx.fem.FunctionSpace,
    tolerance: float | None = None,
    facets: npt.NDArray[np.int32] | None = None,
) -> TieOperators:
    """Segment-based tie operators between volume space ``V`` and surface space ``S``.

    Args:
        V: Function space on the volume mesh (scalar basis is used; blocks are ignored).
        S: Function space on the surface mesh.
        tolerance: Largest distance between a surface cell and a boundary facet that still
            counts as touching (default: 5% of the surface cell's diameter).
        facets: Boundary facets of the volume mesh that may be tied (default: all exterior).

    Returns:
        The tie operators (unscaled by the penalty).
    """
    vol, surf = V.mesh, S.mesh
    tdim = vol.topology.dim
    facets = _boundary_facets(vol) if facets is None else np.asarray(facets, dtype=np.int32)
    f2c = vol.topology.connectivity(tdim - 1, tdim)
    facet_cell = f2c.array[f2c.offsets[facets]]

    # Surface cells: first-order polygons, planes and sizes.
    s_nodes_geo = surf.geometry.dofmaps[0]
    s_poly = surf.geometry.x[cyclic_vertices(s_nodes_geo)]
    s_centre = s_poly.mean(axis=1)
    s_normal = newell_normal(s_poly)
    s_diam = np.linalg.norm(s_poly.max(axis=1) - s_poly.min(axis=1), axis=1)
    tol = 0.05 * s_diam if tolerance is None else np.full(len(s_poly), float(tolerance))

    # Volume boundary facets.
    f_nodes = dolfinx.mesh.entities_to_geometry(vol, tdim - 1, facets)
    f_poly = vol.geometry.x[cyclic_vertices(f_nodes)]
    f_centre = f_poly.mean(axis=1)
    f_normal = newell_normal(f_poly)

    pad = tol[:, None]
    si, fj = _boxes_overlap(
        s_poly.min(axis=1) - pad,
        s_poly.max(axis=1) + pad,
        f_poly.min(axis=1),
        f_poly.max(axis=1),
    )
    # Keep facets nearly parallel to and close to the surface cell's plane.
    cosine = np.abs(np.einsum("nd,nd->n", s_normal[si], f_normal[fj]))
    distance = np.abs(np.einsum("nd,nd->n", f_centre[fj] - s_centre[si], s_normal[si]))
    keep = (cosine > 0.7) & (distance <= tol[si])
    si, fj = si[keep], fj[keep]

    # In-plane basis of each surface cell.
    e1 = s_poly[:, 1] - s_poly[:, 0]
    e1 -= np.einsum("nd,nd->n", e1, s_normal)[:, None] * s_normal
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(s_normal, e1)

    def to_plane(points: np.ndarray, s: int) -> np.ndarray:
        d = points - s_centre[s]
        return np.stack([d @ e1[s], d @ e2[s]], axis=1)

    cell_area = np.array([abs(_polygon_area(to_plane(s_poly[s], s))) for s in range(len(s_poly))])
    covered = np.zeros(len(s_poly))
    qx, qw, q_s, q_f = [], [], [], []
    for s, f in zip(si, fj):
        clip = to_plane(s_poly[s], s)
        if _polygon_area(clip) < 0:
            clip = clip[::-1]
        subject = to_plane(f_poly[f], s)
        if _polygon_area(subject) < 0:
            subject = subject[::-1]
        poly = _clip(subject, clip)
        if len(poly) < 3:
            continue
        area = _polygon_area(poly)
        if area <= 1e-14 * cell_area[s]:
            continue
        covered[s] += area
        # Fan triangulation of the convex intersection, a Gauss rule on each triangle.
        for k in range(1, len(poly) - 1):
            a, b, c = poly[0], poly[k], poly[k + 1]
            tri_area = 0.5 * abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            p2 = a + _TRI_POINTS[:, :1] * (b - a) + _TRI_POINTS[:, 1:] * (c - a)
            qx.append(s_centre[s] + p2[:, :1] * e1[s] + p2[:, 1:] * e2[s])
            qw.append(2.0 * tri_area * _TRI_WEIGHTS)
            q_s.append(np.full(len(p2), s))
            q_f.append(np.full(len(p2), f))

    n_v = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    n_s = S.dofmap.index_map.size_local + S.dofmap.index_map.num_ghosts
    if not qx:
        empty = sp.csr_array((n_v, n_v))
        return TieOperators(
            empty,
            sp.csr_array((n_v, n_s)),
            sp.csr_array((n_s, n_s)),
            covered,
            cell_area,
            0.0,
            np.zeros(0, np.int32),
        )
    x = np.concatenate(qx)
    w = np.concatenate(qw)
    q_s = np.concatenate(q_s)
    q_f = np.concatenate(q_f)

    # Surface basis at the points.
    s_elem = _coordinate_element(surf)
    X_s = pull_back(s_elem, surf.geometry.x[s_nodes_geo[q_s]], x)
    phi_s = S.element.basix_element.tabulate(0, X_s)[0, :, :, 0]
    dofs_s = S.dofmap.list[q_s]

    # Volume basis: move each point onto its facet's plane along the surface normal, then
    # pull it back into the cell behind the facet.
    ns, nf = s_normal[q_s], f_normal[q_f]
    shift = np.einsum("nd,nd->n", x - f_centre[q_f], nf) / np.einsum("nd,nd->n", ns, nf)
    x_vol = x - shift[:, None] * ns
    cells = facet_cell[q_f]
    v_elem = _coordinate_element(vol)
    X_v = pull_back(v_elem, vol.geometry.x[vol.geometry.dofmaps[0][cells]], x_vol)
    phi_v = V.element.basix_element.tabulate(0, X_v)[0, :, :, 0]
    dofs_v = V.dofmap.list[cells]

    def mass(phi_a, dofs_a, phi_b, dofs_b, shape):
        vals = np.einsum("n,ni,nj->nij", w, phi_a, phi_b)
        rows = np.broadcast_to(dofs_a[:, :, None], vals.shape)
        cols = np.broadcast_to(dofs_b[:, None, :], vals.shape)
        return sp.csr_array(sp.coo_array((vals.ravel(), (rows.ravel(), cols.ravel())), shape=shape))

    tied = np.unique(q_f)
    return TieOperators(
        P1=mass(phi_v, dofs_v, phi_v, dofs_v, (n_v, n_v)),
        P2=mass(phi_v, dofs_v, phi_s, dofs_s, (n_v, n_s)),
        P4=mass(phi_s, dofs_s, phi_s, dofs_s, (n_s, n_s)),
        covered_area=covered,
        cell_area=cell_area,
        height=_mean_height(vol, facet_cell[tied], f_centre[tied], f_normal[tied]),
        facets=facets[tied],
    )


def facet_height(volume: dolfinx.mesh.Mesh, facets: npt.NDArray[np.int32]) -> float:
    """Mean height of the cells behind boundary facets (the ``h`` of ``kappa = h/(E eps)``)."""
    tdim = volume.topology.dim
    volume.topology.create_connectivity(tdim - 1, tdim)
    f2c = volume.topology.connectivity(tdim - 1, tdim)
    poly = volume.geometry.x[
        cyclic_vertices(dolfinx.mesh.entities_to_geometry(volume, tdim - 1, facets))
    ]
    cells = f2c.array[f2c.offsets[facets]]
    return _mean_height(volume, cells, poly.mean(axis=1), newell_normal(poly))


def _mean_height(vol, cells, centres, normals) -> float:
    """Mean distance from each tied facet to the farthest node of the cell behind it."""
    x = vol.geometry.x[vol.geometry.dofmaps[0][cells]]
    height = np.abs(np.einsum("nkd,nd->nk", x - centres[:, None, :], normals)).max(axis=1)
    return float(height.mean())
