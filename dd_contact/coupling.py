"""Penalty tie operators between a volume mesh's boundary and an independent surface mesh.

A tie (eqs. 6-7, A1-A6) needs three "mass" matrices with the penalty factor left out::

    P1 = int H_D^T H_D ds,   P2 = int H_D^T H_S ds,   P4 = int H_S^T H_S ds

where H_D are the volume mesh's basis functions traced on its boundary and H_S the surface
mesh's. The meshes do not match, so the integrand of P1 and P2 is only piecewise smooth on a
surface cell. We integrate all three over the *intersections* of surface cells and
boundary facets (segment-based mortar integration): each intersection polygon is cut into
triangles carrying a Gauss rule, and the same points serve P1, P2 and P4. Two things follow:

* consistency: for u = v = constant, P1 u - P2 v = 0 to round-off, so a rigid translation
  of the tied pair costs nothing (a facet integral for P1 next to point-sampled P2 would
  not); for u and v interpolating one linear field, P1 u = P2 v and P4 v = P2^T u;
* exactness: a linear field on one side transmits the exact nodal loads to the other, so the
  tied patch test holds to round-off, not just to quadrature error.

On a quadrilateral that is not a parallelogram the bilinear basis is a rational function of
the physical coordinates, which no polynomial rule on the triangles integrates exactly; the
two subdomains' quadrature errors then differ and the stress picks up an O(1/kappa) error.
So each triangle's Gauss degree follows the distortion of the bilinear map over it
(:func:`bilinear_distortion`), too distorted ones are split, and the integrands come out to
round-off (1e-14 of the triangle's area); triangles and parallelograms keep degree 6.

All matrices are scalar (one dof per node); :func:`blocked` expands them to 3 components.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import cast

import basix
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.spatial import cKDTree

from dd_contact.meshes import cyclic_vertices

__all__ = [
    "TieOperators",
    "bilinear_distortion",
    "blocked",
    "facet_height",
    "matching",
    "newell_normal",
    "pull_back",
    "tie_operators",
]

# Gauss degree of an intersection triangle by the distortion of the bilinear maps over it
# (:func:`bilinear_distortion`): (largest distortion, degree). Measured on 7500 random
# triangles in random convex quadrilaterals: the smallest distortion at which the degree
# integrates phi_i phi_j worse than 1e-14 of the triangle's area, times 0.7. Degree 6 is exact
# for triangles and parallelograms on both sides (bilinear x bilinear). A triangle more
# distorted than the last entry is split in four, at most _MAX_SPLITS times.
_DEGREES = (
    (0.0023, 6),
    (0.021, 8),
    (0.052, 10),
    (0.136, 12),
    (0.228, 14),
    (0.34, 16),
    (0.63, 20),
    (0.9, 25),
    (1.46, 30),
)
_MAX_SPLITS = 5

#: Tie entries at most this fraction of the operator's largest are round-off (a node off the
#: tied facets: 1e-17 to 1e-13; the pin joint's next are 1e-9), dropped: else a reduced
#: subdomain, whose boundary leaves them out, is another model (docs/solvers.md).
TIE_FLOOR = 1e-12


@functools.cache
def _triangle_rule(degree: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Gauss points and weights of degree ``degree`` on the reference triangle."""
    rule = basix.make_quadrature(basix.CellType.triangle, degree)  # annotated as ArrayLike
    return cast(tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]], rule)


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
    active = np.arange(x.shape[0])  # Points still moving (most converge in a step or two).
    for _ in range(iterations):
        if active.size == 0:
            break
        # basix annotates tabulate's result as ArrayLike; (1 + tdim, n, num_nodes)
        tab = cast(np.ndarray, element.tabulate(1, X[active]))[..., 0]
        nodes_a = nodes[active]
        residual = x[active] - np.einsum("nk,nkd->nd", tab[0], nodes_a)
        J = np.einsum("tnk,nkd->ndt", tab[1:], nodes_a)  # (n, gdim, tdim)
        JtJ = np.einsum("ndt,nds->nts", J, J)
        dX = np.linalg.solve(JtJ, np.einsum("ndt,nd->nt", J, residual)[..., None])[..., 0]
        X[active] += dX
        active = active[np.abs(dX).max(axis=1) >= 1e-14]
    return X


def _plane_coordinates(points, centre, e1, e2) -> npt.NDArray[np.float64]:
    """Coordinates ``(n, k, 2)`` of points ``(n, k, 3)`` in the planes ``centre + [e1, e2]``."""
    d = points - centre[:, None, :]
    return np.stack([np.einsum("nkd,nd->nk", d, e1), np.einsum("nkd,nd->nk", d, e2)], axis=2)


def _in_plane_basis(poly: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors e1 (along the first edge) and e2 = n x e1 of polygons ``(n, k, 3)``."""
    e1 = poly[:, 1] - poly[:, 0]
    e1 -= np.einsum("nd,nd->n", e1, normal)[:, None] * normal
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(normal, e1)


def _bilinear_maps(nodes: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Coefficients ``(n, 4, 2)`` of ``x = c0 + c1 X + c2 Y + c3 X Y`` of planar quadrilaterals.

    Args:
        nodes: Planar vertex coordinates in tensor order ``(0,0), (1,0), (0,1), (1,1)``,
            shape ``(n, 4, 2)``.
    """
    x0, x1, x2, x3 = nodes[:, 0], nodes[:, 1], nodes[:, 2], nodes[:, 3]
    return np.stack([x0, x1 - x0, x2 - x0, x0 - x1 - x2 + x3], axis=1)


def _is_parallelogram(maps: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    size = np.linalg.norm(maps[:, 1], axis=1) + np.linalg.norm(maps[:, 2], axis=1)
    return np.linalg.norm(maps[:, 3], axis=1) <= 1e-13 * size


def _solve_2x2(jx: np.ndarray, jy: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Solve ``[jx jy] d = r`` for many 2x2 systems at once (Cramer's rule; last axis 2)."""
    det = jx[..., 0] * jy[..., 1] - jx[..., 1] * jy[..., 0]
    return np.stack(
        [
            (r[..., 0] * jy[..., 1] - r[..., 1] * jy[..., 0]) / det,
            (jx[..., 0] * r[..., 1] - jx[..., 1] * r[..., 0]) / det,
        ],
        axis=-1,
    )


def bilinear_distortion(
    maps: npt.NDArray[np.float64], triangles: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """How far from affine a bilinear map is over each triangle (0 for a parallelogram).

    With ``x = F(X)`` the cell's map and ``X_k`` the reference points of the triangle's
    vertices, the distortion is ``max_k |J(X_k)^-1 c3| * max_ij |X_i - X_j|``: the size of
    the triangle relative to the distance over which the inverse map, hence the cell's basis
    in physical coordinates, stays close to linear. Gauss rules on the triangle converge
    like a power of it (see ``_DEGREES``).

    Args:
        maps: Bilinear maps of the cells of the triangles, shape ``(m, 4, 2)``
            (:func:`_bilinear_maps`).
        triangles: Triangle vertices in the cells' planes, shape ``(m, 3, 2)``.

    Returns:
        Distortion per triangle, shape ``(m,)`` (``inf`` where the map is singular).
    """
    if len(triangles) == 0:
        return np.zeros(0)
    c0, c1, c2, c3 = (maps[:, None, k] for k in range(4))
    X = np.full(triangles.shape, 0.5)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(50):  # Newton; converges in a few steps for a convex cell.
            r = triangles - (c0 + c1 * X[..., :1] + c2 * X[..., 1:] + c3 * X[..., :1] * X[..., 1:])
            dX = _solve_2x2(c1 + c3 * X[..., 1:], c2 + c3 * X[..., :1], r)
            X = X + dX
            step = np.abs(dX[np.isfinite(dX)])
            if step.size == 0 or step.max() <= 1e-12:
                break
        g = _solve_2x2(c1 + c3 * X[..., 1:], c2 + c3 * X[..., :1], c3)
        reach = np.linalg.norm(g, axis=-1).max(axis=1)
        size = np.linalg.norm(X[:, [0, 1, 2]] - X[:, [1, 2, 0]], axis=-1).max(axis=1)
        distortion = reach * size
    return np.where(np.isfinite(distortion), distortion, np.inf)


def _split(triangles: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Each triangle ``(m, 3, d)`` split in four by its edge midpoints: ``(4, m, 3, d)``."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
    return np.stack(
        [np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
    )


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
        projected: Whether P1 is the projected tie ``P2 P4^-1 P2^T`` (a surface that does not
            copy the tied facets) rather than the pointwise one.
    """

    P1: sp.csr_array
    P2: sp.csr_array
    P4: sp.csr_array
    covered_area: npt.NDArray[np.float64]
    cell_area: npt.NDArray[np.float64]
    height: float
    facets: npt.NDArray[np.int32]
    projected: bool = False

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


class _Rules:
    """Picks the rule of each intersection triangle from the bilinear maps of its two cells."""

    def __init__(self, surf, s_nodes, s_centre, e1, e2, vol, f_nodes, f_centre, f_normal):
        self.s_centre, self.e1, self.e2 = s_centre, e1, e2
        self.s_maps = self.f_maps = None
        if s_nodes.shape[1] == 4:  # First-order quadrilaterals: maps in their own planes.
            x = surf.geometry.x[s_nodes]
            self.s_maps = _bilinear_maps(_plane_coordinates(x, s_centre, e1, e2))
            self.s_affine = _is_parallelogram(self.s_maps)
        if f_nodes.shape[1] == 4:
            x = vol.geometry.x[f_nodes]
            self.f_e1, self.f_e2 = _in_plane_basis(x[:, [0, 1, 3, 2]], f_normal)
            self.f_centre = f_centre
            self.f_maps = _bilinear_maps(_plane_coordinates(x, f_centre, self.f_e1, self.f_e2))
            self.f_affine = _is_parallelogram(self.f_maps)

    def distortion(self, tri, tri_s, tri_f) -> npt.NDArray[np.float64]:
        """Largest distortion of the surface cell's and the facet's map over each triangle."""
        out = np.zeros(len(tri))
        if self.s_maps is not None:
            sel = ~self.s_affine[tri_s]
            out[sel] = bilinear_distortion(self.s_maps[tri_s[sel]], tri[sel])
        if self.f_maps is not None:
            sel = ~self.f_affine[tri_f]
            if sel.any():
                s, f = tri_s[sel, None], tri_f[sel]
                x = self.s_centre[s] + tri[sel, :, :1] * self.e1[s] + tri[sel, :, 1:] * self.e2[s]
                local = _plane_coordinates(x, self.f_centre[f], self.f_e1[f], self.f_e2[f])
                out[sel] = np.maximum(out[sel], bilinear_distortion(self.f_maps[f], local))
        return out

    def pick(self, tri, tri_s, tri_f):
        """Triangles (split where too distorted) with the Gauss degree each needs."""
        limits = np.array([limit for limit, _ in _DEGREES])
        degrees = np.array([degree for _, degree in _DEGREES])
        distortion = self.distortion(tri, tri_s, tri_f)
        done: tuple[list[np.ndarray], ...] = [], [], [], []
        for level in range(_MAX_SPLITS + 1):
            # A singular map (a degenerate or non-convex cell) is not helped by splitting.
            split = (distortion > limits[-1]) & np.isfinite(distortion) & (level < _MAX_SPLITS)
            keep = ~split
            rung = np.minimum(np.searchsorted(limits, distortion[keep]), len(limits) - 1)
            for out, value in zip(done, (tri[keep], tri_s[keep], tri_f[keep], degrees[rung])):
                out.append(value)
            if not split.any():
                break
            tri = _split(tri[split]).reshape(-1, 3, 2)
            tri_s, tri_f = np.tile(tri_s[split], 4), np.tile(tri_f[split], 4)
            distortion = self.distortion(tri, tri_s, tri_f)
        return tuple(np.concatenate(out) for out in done)


@dataclass
class _Polygons:
    """First-order cells as polygons: cyclic vertices ``(n, k, 3)``, centres, unit normals."""

    vertices: npt.NDArray[np.float64]
    centre: npt.NDArray[np.float64]
    normal: npt.NDArray[np.float64]


def _polygons(x: npt.NDArray[np.float64], nodes: npt.NDArray[np.int32]) -> _Polygons:
    """The polygons of cells given by their geometry nodes ``nodes`` into coordinates ``x``."""
    poly = x[cyclic_vertices(nodes)]
    return _Polygons(poly, poly.mean(axis=1), newell_normal(poly))


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

    s_nodes = surf.geometry.dofmaps[0]
    surface = _polygons(surf.geometry.x, s_nodes)
    s_poly = surface.vertices
    s_diam = np.linalg.norm(s_poly.max(axis=1) - s_poly.min(axis=1), axis=1)
    tol = 0.05 * s_diam if tolerance is None else np.full(len(s_poly), float(tolerance))
    f_nodes = dolfinx.mesh.entities_to_geometry(vol, tdim - 1, facets)
    boundary = _polygons(vol.geometry.x, f_nodes)

    si, fj = _facing_pairs(surface, boundary, tol)
    e1, e2 = _in_plane_basis(s_poly, surface.normal)
    cell_area, covered, (fans, fan_s, fan_f) = _intersections(
        surface, e1, e2, boundary.vertices, si, fj
    )

    n_v = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    n_s = S.dofmap.index_map.size_local + S.dofmap.index_map.num_ghosts
    if not fans:
        return _untied(n_v, n_s, covered, cell_area)
    # A Gauss rule on each triangle, of the degree its distortion needs.
    s_centre, f_centre, f_normal = surface.centre, boundary.centre, boundary.normal
    rules = _Rules(surf, s_nodes, s_centre, e1, e2, vol, f_nodes, f_centre, f_normal)
    tri, tri_s, tri_f, degree = rules.pick(
        np.concatenate(fans), np.concatenate(fan_s), np.concatenate(fan_f)
    )
    x, w, q_s, q_f = _gauss_points(tri, tri_s, tri_f, degree, s_centre, e1, e2)

    # The volume basis is pulled back into the cell behind the facet: on a curved wall the
    # point lies a little off the facet's plane, and u is extended from the cell, so u and
    # the surface field are compared where they are (a uniform strain is then tied exactly;
    # moving the point onto the facet first was not).
    phi_s, dofs_s = _basis_at(S, q_s, x)
    phi_v, dofs_v = _basis_at(V, facet_cell[q_f], x)

    # Points of one triangle share their cells: sum each run of them before assembling.
    run = np.flatnonzero(np.r_[True, (q_s[1:] != q_s[:-1]) | (q_f[1:] != q_f[:-1])])
    tied = np.unique(q_f)
    return TieOperators(
        P1=_mass(w, run, phi_v, dofs_v, phi_v, dofs_v, (n_v, n_v)),
        P2=_mass(w, run, phi_v, dofs_v, phi_s, dofs_s, (n_v, n_s)),
        P4=_mass(w, run, phi_s, dofs_s, phi_s, dofs_s, (n_s, n_s)),
        covered_area=covered,
        cell_area=cell_area,
        height=_mean_height(vol, facet_cell[tied], f_centre[tied], f_normal[tied]),
        facets=facets[tied],
    )


def matching(ops: TieOperators, vol: dolfinx.mesh.Mesh, surf: dolfinx.mesh.Mesh) -> bool:
    """Whether each tied facet is a cell of the surface (it copies them, or some of them)."""
    if len(ops.facets) != np.count_nonzero(ops.covered_area > 0):
        return False
    wall = np.unique(dolfinx.mesh.entities_to_geometry(vol, vol.topology.dim - 1, ops.facets))
    distance, _ = cKDTree(surf.geometry.x).query(vol.geometry.x[wall])
    return bool(np.all(distance <= 1e-9 * ops.height))


def _untied(n_v: int, n_s: int, covered, cell_area) -> TieOperators:
    """The operators of a surface that touches no facet: empty."""
    empty = sp.csr_array((n_v, n_v))
    P2, P4, none = sp.csr_array((n_v, n_s)), sp.csr_array((n_s, n_s)), np.zeros(0, np.int32)
    return TieOperators(empty, P2, P4, covered, cell_area, 0.0, none)


def _facing_pairs(
    surface: _Polygons, boundary: _Polygons, tol: npt.NDArray[np.float64]
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (surface cell, facet) that may touch.

    Their boxes overlap (the cell's padded by its ``tol``), and the facet is nearly parallel
    to the cell's plane and within ``tol`` of it.
    """
    s_poly, f_poly = surface.vertices, boundary.vertices
    pad = tol[:, None]
    si, fj = _boxes_overlap(
        s_poly.min(axis=1) - pad, s_poly.max(axis=1) + pad, f_poly.min(axis=1), f_poly.max(axis=1)
    )
    s_normal, s_centre = surface.normal[si], surface.centre[si]
    cosine = np.abs(np.einsum("nd,nd->n", s_normal, boundary.normal[fj]))
    distance = np.abs(np.einsum("nd,nd->n", boundary.centre[fj] - s_centre, s_normal))
    keep = (cosine > 0.7) & (distance <= tol[si])
    return si[keep], fj[keep]


def _intersections(surface: _Polygons, e1, e2, f_poly, si, fj) -> tuple:
    """The surface cells' areas, the area of each the facets cover, and the triangles.

    Each pair (si, fj) is intersected in the surface cell's plane (in-plane basis e1, e2);
    the convex intersection is cut into a fan of triangles.

    Returns:
        ``cell_area``, ``covered`` (per surface cell) and ``(triangles, cells, facets)``: lists
        of the fans' triangles ``(n, 3, 2)`` in their cells' planes, and each triangle's
        surface cell and facet.
    """
    s_poly, s_centre = surface.vertices, surface.centre

    def to_plane(points: np.ndarray, s: int) -> np.ndarray:
        d = points - s_centre[s]
        return np.stack([d @ e1[s], d @ e2[s]], axis=1)

    cell_area = np.array([abs(_polygon_area(to_plane(s_poly[s], s))) for s in range(len(s_poly))])
    covered = np.zeros(len(s_poly))
    fans, fan_s, fan_f = [], [], []
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
        n = len(poly) - 2
        fans.append(np.stack([np.broadcast_to(poly[0], (n, 2)), poly[1:-1], poly[2:]], axis=1))
        fan_s.append(np.full(n, s))
        fan_f.append(np.full(n, f))
    return cell_area, covered, (fans, fan_s, fan_f)


def _gauss_points(tri, tri_s, tri_f, degree, s_centre, e1, e2) -> tuple[np.ndarray, ...]:
    """Gauss points in 3-D, their weights, surface cells and facets, triangle after triangle.

    Args:
        tri: Triangles in their surface cells' planes, shape ``(m, 3, 2)``.
        tri_s: Surface cell of each triangle.
        tri_f: Facet of each triangle.
        degree: Gauss degree of each triangle (:meth:`_Rules.pick`).
        s_centre: Origin of each surface cell's plane.
        e1: First in-plane unit vector of each surface cell.
        e2: Second in-plane unit vector of each surface cell.
    """
    qx, qw, q_s, q_f = [], [], [], []
    for deg in np.unique(degree):
        sel = degree == deg
        points, weights = _triangle_rule(int(deg))
        a, b, c = (tri[sel, k, None, :] for k in range(3))
        u, v = b - a, c - a
        tri_area = 0.5 * np.abs(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0])
        p2 = a + points[None, :, :1] * u + points[None, :, 1:] * v  # (m, q, 2)
        s_sel = tri_s[sel, None]
        qx.append(
            (s_centre[s_sel] + p2[..., :1] * e1[s_sel] + p2[..., 1:] * e2[s_sel]).reshape(-1, 3)
        )
        qw.append((2.0 * tri_area * weights[None, :]).ravel())
        q_s.append(np.repeat(tri_s[sel], len(weights)))
        q_f.append(np.repeat(tri_f[sel], len(weights)))
    return tuple(np.concatenate(parts) for parts in (qx, qw, q_s, q_f))


def _basis_at(
    space: dolfinx.fem.FunctionSpace, cells: np.ndarray, x: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Scalar basis values ``(n, dofs)`` and dofs of ``space`` at points ``x``, each in its cell."""
    mesh = space.mesh
    nodes = mesh.geometry.x[mesh.geometry.dofmaps[0][cells]]
    X = pull_back(_coordinate_element(mesh), nodes, x)
    phi = cast(np.ndarray, space.element.basix_element.tabulate(0, X))  # basix: ArrayLike
    return phi[0, :, :, 0], space.dofmap.list[cells]


def _mass(w, run, phi_a, dofs_a, phi_b, dofs_b, shape) -> sp.csr_array:
    """``sum w phi_a phi_b^T``, each ``run``'s points summed first, less :data:`TIE_FLOOR`."""
    vals = np.add.reduceat(np.einsum("n,ni,nj->nij", w, phi_a, phi_b), run, axis=0)
    rows = np.broadcast_to(dofs_a[run, :, None], vals.shape)
    cols = np.broadcast_to(dofs_b[run, None, :], vals.shape)
    P = sp.csr_array(sp.coo_array((vals.ravel(), (rows.ravel(), cols.ravel())), shape=shape))
    P.data[np.abs(P.data) <= TIE_FLOOR * np.abs(P.data).max(initial=0.0)] = 0.0
    P.eliminate_zeros()
    return P


def facet_height(volume: dolfinx.mesh.Mesh, facets: npt.NDArray[np.int32]) -> float:
    """Mean height of the cells behind boundary facets (the ``h`` of ``kappa = h/(E eps)``)."""
    tdim = volume.topology.dim
    volume.topology.create_connectivity(tdim - 1, tdim)
    f2c = volume.topology.connectivity(tdim - 1, tdim)
    poly = _polygons(volume.geometry.x, dolfinx.mesh.entities_to_geometry(volume, tdim - 1, facets))
    cells = f2c.array[f2c.offsets[facets]]
    return _mean_height(volume, cells, poly.centre, poly.normal)


def _mean_height(vol, cells, centres, normals) -> float:
    """Mean distance from each tied facet to the farthest node of the cell behind it."""
    x = vol.geometry.x[vol.geometry.dofmaps[0][cells]]
    height = np.abs(np.einsum("nkd,nd->nk", x - centres[:, None, :], normals)).max(axis=1)
    return float(height.mean())
