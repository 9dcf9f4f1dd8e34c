"""What the solvers' symbolic analysis finds in a scene, before anything is factorised.

:func:`scene_structure` gives the statistics the timing model prices (MUMPS's analysis of
every sparse matrix an algorithm factorises, the couplings and the contact regions);
:class:`Candidates` analyses the solvers ``algorithm="auto"`` chooses between and keeps
their parts, so that the chosen solver is built from what was analysed, not analysed
twice. Pricing is :mod:`dd_contact.timing`'s: it never builds a solver.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from mpi4py import MPI

from dd_contact.blocks import BlockSystem, ContactRegion
from dd_contact.solvers.engine import surface_structure
from dd_contact.solvers.full import MonolithicSolver, monolithic_statistics
from dd_contact.solvers.linalg import SparseStatistics
from dd_contact.solvers.schedule import FullSchedule, Schedule
from dd_contact.solvers.subdomains import owned_subdomains, subdomain_statistics

__all__ = ["Candidates", "SceneStructure", "scene_structure"]


@dataclass
class SceneStructure:
    """What the plans need to know about a scene's (constrained) block system.

    Attributes:
        sizes: Size of every block.
        regions: Contact region -> the block it acts on.
        subdomains: Per subdomain, MUMPS's analysis of the matrix the orders factorise.
        layouts: Per subdomain, ``(surface block, tied dofs)`` of each of its couplings.
        base_pairs: Surface block pairs with a matrix of their own.
        full: MUMPS's analysis of FULL's matrix (``None``: FULL not considered).
        condensation: How the orders condense a subdomain (``"schur"``, ``"multi-rhs"``).
        plans: What pricing made of it, per algorithm (:func:`dd_contact.timing.plan`).
    """

    sizes: dict[str, int]
    regions: Mapping[str, str | tuple[str, ...]]
    subdomains: dict[str, SparseStatistics]
    layouts: dict[str, list]
    base_pairs: set
    full: SparseStatistics | None
    condensation: str = "schur"
    plans: dict = field(default_factory=dict, repr=False, compare=False)

    def schedule(self, algorithm: str) -> Schedule | FullSchedule:
        """The schedule ``algorithm`` follows on this scene."""
        if algorithm == "FULL":
            return FullSchedule(sum(self.sizes.values()), self.regions)
        return Schedule(
            algorithm, self.sizes, self.layouts, self.base_pairs, self.regions, self.condensation
        )


def _structure(comm, system, contacts, condensation, subdomains, full) -> SceneStructure:
    """Collective: the structure from the subdomains' analysis (and FULL's, if given)."""
    stats, layouts = {}, {}
    for block, (analysed, layout) in subdomains.items():
        stats[block], layouts[block] = analysed, layout
    pairs, regions = surface_structure(comm, system, contacts)
    return SceneStructure(dict(system.sizes), regions, stats, layouts, pairs, full, condensation)


def scene_structure(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    condensation: str = "schur",
    full: bool = True,
    orders: bool = True,
) -> SceneStructure:
    """Collective: analyse the matrices each algorithm would factorise (no factorisation).

    Args:
        comm: Communicator of the problem.
        system: This rank's pieces of the constrained block system.
        contacts: This rank's contact regions.
        condensation: As for :class:`dd_contact.solvers.engine.BlockEliminationSolver`.
        full: Analyse FULL's matrix.
        orders: Analyse the subdomain matrices of the decomposition orders.
    """
    subdomains = subdomain_statistics(comm, system, contacts, condensation) if orders else {}
    full_stats = monolithic_statistics(comm, system, contacts) if full else None
    return _structure(comm, system, contacts, condensation, subdomains, full_stats)


class Candidates:
    """Collective: the solvers ``auto`` chooses between, analysed, their parts kept.

    Args:
        comm: Communicator of the problem.
        system: This rank's pieces of the constrained block system.
        contacts: This rank's contact regions.
        condensation: How the orders condense a subdomain.
        log: The work log the kept parts record into.
    """

    def __init__(self, comm, system, contacts: Sequence[ContactRegion], condensation, log):
        self.comm, self.system, self.contacts = comm, system, list(contacts)
        self.condensation, self.log = condensation, log
        #: This rank's subdomains, built and analysed (:meth:`analyse_orders`).
        self.subdomains: dict | None = None
        #: FULL's solver, its matrix assembled and analysed (:meth:`analyse_full`).
        self.full: MonolithicSolver | None = None

    def analyse_orders(self) -> SceneStructure:
        """Build this rank's subdomains (kept) and the structure of their analysis."""
        comm, system, contacts = self.comm, self.system, self.contacts
        self.subdomains = owned_subdomains(comm, system, contacts, self.log, self.condensation)
        analysed = subdomain_statistics(comm, system, contacts, self.condensation, self.subdomains)
        return _structure(comm, system, contacts, self.condensation, analysed, None)

    def analyse_full(self, structure: SceneStructure | None = None) -> SceneStructure:
        """Build FULL's solver (kept) and add its analysis to ``structure``."""
        self.full = MonolithicSolver(self.comm, self.system, self.contacts, self.log)
        analysed = self.full.analyse()
        if structure is None:
            comm, system, contacts = self.comm, self.system, self.contacts
            return _structure(comm, system, contacts, self.condensation, {}, analysed)
        structure.full = analysed
        return structure

    def take(self, algorithm: str):
        """The parts ``algorithm``'s solver is built from (``None``: none); frees the rest."""
        keep = self.full if algorithm == "FULL" else self.subdomains
        if algorithm != "FULL" and self.full is not None:
            self.full.destroy()
        if algorithm == "FULL":
            for sub in (self.subdomains or {}).values():
                sub.destroy()
        self.subdomains, self.full = None, None
        return keep
