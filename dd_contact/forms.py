"""UFL forms of the subdomain part of eq. (9): stiffness K_D, mass M_D and loads r_D.

The penalty terms of (9)-(11) are not UFL forms: they couple independent meshes and are
assembled in :mod:`dd_contact.coupling`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import dolfinx.fem as fem
import numpy as np
import scipy.sparse as sp
import ufl

if TYPE_CHECKING:
    from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "MASS_KINDS",
    "SubdomainLoad",
    "assemble_load",
    "assemble_mass",
    "assemble_stiffness",
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


def _load_terms(sub: Subdomain) -> list[tuple[ufl.core.expr.Expr, ufl.Measure]]:
    """(expression, measure) of each load: the body force over dx, each traction over ds."""
    terms = []
    if sub.body_force is not None:
        terms.append((sub.body_force, ufl.dx(domain=sub.mesh)))
    for tags, traction in sub.tractions:
        # One measure per traction: traction regions may overlap, meshtags may not.
        terms.append((traction, ufl.Measure("ds", domain=sub.mesh, subdomain_data=tags)(1)))
    return terms


def _scaled_field(expr: ufl.core.expr.Expr) -> tuple[fem.Constant, ufl.core.expr.Expr] | None:
    """``(a, field)`` if ``expr`` is a scalar Constant times a vector field, else None.

    UFL writes ``a * field`` as ``ComponentTensor(Product(a, field[i]), i)``.
    """
    if not isinstance(expr, ufl.classes.ComponentTensor):
        return None
    product, index = expr.ufl_operands
    if not isinstance(product, ufl.classes.Product):
        return None
    for scale, other in (product.ufl_operands, product.ufl_operands[::-1]):
        if (
            isinstance(scale, fem.Constant)
            and scale.ufl_shape == ()
            and isinstance(other, ufl.classes.Indexed)
            and other.ufl_operands[1] == index
        ):
            return scale, other.ufl_operands[0]
    return None


def _packed(vector: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
    """``(indices, values)`` of a vector's nonzeros, or ``(None, vector)`` if mostly nonzero.

    A traction's load is nonzero on its surface only.
    """
    nonzero = np.flatnonzero(vector)
    if 2 * len(nonzero) > len(vector):
        return None, vector
    return nonzero, vector[nonzero]


class _UserData:
    """The user's Functions and Constants a cached load was assembled with, as they were.

    A cached load is stale once the user changes one of them between solves; :meth:`changed`
    says so (a comparison of values, far cheaper than the assembly it saves).
    """

    def __init__(self, expr, skip: set[int]):
        self._objects = [
            obj
            for obj in (
                *ufl.algorithms.analysis.extract_coefficients(expr),
                *ufl.algorithms.analysis.extract_constants(expr),
            )
            if id(obj) not in skip
        ]
        self._values = self._now()

    @property
    def watches(self) -> bool:
        """Whether there is any of the user's data to watch."""
        return bool(self._objects)

    def _now(self) -> list[np.ndarray]:
        return [np.array(o.x.array if hasattr(o, "x") else o.value) for o in self._objects]

    def changed(self) -> bool:
        """Whether any value differs from the last :meth:`changed` or construction."""
        now = self._now()
        if all(np.array_equal(a, b) for a, b in zip(now, self._values, strict=True)):
            return False
        self._values = now
        return True


class SubdomainLoad:
    """The load vector r_D(t) of one subdomain, each term assembled as seldom as it allows.

    A term (the body force, each traction) is linear in the load data, so:

    * a vector ``fem.Constant`` c (a 3-vector, or a callable ``t -> 3-vector`` that
      ``Subdomain.set_time`` evaluates into one): the load of each unit vector is assembled
      once, ``r = sum_i c_i r_i`` with c's value at the call;
    * a scalar ``fem.Constant`` a times a field that uses none of
      ``Subdomain.time_constants`` (``amplitude=``, or ``Subdomain.time * field``): the
      field's load is assembled once and scaled by a's value;
    * a term that uses none of ``time_constants``: assembled once;
    * any other (a general UFL load of :attr:`Subdomain.time`): assembled at every call.

    A cached term is assembled again when a Function or Constant of the user's in it has
    changed since (its values are compared at every call). :attr:`assemblies` counts
    dolfinx's vector assemblies.

    Args:
        sub: The subdomain; set its time (``Subdomain.set_time``) before each call.
    """

    def __init__(self, sub: Subdomain):
        self.num_dofs = sub.num_dofs
        self.assemblies = 0
        du = ufl.TestFunction(sub.V)
        changing = {id(c) for c in sub.time_constants}

        def uses_time(expr) -> bool:
            constants = ufl.algorithms.analysis.extract_constants(expr)
            return any(id(c) in changing for c in constants)

        #: (form, the user's data in it) of the terms that do not change with time
        self._fixed_terms: list[tuple[fem.Form, _UserData]] = []
        #: [Constant, forms, packed load of each, the user's data]: r += value[k] * load[k]
        self._scaled: list[list] = []
        self._general: list[fem.Form] = []  # assembled at every call
        for expr, measure in _load_terms(sub):
            scaled = _scaled_field(expr)
            if isinstance(expr, fem.Constant):
                parts = [fem.form(du[i] * measure) for i in range(3)]
                self._scaled.append([expr, parts, None, _UserData(expr, {id(expr)})])
            elif scaled is not None and not uses_time(scaled[1]):
                part = fem.form(ufl.inner(scaled[1], du) * measure)
                self._scaled.append([scaled[0], [part], None, _UserData(scaled[1], set())])
            elif uses_time(expr):
                self._general.append(fem.form(ufl.inner(expr, du) * measure))
            else:
                form = fem.form(ufl.inner(expr, du) * measure)
                self._fixed_terms.append((form, _UserData(expr, set())))
        for term in self._scaled:
            term[2] = [_packed(self._assemble(f)) for f in term[1]]
        self._fixed = self._sum_fixed()
        #: Whether the load is the same at every time (and no user data can change it).
        watched = any(data.watches for _, data in self._fixed_terms)
        self.constant = not (self._scaled or self._general or watched)

    def _assemble(self, form: fem.Form) -> np.ndarray:
        self.assemblies += 1
        return fem.assemble_vector(form).array[: self.num_dofs].copy()

    def patterns(self) -> list[np.ndarray]:
        """The load's spatial patterns: every load it gives is a combination of these.

        The fixed part, and each scaled term's assembled load per component; a general
        term (assembled at every call) contributes its load now (a reduced subdomain is then
        exact for that load only).
        """
        out = [self._fixed] if np.any(self._fixed) else []
        for _, _, packed, _ in self._scaled:
            for index, values in packed:
                vector = values.copy() if index is None else np.zeros(self.num_dofs)
                if index is not None:
                    vector[index] = values
                out.append(vector)
        out += [self._assemble(form) for form in self._general]
        return out

    def _sum_fixed(self) -> np.ndarray:
        return sum((self._assemble(f) for f, _ in self._fixed_terms), np.zeros(self.num_dofs))

    def _refresh(self) -> None:
        """Assemble again the cached terms whose user data changed since."""
        if any([data.changed() for _, data in self._fixed_terms]):  # every snapshot renewed
            self._fixed = self._sum_fixed()
        for term in self._scaled:
            if term[3].changed():
                term[2] = [_packed(self._assemble(f)) for f in term[1]]

    def combined(self, project: Callable[[np.ndarray], list]) -> list[np.ndarray] | None:
        """``project(r_D)`` now, as the sum of each cached part's projection (kept).

        ``project`` is linear (a reduced subdomain's ``T^T r`` and its supports' rows): a
        part is projected once per assembly, a step then only sums. ``None`` with a general
        term (its load is assembled at every call).
        """
        if self._general:
            return None
        self._refresh()
        kept: dict[int, tuple] = getattr(self, "_projected", {})
        self._projected: dict[int, tuple] = {}
        parts = [(1.0, self._fixed)] + [
            (value, part)
            for constant, _, packed, _ in self._scaled
            for value, part in zip(np.ravel(constant.value), packed, strict=True)
        ]
        out: list[np.ndarray] | None = None
        for value, part in parts:
            key = id(part)
            if key not in kept or kept[key][0] is not part:  # a new assembly: projected again
                whole = part if isinstance(part, np.ndarray) else self._unpacked(part)
                kept[key] = (part, [np.asarray(p, dtype=float) for p in project(whole)])
            self._projected[key] = kept[key]
            terms = [value * p for p in kept[key][1]]
            out = terms if out is None else [a + b for a, b in zip(out, terms, strict=True)]
        assert out is not None  # the fixed part at least
        return out

    def reduced(self, basis) -> list[np.ndarray]:
        """``[T^T r_D, r_D on the supports]`` of a reduced subdomain's ``basis`` now."""

        def project(v: np.ndarray) -> list[np.ndarray]:
            return [basis.project_load(v), v[basis.fixed]]

        return self.combined(project) or project(self())

    def _unpacked(self, packed: tuple) -> np.ndarray:
        index, values = packed
        if index is None:
            return values
        vector = np.zeros(self.num_dofs)
        vector[index] = values
        return vector

    def __call__(self) -> np.ndarray:
        """r_D at the subdomain's current time: a new array (the fixed part itself if constant)."""
        self._refresh()
        if self.constant:
            return self._fixed
        load = self._fixed.copy()
        for constant, _, packed, _ in self._scaled:
            for value, (index, values) in zip(np.ravel(constant.value), packed, strict=True):
                if value == 0.0:
                    continue
                if index is None:
                    load += value * values
                else:
                    load[index] += value * values
        for form in self._general:
            load += self._assemble(form)
        return load


def assemble_load(sub: Subdomain) -> np.ndarray:
    """r_D on the owned dofs at the subdomain's current time, every term assembled now."""
    du = ufl.TestFunction(sub.V)
    load = np.zeros(sub.num_dofs)
    for expr, measure in _load_terms(sub):
        load += fem.assemble_vector(fem.form(ufl.inner(expr, du) * measure)).array[: sub.num_dofs]
    return load
