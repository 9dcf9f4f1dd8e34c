"""The elimination schedule: what each algorithm factorises and substitutes, and when.

This module is the one description of the algorithms (method.md section 5). The engine
(:mod:`dd_contact.solvers.engine`) executes it, :mod:`dd_contact.timing` prices it with
measured rates, and :mod:`dd_contact.flops` counts it with the paper's kernels. It knows
sizes, block kinds and couplings only: numpy, no PETSc, no dolfinx.
"""

from __future__ import annotations

__all__ = [
    "ALGORITHMS",
    "CONDENSATIONS",
    "ORDERS",
    "fitting_algorithms",
]

#: Surface levels eliminated after the subdomains, first to last, for every order. The name
#: lists the unknowns in the order they are obtained, i.e. the levels read backwards.
ORDERS: dict[str, tuple[str, ...]] = {
    "v-w-u": ("w", "v"),
    "w-v-u": ("v", "w"),
    "w-u": ("w",),
    "v-u": ("v",),
}

#: Every algorithm, baseline first: FULL factorises the whole system as one matrix.
ALGORITHMS: tuple[str, ...] = ("FULL", *ORDERS)

#: Ways to form a subdomain's condensed operator ``C^T K^-1 C``: MUMPS's Schur complement
#: within the factorisation, or one substitution per coupling column.
CONDENSATIONS = ("schur", "multi-rhs")


def fitting_algorithms(
    has_interface: bool, has_contact_interfaces: bool, variants: bool = False
) -> tuple[str, ...]:
    """The algorithms that fit a scene: ``v`` needs an interface, ``w`` contact interfaces.

    Args:
        has_interface: The scene has an interface mesh (unknowns ``v``).
        has_contact_interfaces: The scene has contact-interface meshes (unknowns ``w``).
        variants: ``False``: what runs on the scene as built, i.e. FULL and the orders whose
            levels are exactly the scene's surface unknowns. ``True``: the paper's
            operation-count reading, where each algorithm runs on its own variant of the
            model (w-u merges the subdomains, dropping the interface; v-u puts contact on
            the subdomain's boundary, dropping the contact interfaces), i.e. FULL and the
            orders whose levels the scene has.

    Returns:
        The fitting algorithms in :data:`ALGORITHMS` order.
    """
    kinds = {kind for kind, has in (("v", has_interface), ("w", has_contact_interfaces)) if has}
    fit = [
        name
        for name, levels in ORDERS.items()
        if (set(levels) <= kinds if variants else set(levels) == kinds)
    ]
    return ("FULL", *fit)
