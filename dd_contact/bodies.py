"""Bodies and their rigid motions: what must hold a quasi-static body that has too few supports.

Subdomains tied through the interface move together as one body. The six rigid motions of a
body that its Dirichlet conditions do not stop must be stopped by contact, or the static
problem is singular (:meth:`dd_contact.scene.Scene.check_static_supports` and the check of
the contact iteration before every solve).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from dd_contact.subdomains import Subdomain

__all__ = ["RIGID_MOTIONS", "Body", "rigid_motion_rows"]


#: Names of the six rigid-body motions, in the order of :func:`rigid_motion_rows`.
RIGID_MOTIONS = (
    "translation x",
    "translation y",
    "translation z",
    "rotation about x",
    "rotation about y",
    "rotation about z",
)


def rigid_motion_rows(r: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """How the six rigid motions move points at ``r`` (from the centre) along ``direction``.

    Row i is ``[d, r x d]``: the motion ``(t, theta)`` moves the point by
    ``t + theta x r``, whose component along d is ``d . t + theta . (r x d)``.
    """
    return np.hstack([direction, np.cross(r, direction)])


@dataclass(frozen=True)
class Body:
    """Subdomains that move together, and the rigid motions no Dirichlet condition stops.

    Attributes:
        subdomains: The subdomains.
        centre: Centre of the rotations (mean of the nodes).
        size: Length scale of the body (its bounding-box diagonal): rotations are scaled by
            it so that all six motions are measured alike.
        free: Basis of the free rigid motions (6 x m, orthonormal columns; m = 0: held).
    """

    subdomains: tuple
    centre: np.ndarray
    size: float
    free: np.ndarray

    @classmethod
    def of(cls, group: Sequence[Subdomain]) -> Body:
        """The body of ``group`` and the rigid motions its Dirichlet conditions leave free."""
        x = np.concatenate([s.mesh.geometry.x for s in group])
        centre = x.mean(axis=0)
        size = max(float(np.linalg.norm(x.max(axis=0) - x.min(axis=0))), 1e-300)
        rows = []
        for sub in group:
            dofs, _ = sub.dirichlet
            r = (sub.V.tabulate_dof_coordinates()[dofs // 3] - centre) / size
            rows.append(rigid_motion_rows(r, np.eye(3)[dofs % 3]))
        return cls(tuple(group), centre, size, _null_space(np.concatenate(rows)))

    def describe(self) -> str:
        """The free motions in words, e.g. ``"1 free rigid motion: translation x"``."""
        m = self.free.shape[1]
        if m == 0:
            return "no free rigid motion"
        named = [RIGID_MOTIONS[i] for i in range(6) if np.abs(self.free[i]).max() > 0.5]
        what = ", ".join(named) if len(named) == m else "combined translations and rotations"
        return f"{m} free rigid motion{'s' if m > 1 else ''}: {what}"


def _null_space(rows: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the motions that ``rows`` do not constrain (6 x m)."""
    if len(rows) == 0:
        return np.eye(6)
    _, s, vt = np.linalg.svd(rows, full_matrices=True)
    rank = int(np.sum(s > 1e-10 * s.max())) if s.size else 0
    return vt[rank:].T
