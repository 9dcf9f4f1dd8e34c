"""What both models share: their steel and the facet tags of their block meshes."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.subdomains import Material

__all__ = ["FACE_TAGS", "STEEL", "block_tags"]

#: Structural steel [Pa, -, kg/m^3].
STEEL = Material(210e9, 0.3, 7850.0)
#: Facet tags of a block mesh: a hole wall and the six sides of its bounding box.
FACE_TAGS = {"hole": 1, "x0": 2, "x1": 3, "y0": 4, "y1": 5, "z0": 6, "z1": 7}


def block_tags(
    mesh: dolfinx.mesh.Mesh,
    lower: Sequence[float],
    upper: Sequence[float],
    hole: tuple[Sequence[float], float] | None = None,
) -> dolfinx.mesh.MeshTags:
    """:data:`FACE_TAGS` of the boundary of a block ``[lower, upper]``.

    With ``hole = ((x, y), radius)``, the wall of a hole about z (its nodes on the circle).
    """
    tol = 1e-9 * max(np.subtract(upper, lower))
    # a locator of each tag (Callable[..., Any]: mypy infers no lambda with defaults for
    # face_tags's Callable[[np.ndarray], np.ndarray])
    regions: dict[int, Callable[..., Any]] = {}
    if hole is not None:
        (cx, cy), radius = hole
        regions[FACE_TAGS["hole"]] = lambda x: np.hypot(x[0] - cx, x[1] - cy) < radius * 1.001
    for axis, name in enumerate("xyz"):
        regions[FACE_TAGS[f"{name}0"]] = lambda x, a=axis: np.abs(x[a] - lower[a]) < tol
        regions[FACE_TAGS[f"{name}1"]] = lambda x, a=axis: np.abs(x[a] - upper[a]) < tol
    return meshes.face_tags(mesh, regions)
