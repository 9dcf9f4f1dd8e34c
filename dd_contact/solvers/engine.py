"""The block-elimination engine: executes the schedule of an order.

System (14) has three kinds of unknowns: subdomain displacements ``u:`` (large, sparse),
the interface displacement ``v:`` and contact-interface displacements ``w:`` (small). The
engine condenses the ``u`` blocks first, each with its own sparse factorisation (MUMPS
Cholesky) made once for the whole run, which leaves a dense SPD system on the surface
blocks (A14-A18)::

    S = K_surface - sum_k C_k^T K_hat_k^-1 C_k,     g = b_surface - sum_k C_k^T u_hat_k

where ``C_k`` are the non-zero coupling columns of subdomain k (``-P_DI2``, ``-P_CI2``). The
order's :class:`~dd_contact.solvers.schedule.Schedule` says which surface blocks are then
eliminated together (its groups, each a dense LAPACK Cholesky factorisation) and which of
them to re-factorise and re-solve after a change; the engine only observes what changed (a
contact matrix, a subdomain's condensation, a right-hand side) and does what the schedule
says. Contact on a subdomain's own boundary (``ContactBoundary``, order ``"v-u"``) makes
that subdomain's matrix change: it is then re-factorised and re-condensed on each of its
contact changes.

Parallel: ranks own whole subdomains (the owner of ``u:<name>`` factorises, condenses and
back-substitutes it, and its u never leaves that rank here); the dense surface system, small
by construction, is solved on rank 0. Per solve the ranks exchange surface vectors only: each
rank's part of the surface right-hand side goes to rank 0 (one gather, with a condensation or
contact matrix only after it changed) and the surface solution comes back (one buffer
broadcast).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockSystem, ContactRegion, refuse_unsolvable
from dd_contact.parallel import ROOT, allgathered, any_rank, bcast_array, gather_to_root, gathered
from dd_contact.solvers.linalg import dense_threads
from dd_contact.solvers.lowrank import LowRankSurface
from dd_contact.solvers.pointwise import PointwiseSurface
from dd_contact.solvers.reduced import reduced_subdomains
from dd_contact.solvers.schedule import (
    Schedule,
)
from dd_contact.solvers.stuck import StuckSurface
from dd_contact.solvers.subdomains import (
    SubdomainSolver,
    owned_subdomains,
)
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "BlockEliminationSolver",
    "order_schedule",
    "surface_structure",
]


def order_schedule(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    order: str,
    condensation: str,
    layouts: dict[Block, list],
) -> Schedule:
    """Collective: the schedule of ``order`` for this block system (same on every rank).

    Args:
        comm: Communicator.
        system: This rank's pieces of the (constrained) block system.
        contacts: This rank's contact regions.
        order: One of the orders.
        condensation: How subdomains are condensed.
        layouts: This rank's subdomain layouts (:func:`coupling_layout`).
    """
    pairs, regions = surface_structure(comm, system, contacts)
    return Schedule(order, system.sizes, gathered(comm, layouts), pairs, regions, condensation)


def surface_structure(
    comm: MPI.Comm, system: BlockSystem, contacts: Sequence[ContactRegion]
) -> tuple[set[tuple[Block, Block]], dict[str, tuple[Block, ...]]]:
    """Collective: what every rank knows of the surface, gathered.

    Returns the surface block pairs with a matrix of their own (both orientations) and the
    block each contact region acts on.
    """
    pairs = {(r, c) for r, c, _ in system.all_blocks() if r.kind != "u" != c.kind}
    pairs = {p for part in allgathered(comm, pairs) for p in part}
    regions = gathered(comm, {region.name: region.blocks for region in contacts})
    return pairs, regions


# -- the solver ---------------------------------------------------------------------------
def _pointed(region: ContactRegion) -> bool:
    """Whether a region's changes reach the surface point by point (a frictionless pair)."""
    return (
        region.points is not None and region.symmetric and all(b.kind != "u" for b in region.blocks)
    )


def _unsymmetric(contacts: Sequence[ContactRegion]) -> list[Block]:
    """The blocks of the regions whose contact matrix is unsymmetric (friction)."""
    return [b for region in contacts if not region.symmetric for b in region.blocks]


class BlockEliminationSolver:
    """Solves system (14) by block elimination in a given order.

    Same protocol as :class:`dd_contact.solvers.MonolithicSolver`: :meth:`set_contact` for
    each contact region, :meth:`solve` during the contact iteration (returns the blocks the
    contact check needs), :meth:`finish` once the contact state has settled (returns every
    block on every rank).

    Args:
        comm: Communicator; ranks own whole subdomains.
        system: This rank's pieces of the (constrained) block system.
        contacts: This rank's contact regions.
        log: Where factorisations and solves are recorded.
        order: One of :data:`~dd_contact.solvers.schedule.ORDERS`.
        condensation: How ``C^T K^-1 C`` is formed: ``"schur"`` (default: MUMPS computes the
            Schur complement of ``[[K, C], [C^T, 0]]`` within the factorisation, the faster;
            docs/solvers.md) or ``"multi-rhs"`` (one substitution per coupling column, in
            blocks of 256, as the paper counts it).
        subdomains: This rank's subdomains built (and maybe analysed) already, with this
            ``log`` and ``condensation`` (:func:`owned_subdomains`; ``algorithm="auto"``
            reuses the ones it analysed); by default built here.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        system: BlockSystem,
        contacts: Sequence[ContactRegion],
        log: WorkLog,
        order: str,
        condensation: str = "schur",
        subdomains: Mapping[Block, SubdomainSolver] | None = None,
    ):
        refuse_unsolvable(contacts)
        self.comm, self.system, self.log, self.order = comm, system, log, order
        self._regions = {region.name: region for region in contacts}
        if subdomains is None:
            subdomains = owned_subdomains(comm, system, contacts, log, condensation)
            subdomains.update(reduced_subdomains(comm, system, log))  # type: ignore[arg-type]
        self.subdomains: Mapping[Block, SubdomainSolver] = subdomains
        layouts = {b: sub.layout for b, sub in self.subdomains.items()}
        self.schedule = order_schedule(comm, system, contacts, order, condensation, layouts)
        self._needed_u = set(self.schedule.needed_u) & set(self.subdomains)
        mine = [(r, c, A) for (r, c), A in system.matrices.items() if r.kind != "u" != c.kind]
        # the surface pairs' point rows travel with them (one meeting of the ranks)
        points = [(r.name, r.parts, r.points) for r in contacts if _pointed(r)]
        sent: dict[str, list[Any]] = {"matrices": mine, "points": points}  # not a solve's tuple
        pieces = gather_to_root(comm, sent)
        self.surface: LowRankSurface | None = None
        # a subdomain with contact on its own boundary is re-factorised: it sends a new Z
        recondensed = any_rank(comm, any(r.block.kind == "u" for r in contacts))
        unsymmetric = {b for part in allgathered(comm, _unsymmetric(contacts)) for b in part}
        unstuck = any_rank(comm, any(not r.symmetric and r.stuck is None for r in contacts))
        #: Friction's surface factorised with every point sticking, the slip corrected
        self._stuck = bool(unsymmetric) and not unstuck and LowRankSurface.enabled
        if comm.rank == ROOT:
            assert pieces is not None  # gathered here
            # friction: factorised with every point sticking; else corrected point by point
            kind = StuckSurface if self._stuck else PointwiseSurface
            self.surface = kind(self.schedule, log, recondensed, unsymmetric)
            for part in pieces:
                for r, c, A in part["matrices"]:
                    self.surface.add_base(r, c, A)
                for name, parts, F in part["points"]:
                    self.surface.add_points(name, parts, F)
        #: Latest contact matrix of each region, by the block pairs it fills (and its stuck one).
        self._contact: dict[str, dict[tuple[Block, Block], sp.csr_array]] = {}
        self._stuck_contact: dict[str, dict[tuple[Block, Block], sp.csr_array]] = {}
        self._pending_contact: set[tuple[Block, Block]] = set()  # changed since the last solve
        self._given: dict[str, sp.csr_array] = {}  # the last matrix given per region
        #: The active flags of the regions with point rows, changed since the last solve.
        self._pointed = {r.name for r in contacts if _pointed(r)}
        self._active: dict[str, np.ndarray | None] = {}
        self._pending_active: dict[str, np.ndarray | None] = {}
        # The surface blocks side by side in one vector, in the same order on every rank: what
        # the ranks sum (right-hand side) and what rank 0 broadcasts (solution).
        sizes = self.schedule.surface
        blocks = sorted(sizes)
        ends = np.cumsum([sizes[b] for b in blocks])
        self._where: dict[str, slice] = {
            b: slice(end - sizes[b], end) for b, end in zip(blocks, ends, strict=True)
        }
        self._surface_size = int(ends[-1]) if blocks else 0
        #: Rows of the largest dense group: its size decides the BLAS threads of the surface.
        self._dense_rows = max(
            (sum(sizes[b] for b in g.blocks) for g in self.schedule.flat), default=0
        )
        self._x: dict[str, np.ndarray] = {}
        self._complete = False

    def set_contact(self, key: str, matrix: sp.csr_array, active: np.ndarray | None = None) -> None:
        """Replace the contact matrix of region ``key`` (surface dof numbering).

        ``active``: its points' flags, which a region with point rows sends to the surface
        (``None``: unknown, and its changes are then corrected from the matrices). The same
        matrix object given again is taken as unchanged: a given matrix is never changed in
        place (the contact operator keeps and gives back its last one).
        """
        region = self._regions[key]
        if key in self._pointed:
            old_flags = self._active.get(key, np.zeros(0, bool))
            if active is None or old_flags is None or not np.array_equal(old_flags, active):
                flags = None if active is None else np.array(active, bool)
                self._active[key] = self._pending_active[key] = flags
        if region.block in self.subdomains:
            self.subdomains[region.block].matrix.set_contact(key, matrix)
            return
        if not self._stuck and self._given.get(key) is matrix:
            return  # the operator's kept matrix (its active set unchanged): the same pieces
        self._given[key] = matrix
        old = self._contact.get(key, {})
        pieces = region.in_blocks(matrix, self.system.sizes)  # a pair's: four pieces
        for pair, piece in pieces.items():
            if pair not in old or (old[pair] is not piece and (old[pair] != piece).nnz):
                self._pending_contact.add(pair)
        self._contact[key] = pieces
        if self._stuck:
            stuck = matrix if region.stuck is None else region.stuck()
            self._stuck_contact[key] = region.in_blocks(stuck, self.system.sizes)

    def _changed_contact(self, regions=None) -> dict[tuple[Block, Block], sp.csr_array]:
        """The contact pieces changed since the last solve, summed over the regions.

        ``regions``: those pieces' (default: the contact matrices').
        """
        out: dict[tuple[Block, Block], sp.csr_array] = {}
        for pieces in (self._contact if regions is None else regions).values():
            for pair in self._pending_contact & pieces.keys():
                out[pair] = out[pair] + pieces[pair] if pair in out else pieces[pair]
        if regions is None:
            self._pending_contact = set()
        return out

    def solve(self, rhs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Solve with this rank's right-hand-side contributions (collective).

        Returns the surface blocks solved so far and the owned subdomains the contact check
        needs; the rest follows in :meth:`finish`.
        """
        with self.log.solving():
            return self._solve(rhs)

    def _solve(self, rhs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        changed: dict[str, dict[Any, Any]] = {"Z": {}}
        if self._stuck:  # friction: the stuck matrices the surface factorises, too
            changed["stuck"] = self._changed_contact(self._stuck_contact)
        changed["contact"] = self._changed_contact()
        if self._pending_active:  # only then: a quiet solve sends what it did
            changed["active"], self._pending_active = self._pending_active, {}
        g = np.zeros(self._surface_size)  # this rank's part of the surface right-hand side
        for block, sub in self.subdomains.items():
            if sub.changing:
                sub.factorise()
                changed["Z"][block], sub.Z = sub.Z, None  # the surface's from now on
            b = rhs[block] if block in rhs else np.zeros(self.system.sizes[block])
            reduced = sub.surface_rhs(b)
            start = 0
            for s, J in sub.layout:
                g[self._where[s]][J] += reduced[start : start + len(J)]
                start += len(J)
        for key, vector in rhs.items():
            if Block.parse(key).kind != "u":
                g[self._where[key]] += vector
        # One meeting of the ranks before the surface solve: a surface vector from each, and
        # a matrix only where one changed (each meeting costs a rank's turn on a busy machine).
        parts = gather_to_root(self.comm, (g, changed), g.nbytes)
        complete = self.schedule.needs_all_surface
        x = np.zeros(self._surface_size)
        if self.comm.rank == ROOT:
            surface = self.surface
            assert parts is not None and surface is not None  # the root's
            g = np.sum([part for part, _ in parts], axis=0)
            with dense_threads(self._dense_rows):
                for _, part in parts:
                    for block, Z in part["Z"].items():
                        surface.set_condensed(block, Z)
                    stuck = part.get("stuck", {})
                    for pair, matrix in part["contact"].items():
                        surface.set_contact(pair, matrix, stuck.get(pair))
                    for name, flags in part.get("active", {}).items():
                        surface.set_active(name, flags)
                surface.factorise()
                solved = surface.solve({b: g[w].copy() for b, w in self._where.items()}, complete)
            x = self._packed(solved)
        self._x = self._unpacked(bcast_array(self.comm, x), complete)
        self._complete = complete
        out = dict(self._x)
        for block in self._needed_u:
            out[block] = self.subdomains[block].back_substitute(self._x)
        return out

    def _packed(self, blocks: dict[str, np.ndarray]) -> np.ndarray:
        """Surface blocks side by side in one vector (zero where a block is not given)."""
        x = np.zeros(self._surface_size)
        for block, vector in blocks.items():
            x[self._where[block]] = vector
        return x

    def _unpacked(self, x: np.ndarray, complete: bool) -> dict[str, np.ndarray]:
        """The surface blocks of a broadcast solution: all, or the last level's only."""
        levels = self.schedule.groups if complete else self.schedule.groups[-1:]
        known = [b for level in levels for grp in level for b in grp.blocks]
        return {b: x[self._where[b]] for b in known}

    def finish(self) -> dict[str, np.ndarray]:
        """Every surface block and this rank's subdomains of the last solution (collective).

        The other ranks' subdomains stay there: a caller that needs every block on every
        rank gathers them (:func:`dd_contact.parallel.allgather_blocks`).
        """
        with self.log.solving():
            return self._finish()

    def _finish(self) -> dict[str, np.ndarray]:
        if self.surface is not None:  # the root's
            self.surface.restart()
        if not self._complete:
            x = np.zeros(self._surface_size)
            if self.comm.rank == ROOT:
                assert self.surface is not None  # the root's
                with dense_threads(self._dense_rows):
                    x = self._packed(self.surface.back_substitute(self._x))
            self._x = self._unpacked(bcast_array(self.comm, x), True)
            self._complete = True
        u: dict[str, np.ndarray] = {
            b: s.back_substitute(self._x) for b, s in self.subdomains.items()
        }
        return {**self._x, **u}

    @property
    def rhs_offset(self) -> dict[str, np.ndarray]:
        """Nothing is subtracted from the right-hand side."""
        return {}

    def rebase(self) -> None:
        """A checkpoint: the next solve starts from factors a resumed run would make."""
        if self.surface is not None:  # the root's
            self.surface.rebase()

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for sub in self.subdomains.values():
            sub.destroy()
