"""Post-processing: cell stresses, von Mises stress, boundary averages, energy."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import ufl

from dd_contact.assembly import ContactZone, Model
from dd_contact.forms import stress
from dd_contact.scene import Subdomain, Where

__all__ = ["boundary_average", "cell_stress", "energy", "von_mises"]


def cell_stress(sub: Subdomain) -> np.ndarray:
    """Stress at each cell's midpoint, shape ``(num_cells, 3, 3)``."""
    Q = fem.functionspace(sub.mesh, ("DG", 0, (3, 3)))
    sigma = fem.Function(Q)
    sigma.interpolate(fem.Expression(stress(sub.u, sub.material), Q.element.interpolation_points))
    return sigma.x.array.reshape(-1, 3, 3)


def von_mises(sub: Subdomain) -> fem.Function:
    """Cell-wise von Mises stress as a DG0 function (for plots and output)."""
    s = cell_stress(sub)
    dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3.0
    W = fem.functionspace(sub.mesh, ("DG", 0))
    out = fem.Function(W, name=f"von_mises_{sub.name}")
    out.x.array[:] = np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))
    return out


def boundary_average(sub: Subdomain, where: Where) -> np.ndarray:
    """Area-averaged displacement over a boundary region of a subdomain."""
    facets = sub.locate_facets(where)
    tags = dolfinx.mesh.meshtags(sub.mesh, 2, facets, np.ones_like(facets))
    ds = ufl.Measure("ds", domain=sub.mesh, subdomain_data=tags)
    area = fem.assemble_scalar(fem.form(fem.Constant(sub.mesh, 1.0) * ds(1)))
    return np.array([fem.assemble_scalar(fem.form(sub.u[i] * ds(1))) / area for i in range(3)])


def energy(
    model: Model,
    x: Mapping[str, np.ndarray],
    velocities: Mapping[str, np.ndarray],
    zones: Sequence[ContactZone],
) -> dict[str, float]:
    """This rank's part of the kinetic, elastic (with ties) and contact-penalty energy.

    Sum the parts over the ranks for the model's energy
    (:meth:`dd_contact.TransientProblem.energy` does).

    Args:
        model: This rank's assembled pieces (stiffness and tie blocks, mass matrices).
        x: Every block's displacement (``u:``, ``v:`` and ``w:`` blocks).
        velocities: Velocity of every owned subdomain block.
        zones: This rank's contact zones (their surface displacement is read from the scene).

    Returns:
        ``"kinetic"``, ``"elastic"`` and ``"contact"``.
    """
    elastic = 0.0
    for (rb, cb), A in model.system.matrices.items():
        factor = 0.5 if rb == cb else 1.0
        elastic += factor * float(x[rb] @ (A @ x[cb]))
    for tie in model.system.stiff_ties:  # the ties' penalty above KAPPA_SPLIT
        elastic += 0.5 * tie.sigma * sum(float(x[b] @ f) for b, f in tie.jump(x).items())
    kinetic = 0.0
    for block, v in velocities.items():
        if block in model.mass:
            kinetic += 0.5 * float(v @ (model.mass[block] @ v))
    contact = float(sum(z.operator.energy(z.contact.w.x.array) for z in zones))
    return {"kinetic": kinetic, "elastic": elastic, "contact": contact}
