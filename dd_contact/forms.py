"""UFL forms of the subdomain part of eq. (9): stiffness K_D, mass M_D and loads r_D.

The penalty terms of (9)-(11) are not UFL forms: they couple independent meshes and are
assembled in :mod:`dd_contact.coupling`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import dolfinx.fem as fem
import numpy as np
import scipy.sparse as sp
import ufl

if TYPE_CHECKING:
    from dd_contact.scene import Material, Subdomain

__all__ = [
    "MASS_KINDS",
    "assemble_load",
    "assemble_mass",
    "assemble_stiffness",
    "load_forms",
    "lump_mass",
    "strain",
    "stress",
]


def strain(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small-strain tensor."""
    return ufl.sym(ufl.grad(u))


def stress(u: ufl.core.expr.Expr, material: Material) -> ufl.core.expr.Expr:
    """Linear isotropic (Hooke) stress."""
    eps = strain(u)
    return 2.0 * material.mu * eps + material.lmbda * ufl.tr(eps) * ufl.Identity(3)


def _to_csr(form: ufl.Form) -> sp.csr_array:
    return sp.csr_array(fem.assemble_matrix(fem.form(form)).to_scipy())


def assemble_stiffness(sub: Subdomain) -> sp.csr_array:
    """K_D = int sigma(u) : eps(du) dx (no boundary conditions applied)."""
    u, du = ufl.TrialFunction(sub.V), ufl.TestFunction(sub.V)
    return _to_csr(ufl.inner(stress(u, sub.material), strain(du)) * ufl.dx)


def assemble_mass(sub: Subdomain) -> sp.csr_array:
    """M_D = int rho u . du dx."""
    u, du = ufl.TrialFunction(sub.V), ufl.TestFunction(sub.V)
    return _to_csr(sub.material.rho * ufl.inner(u, du) * ufl.dx)


#: The mass matrices of ``TransientProblem(mass=...)``.
MASS_KINDS = ("consistent", "lumped", "averaged")


def mass_of_kind(mass: sp.sparray, degree: int, kind: str) -> sp.csr_array:
    """The consistent ``mass`` as ``kind`` of :data:`MASS_KINDS` asks.

    ``"averaged"`` is half consistent, half lumped: the two err on opposite sides in the
    speed of short waves (for linear elements in 1-D the errors cancel to fourth order),
    so a wave front, such as an impact's, overshoots least (docs/contact.md).
    """
    if kind == "consistent":
        return sp.csr_array(mass)
    lumped = lump_mass(mass, degree)
    return lumped if kind == "lumped" else sp.csr_array((lumped + sp.csr_array(mass)) / 2)


def lump_mass(mass: sp.sparray, degree: int) -> sp.csr_array:
    """A diagonal mass matrix with the total mass of ``mass``, every entry > 0 or 0.

    Degree 1 (P1 tetrahedra, Q1 hexahedra): each row's sum (all positive). Degree 2: the
    row sums of P2 tetrahedra are zero or negative at the vertices, so the diagonal is
    scaled instead to the total mass (Hinton, Rock and Zienkiewicz): per cell on affine
    cells, whose element matrices are the reference one times a volume. Rows that are
    zero (massless contact walls) stay zero.
    """
    M = sp.csr_array(mass)
    if degree == 1:
        diagonal = np.asarray(M.sum(axis=1)).ravel()
    else:
        diagonal = M.diagonal() * (M.sum() / M.diagonal().sum())
    return sp.csr_array(sp.diags_array(diagonal))


def load_forms(sub: Subdomain) -> list[fem.Form]:
    """Compiled load forms: int f . du dx and int t . du ds for each traction region."""
    du = ufl.TestFunction(sub.V)
    forms = []
    if sub.body_force is not None:
        forms.append(ufl.inner(sub.body_force, du) * ufl.dx)
    for tags, traction in sub.tractions:
        # One measure per traction: traction regions may overlap, meshtags may not.
        ds = ufl.Measure("ds", domain=sub.mesh, subdomain_data=tags)
        forms.append(ufl.inner(traction, du) * ds(1))
    return [fem.form(f) for f in forms]


def assemble_load(sub: Subdomain, forms: list[fem.Form] | None = None) -> np.ndarray:
    """r_D on the owned dofs, from :func:`load_forms` (compiled now if not given)."""
    load = np.zeros(sub.num_dofs)
    for form in load_forms(sub) if forms is None else forms:
        load += fem.assemble_vector(form).array[: sub.num_dofs]
    return load
