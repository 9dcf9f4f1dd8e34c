"""From a dolfinx :class:`~dd_contact.scene.Scene` to the sizes the operation-count model needs.

The model (:mod:`dd_contact.paper.flops.model`) works on sizes alone; this bridge reads them off a
scene as built: dofs and half-bandwidths of the subdomains in their dolfinx numbering, the
interface dofs each subdomain is tied to (the non-zero columns of its tie operator), the
contact regions, and, from a run, the numbers of steps and contact state changes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from dd_contact.coupling import tie_operators
from dd_contact.paper.flops.model import ContactCounts, MeshCounts, SceneSizes, SubdomainCounts
from dd_contact.scene import ContactBoundary, Scene
from dd_contact.subdomains import Subdomain

__all__ = ["half_bandwidth_of", "sizes_from_scene"]


def half_bandwidth_of(sub: Subdomain) -> int:
    """Half-bandwidth (diagonal counted) of a subdomain's matrix in dolfinx's dof numbering.

    Nodes ``a < b`` of one cell couple the dofs ``3a`` and ``3b + 2``: ``B = 3 (b - a) + 3``.
    """
    cells = sub.V.dofmap.list
    span = int(np.max(cells.max(axis=1) - cells.min(axis=1))) if cells.size else 0
    return 3 * span + 3


def sizes_from_scene(
    scene: Scene,
    n_steps: int = 1,
    changes: Mapping[str, int] | None = None,
    whole: MeshCounts | None = None,
) -> SceneSizes:
    """The model's sizes of a scene (block names as in the solvers' work log).

    Args:
        scene: The scene (every rank holds every mesh, so this is rank-local).
        n_steps: ``N_TS``.
        changes: Contact state changes as :attr:`TransientProblem.changes` gives them
            (``"gamma"`` and one count per contact region); default none.
        whole: The undecomposed model as one banded matrix (FULL and w-u). Default: all the
            scene's dofs with the largest subdomain half-bandwidth, a lower bound of the real
            one; with one subdomain, that subdomain (the scene is then its own whole).

    Returns:
        Sizes with subdomains ``u:<name>``, contacts ``w:<name>`` and interface
        ``v:<name>``, as the solvers name their blocks.
    """
    changes = dict(changes or {})
    iface = scene.interface
    subdomains = []
    for sub in scene.subdomains:
        tied = 0
        if iface is not None and any(sub is t for t in iface.subdomains):
            P2 = tie_operators(sub.V, iface.V, tolerance=iface.tolerance).P2
            tied = 3 * len(np.unique(P2.tocsc().nonzero()[1]))
        subdomains.append(SubdomainCounts(sub.block, sub.num_dofs, half_bandwidth_of(sub), tied))
    contacts = [
        ContactCounts(c.block, c.num_dofs, scene.index(c.subdomain), changes.get(c.name, 0))
        for c in scene.contacts
    ]
    if whole is None:
        total = sum(s.dofs for s in subdomains) + (iface.num_dofs if iface is not None else 0)
        total += sum(c.num_dofs for c in scene.contacts if not isinstance(c, ContactBoundary))
        bandwidth = max(s.half_bandwidth for s in subdomains)
        whole = MeshCounts("FULL", total, bandwidth)
        if len(subdomains) == 1:
            whole = MeshCounts(subdomains[0].name, subdomains[0].dofs, bandwidth)
    return SceneSizes(
        subdomains=tuple(subdomains),
        contacts=tuple(contacts),
        interface_dofs=iface.num_dofs if iface is not None else None,
        n_steps=n_steps,
        gamma=changes.get("gamma", 0),
        whole=whole,
        interface_name=iface.block if iface is not None else "Gamma_I",
    )
