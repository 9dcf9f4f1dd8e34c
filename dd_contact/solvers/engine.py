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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.assembly import BlockSystem
from dd_contact.blocks import Block, ContactRegion, refuse_unsolvable
from dd_contact.parallel import ROOT, allgathered, any_rank, bcast_array, gather_to_root, gathered
from dd_contact.solvers.linalg import (
    DenseCholesky,
    PatternedMatrix,
    SparseCholesky,
    SparseStatistics,
    coo_of,
    sparse_statistics,
)
from dd_contact.solvers.mumps_schur import SchurFactorisation
from dd_contact.solvers.schedule import (
    CONDENSATIONS,
    Group,
    Schedule,
    condensation_chunks,
)
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "BlockEliminationSolver",
    "SubdomainCondensation",
    "coupling_layout",
    "order_schedule",
    "owned_subdomains",
    "subdomain_statistics",
    "surface_structure",
]


def coupling_layout(block: str, system: BlockSystem) -> tuple[list, sp.csr_array]:
    """The couplings of a subdomain: ``(surface block, tied dofs)`` each, and their columns.

    Returns the layout and ``C``, the subdomain's non-zero coupling columns side by side.
    """
    layout, columns = [], []
    for surface, A in system.coupled(block):
        A = sp.csr_array(A)
        A.eliminate_zeros()
        J = np.unique(A.indices)
        layout.append((surface, J))
        columns.append(A[:, J])
    n = system.sizes[block]
    return layout, (sp.csr_array(sp.hstack(columns)) if columns else sp.csr_array((n, 0)))


def order_schedule(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    order: str,
    condensation: str,
    layouts: dict[str, list],
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
) -> tuple[set[tuple[Block, Block]], dict[str, Block]]:
    """Collective: what every rank knows of the surface, gathered.

    Returns the surface block pairs with a matrix of their own (both orientations) and the
    block each contact region acts on.
    """
    pairs = {(r, c) for r, c, _ in system.all_blocks() if r.kind != "u" != c.kind}
    pairs = {p for part in allgathered(comm, pairs) for p in part}
    regions = gathered(comm, {region.name: region.blocks for region in contacts})
    return pairs, regions


# -- the subdomain level ------------------------------------------------------------------
class SubdomainSolver(Protocol):
    """What the engine asks of a subdomain: the seam of reduced subdomains.

    :class:`SubdomainCondensation` (a sparse factor, one substitution per step) is the one
    kind today; a reduced model (constraint and normal modes, a small dense matrix) will be
    another, built by :func:`owned_subdomains`, with the same surface-facing operations.
    """

    block: Block
    layout: list
    Z: np.ndarray | None

    @property
    def changing(self) -> bool:
        """Whether it must be factorised (again) before the next solve."""
        ...

    def analyse(self) -> SparseStatistics:
        """What its factorisation will cost (for the timing model)."""
        ...

    def factorise(self) -> None:
        """(Re-)factorise and condense: Z = C^T K^-1 C."""
        ...

    def surface_rhs(self, b: np.ndarray) -> np.ndarray:
        """Its part of the surface right-hand side, -C^T K^-1 b."""
        ...

    def back_substitute(self, surface: dict[str, np.ndarray]) -> np.ndarray:
        """Its displacement given the surface solution (eq. 17)."""
        ...

    def destroy(self) -> None:
        """Free what it holds."""
        ...


class SubdomainCondensation:
    """One owned subdomain: its factorisation, condensation, u_hat and back-substitution.

    Args:
        block: The subdomain's block.
        system: The block system (this rank holds every piece of the block).
        contacts: The contact regions on the subdomain's own boundary (no contact interface).
        log: Where the work is recorded.
        condensation: ``"schur"`` or ``"multi-rhs"``.
        compact: Compact MUMPS's workspace after the first factorisation (``"schur"`` only; it
            copies the factors: :data:`~dd_contact.solvers.mumps_schur.ICNTL_COMPACT`).

    Attributes:
        layout: ``(surface block, columns)`` of each coupling: the surface dofs tied here.
        Z: ``C^T K^-1 C`` over the concatenated coupling columns (dense).
    """

    def __init__(
        self,
        block: Block,
        system: BlockSystem,
        contacts: Sequence[ContactRegion],
        log: WorkLog,
        condensation: str,
        compact: bool = False,
    ):
        if condensation not in CONDENSATIONS:
            raise ValueError(
                f"unknown condensation {condensation!r}; valid: {', '.join(CONDENSATIONS)}"
            )
        self.block, self.log = block, log
        n = system.sizes[block]
        self.layout, self.C = coupling_layout(block, system)
        m = self.C.shape[1]
        # MUMPS's Schur complement: factorise [[K, C], [C^T, 0]] with the last m as Schur
        # block; it gives -Z directly, and its reduction and expansion phases give the
        # surface right-hand side and u with one forward and one backward sweep.
        self.schur = m if condensation == "schur" else 0
        rows, cols, values = coo_of(system.block(block, block))
        if self.schur:
            cr, cc, cv = coo_of(self.C)
            diagonal = n + np.arange(m)  # the Schur block's pattern, zero
            rows = np.concatenate([rows, cr, cc + n, diagonal])
            cols = np.concatenate([cols, cc + n, cr, diagonal])
            values = np.concatenate([values, cv, cv, np.zeros(m)])
        size = n + self.schur
        base = (rows, cols, values)
        # Driven through MUMPS's C interface (reduction and expansion apart), the Schur
        # factorisation needs no PETSc matrix: the upper triangle's COO only.
        self.matrix = PatternedMatrix(MPI.COMM_SELF, size, size, base, contacts, bool(self.schur))
        self.factor: SparseCholesky | SchurFactorisation | None = None
        if self.schur:
            rows, cols = self.matrix.take_indices()
            self.factor = SchurFactorisation(rows, cols, size, m, log, block, compact)
        self.Z, self.u_hat, self._b, self._g = None, None, None, None
        self.u: np.ndarray | None = None
        self._factorised = False

    @property
    def changing(self) -> bool:
        """Whether the matrix must be re-factorised (new contact values, or never done)."""
        return not self._factorised or self.matrix.dirty

    def analyse(self) -> SparseStatistics:
        """MUMPS's symbolic analysis of the matrix :meth:`factorise` factorises.

        With ``"schur"`` the analysis is the factorisation's own (not repeated by it).
        """
        if self.schur:
            return self.factor.analyse(self.matrix.values)
        self.matrix.push()
        return sparse_statistics(self.matrix.A)

    def factorise(self) -> None:
        """(Re-)factorise K_hat and condense the coupling columns: Z = C^T K^-1 C."""
        self.matrix.push()
        if self.schur:
            self.Z = self.factor.factorise(self.matrix.values)  # S = -Z, exactly symmetric
            np.negative(self.Z, out=self.Z)
        else:
            if self.factor is None:
                self.factor = SparseCholesky(self.matrix.A, self.log, self.block)
            else:
                self.factor.refactorise()
            m = self.C.shape[1]
            self.Z = np.zeros((m, m))
            Csc = self.C.tocsc()
            for j0, j1 in condensation_chunks(m):
                X = self.factor.solve_many(Csc[:, j0:j1].toarray(), "condense")
                self.Z[:, j0:j1] = self.C.T @ X
            self.Z = 0.5 * (self.Z + self.Z.T)  # symmetric up to round-off; make it exact
        self._b, self._factorised = None, True

    def surface_rhs(self, b: np.ndarray) -> np.ndarray:
        """-C^T K^-1 b, computed only when b or K changed.

        With ``"schur"``: MUMPS's reduction, one forward sweep whose result MUMPS keeps for
        :meth:`back_substitute`. With ``"multi-rhs"``: a full substitution u_hat = K^-1 b.
        """
        if self._b is None or not np.array_equal(b, self._b):
            self._b = b.copy()
            if self.schur:
                self._g = self.factor.reduce(b, "u_hat")
            else:
                self.u_hat = self.factor.solve_array(b, "u_hat")
                self._g = -(self.C.T @ self.u_hat)
        self.u = None
        return self._g

    def back_substitute(self, surface: dict[str, np.ndarray]) -> np.ndarray:
        """U = K^-1 (b - C x_surface) (eq. 17), once per new surface solution.

        With ``"schur"``: MUMPS's expansion, one backward sweep from the forward sweep of
        :meth:`surface_rhs` (a second expansion for the same b sweeps forward again).
        """
        if self.u is None:
            xs = np.concatenate([surface[s][J] for s, J in self.layout] or [np.zeros(0)])
            if not self.schur:
                self.u = self.factor.solve_array(self._b - self.C @ xs, "u")
                return self.u
            if not self.factor.reduced:  # MUMPS released the forward sweep
                self.factor.reduce(self._b, "u")
            self.u = self.factor.expand(xs, "u")
        return self.u

    def destroy(self) -> None:
        """Free the PETSc objects."""
        if self.factor is not None:
            self.factor.destroy()
        self.matrix.destroy()


def owned_subdomains(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    log: WorkLog,
    condensation: str,
) -> dict[Block, SubdomainCondensation]:
    """The subdomains this rank owns, each ready to factorise (nothing factorised yet).

    They are factorised in this order: first those without contact on their own boundary,
    then those with (re-factorised on each contact change). Each but the last compacts
    MUMPS's workspace after its first factorisation: what the earlier ones keep adds to
    the later ones' peak. The compaction copies the factors, so the last one does not, nor
    does a re-factorisation: their copy would set the peak. Peaks on the 306k-dof bar
    (ru_maxrss, MiB; docs/solvers.md): w-v-u 4,261 with both subdomains compacted, 3,392
    with the first only (FULL 3,439); w-u's one subdomain 5,192 compacted, 3,336 not; v-u
    4,168 before, 3,424 with its contact subdomain factorised first, 3,300 with it last.
    """
    owned = [b for b, owner in system.owners.items() if b.kind == "u" and owner == comm.rank]
    own_contacts = {b: [r for r in contacts if r.block == b] for b in owned}
    owned.sort(key=lambda b: bool(own_contacts[b]))  # stable: the owners' order otherwise
    return {
        block: SubdomainCondensation(
            block, system, own_contacts[block], log, condensation, compact=block != owned[-1]
        )
        for block in owned
    }


def subdomain_statistics(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    condensation: str = "schur",
    subdomains: dict[Block, SubdomainCondensation] | None = None,
) -> dict[Block, tuple[SparseStatistics, list]]:
    """Collective: each subdomain's analysed matrix and coupling layout.

    The matrix is the one the engine factorises: with its Schur block if
    ``condensation="schur"``. Returns ``block -> (statistics, layout)`` on every rank.
    ``subdomains``: this rank's, built already (:func:`owned_subdomains`, analysed here and
    kept for a solver); by default built and freed here.
    """
    owned = subdomains
    if owned is None:
        owned = owned_subdomains(comm, system, contacts, WorkLog(), condensation)
    mine = {block: (sub.analyse(), sub.layout) for block, sub in owned.items()}
    if subdomains is None:
        for sub in owned.values():
            sub.destroy()
    return gathered(comm, mine)


# -- the dense surface levels (rank 0) ----------------------------------------------------
@dataclass
class _GroupState:
    """What was computed for one group of the schedule."""

    factor: DenseCholesky | None = None
    B: np.ndarray | None = None  # the non-zero coupling columns to the neighbours
    subtracted: np.ndarray | None = None  # B^T A_GG^-1 B: what eliminating the group subtracts
    columns: list[tuple[str, np.ndarray]] = field(default_factory=list)
    offsets: np.ndarray | None = None
    g_in: np.ndarray | None = None  # right-hand side when last eliminated
    y: np.ndarray | None = None  # A_GG^-1 g_in


class _Surface:
    """The condensed surface system on rank 0, eliminated group by group as scheduled.

    Args:
        schedule: The elimination schedule.
        log: Where the dense work is recorded.
        recondensed: Whether a subdomain can send a new Z (it has contact on its own boundary
            and is re-factorised on a change). The Schur pairs are then rebuilt from the
            base and every subdomain's Z, which are kept. Otherwise both are freed once every
            subdomain's Z is in them (at 306k dofs 84 MB of dense copies; a new Z then raises).

    Attributes:
        base: The surface pairs' own matrices, dense (an off-diagonal one and its transpose
            share their memory).
        schur_pairs: The pairs of S = base - sum_k Z_k (A14-A18), each subdomain's
            condensation Z_k subtracted where it touches.
        eliminated: The pairs after the earlier levels' groups are eliminated.
    """

    def __init__(self, schedule: Schedule, log: WorkLog, recondensed: bool = True):
        self.schedule, self.sizes, self.log = schedule, schedule.surface, log
        self.recondensed = recondensed
        self.base: dict[tuple[str, str], np.ndarray] = {}
        self.condensed: dict[str, np.ndarray] = {}  # latest Z of each subdomain (if kept)
        self._sources_freed = False  # base pairs in S and every Z freed (not recondensed)
        #: Contact matrices by the block pair they couple: ``(w, w)`` for an obstacle's
        #: region; a contact pair's off-diagonal pieces will go in as ``(a, b)``.
        self.contact: dict[tuple[str, str], sp.csr_array] = {}
        self.schur_pairs: dict[tuple[str, str], np.ndarray] = {}
        self.eliminated: dict[tuple[str, str], np.ndarray] = {}
        self.state = {g.name: _GroupState() for g in schedule.flat}
        self.changed: set[str] = set()  # surface blocks changed since the last factorise
        self.new_pairs: set[tuple[str, str]] = set()  # Schur pairs changed since then
        self.stale: set[str] = {g.name for g in schedule.flat}  # nothing factorised yet

    def add_base(self, row: str, col: str, A: sp.sparray) -> None:
        """Add a stored piece of a surface pair's own matrix (``BlockSystem.matrices``).

        The dense pair it stands for in both orientations: the transpose is a view.
        """
        dense = sp.csr_array(A).toarray()
        self.base[(row, col)] = self.base.get((row, col), 0.0) + dense
        if row != col:
            self.base[(col, row)] = self.base[(row, col)].T

    def set_condensed(self, block: str, Z: np.ndarray) -> None:
        """A subdomain's new condensation: rebuild the surface pairs it touches."""
        if self._sources_freed:
            raise RuntimeError(
                f"subdomain {block!r} sent a second condensation, but no subdomain has contact "
                "on its own boundary, so the surface freed what its pairs were built from"
            )
        self.condensed[block] = Z
        where = self.schedule.where
        touched = {(a, b) for a in where[block] for b in where[block]}
        for pair in sorted(touched):
            if pair[::-1] in touched and pair[::-1] < pair:  # S is symmetric: a view, no copy
                self.schur_pairs[pair] = self.schur_pairs[pair[::-1]].T
                continue
            matrix = self.base.get(pair, np.zeros((self.sizes[pair[0]], self.sizes[pair[1]])))
            matrix = np.array(matrix)
            for k, Zk in self.condensed.items():
                if pair[0] in where[k] and pair[1] in where[k]:
                    (o1, J1), (o2, J2) = where[k][pair[0]], where[k][pair[1]]
                    matrix[np.ix_(J1, J2)] -= Zk[o1 : o1 + len(J1), o2 : o2 + len(J2)]
            self.schur_pairs[pair] = matrix
        self.new_pairs |= touched
        self.changed |= self.schedule.touched(block)
        if not self.recondensed and self.condensed.keys() == where.keys():
            self.condensed.clear()  # every Z is in S now, and none will change
            for pair in self.schur_pairs:
                self.base.pop(pair, None)
            self._sources_freed = True

    def set_contact(self, pair: tuple[str, str], matrix: sp.csr_array) -> None:
        """The new contact matrix of a block pair (``(w, w)``: a block's own)."""
        self.contact[pair] = matrix
        self.changed |= set(pair)

    def _schur_pair(self, pair) -> np.ndarray | None:
        """The pair's matrix in S (its base matrix if no subdomain touches it), or None."""
        return self.schur_pairs[pair] if pair in self.schur_pairs else self.base.get(pair)

    def factorise(self) -> None:
        """Re-factorise the groups the schedule finds stale after what changed."""
        if self.changed:  # a new condensation also marks the blocks it touches
            self.stale |= self.schedule.stale_groups(self.changed)
        if not self.stale:
            return
        # every pair's matrix as the current level sees it: S's, then each level's eliminated
        level_pairs = {p: self._schur_pair(p) for p in self.schedule.pairs}
        for level in self.schedule.groups:
            updates: dict[tuple[str, str], list] = {}
            for g in level:
                state = self.state[g.name]
                if g.name in self.stale:
                    state.factor = None  # freed before its successor is assembled: not two at once
                    state.factor = self._dense_factor(self._assemble(g, level_pairs), g)
                    if not g.last and g.neighbours:
                        self._couple(g, state, level_pairs)
                if not g.last and g.neighbours:
                    for i, (r1, _) in enumerate(state.columns):
                        for j, (r2, _) in enumerate(state.columns):
                            updates.setdefault((r1, r2), []).append((g, state, i, j))
            for pair, parts in updates.items():
                redo = pair in self.new_pairs or any(g.name in self.stale for g, *_ in parts)
                if redo or pair not in self.eliminated:
                    for g, state, *_ in parts:
                        if state.subtracted is None:  # freed after its last use below
                            self._couple(g, state, level_pairs)
                    M = level_pairs.get(pair)
                    M = np.zeros((self.sizes[pair[0]], self.sizes[pair[1]])) if M is None else M
                    M = M.copy()
                    for _, state, i, j in parts:
                        (_, J1), (_, J2) = state.columns[i], state.columns[j]
                        o1, o2 = state.offsets[i], state.offsets[j]
                        M[np.ix_(J1, J2)] -= state.subtracted[o1 : o1 + len(J1), o2 : o2 + len(J2)]
                    self.eliminated[pair] = M
                level_pairs[pair] = self.eliminated[pair]
            for g in level:  # B^T A_GG^-1 B is in the eliminated pairs now: as large as they
                self.state[g.name].subtracted = None
        self.changed, self.new_pairs = set(), set()

    def _dense_factor(self, A: np.ndarray, g: Group) -> DenseCholesky:
        """The factor of a group's matrix: Cholesky, every contact block being symmetric.

        The seam of friction: a group holding an unsymmetric contact block (slip) gets an LU
        factor here; :func:`~dd_contact.blocks.refuse_unsolvable` refuses one until then.
        """
        return DenseCholesky(A, self.log, g.name)

    def _assemble(self, g: Group, level_pairs) -> np.ndarray:
        offsets = np.cumsum([0] + [self.sizes[b] for b in g.blocks])
        A = np.zeros((offsets[-1], offsets[-1]))
        for i, a in enumerate(g.blocks):
            rows = slice(offsets[i], offsets[i + 1])
            for j, b in enumerate(g.blocks):
                if level_pairs.get((a, b)) is not None:
                    A[rows, offsets[j] : offsets[j + 1]] = level_pairs[(a, b)]
            for j, b in enumerate(g.blocks):  # the contact pieces of row a
                if (a, b) in self.contact:
                    A[rows, offsets[j] : offsets[j + 1]] += self.contact[(a, b)].toarray()
        return A

    def _couple(self, g: Group, state: _GroupState, level_pairs) -> None:
        """X = A_GG^-1 B with B the non-zero coupling columns to the later blocks."""
        rows = np.cumsum([0] + [self.sizes[b] for b in g.blocks])
        state.columns, parts = [], []
        for r in g.neighbours:
            B = np.zeros((rows[-1], self.sizes[r]))
            for i, a in enumerate(g.blocks):
                if level_pairs.get((a, r)) is not None:
                    B[rows[i] : rows[i + 1]] = level_pairs[(a, r)]
            J = np.flatnonzero(np.any(B != 0.0, axis=0))
            state.columns.append((r, J))
            parts.append(B[:, J])
        state.B = np.hstack(parts)
        state.offsets = np.cumsum([0] + [len(J) for _, J in state.columns])
        state.subtracted = state.factor.congruence(state.B, "condense")

    def solve(self, g: dict[str, np.ndarray], complete: bool) -> dict[str, np.ndarray]:
        """Eliminate the right-hand side forward and solve the last level.

        With ``complete``, back-substitute the earlier levels too.
        """
        g = {b: v.copy() for b, v in g.items()}
        for level in self.schedule.groups:
            for grp in level:
                state = self.state[grp.name]
                rhs = np.concatenate([g[b] for b in grp.blocks])
                if grp.last:
                    self._split(grp, state.factor.solve(rhs, "x"), g)
                    continue
                new_rhs = state.y is None or not np.array_equal(rhs, state.g_in)
                if self.schedule.solves(grp, self.stale, new_rhs):
                    state.y, state.g_in = state.factor.solve(rhs, "y"), rhs
                if grp.neighbours:
                    correction = state.B.T @ state.y
                    for i, (r, J) in enumerate(state.columns):
                        g[r][J] -= correction[state.offsets[i] : state.offsets[i + 1]]
        self.stale = set()
        x = {b: g[b] for grp in self.schedule.groups[-1] for b in grp.blocks}
        if complete:
            x.update(self.back_substitute(x))
        return x

    def back_substitute(self, x: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Solve the earlier levels, last first, given the later blocks in ``x``."""
        x = dict(x)
        for level in reversed(self.schedule.groups[:-1]):
            for grp in level:
                state = self.state[grp.name]
                rhs = state.g_in.copy()
                if grp.neighbours:
                    coupled = np.concatenate([x[r][J] for r, J in state.columns])
                    rhs -= state.B @ coupled
                self._split(grp, state.factor.solve(rhs, "x"), x)
        return x

    def _split(self, grp: Group, values: np.ndarray, out: dict) -> None:
        start = 0
        for b in grp.blocks:
            out[b] = values[start : start + self.sizes[b]]
            start += self.sizes[b]


# -- the solver ---------------------------------------------------------------------------
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
            Schur complement of ``[[K, C], [C^T, 0]]`` within the factorisation; measured
            about 3x faster at 150k dofs) or ``"multi-rhs"`` (one substitution per coupling
            column, in blocks of 256, as the paper counts it).
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
        subdomains: dict[Block, SubdomainCondensation] | None = None,
    ):
        refuse_unsolvable(contacts)
        self.comm, self.system, self.log, self.order = comm, system, log, order
        self._regions = {region.name: region for region in contacts}
        if subdomains is None:
            subdomains = owned_subdomains(comm, system, contacts, log, condensation)
        self.subdomains: dict[Block, SubdomainSolver] = subdomains
        layouts = {b: sub.layout for b, sub in self.subdomains.items()}
        self.schedule = order_schedule(comm, system, contacts, order, condensation, layouts)
        self._needed_u = set(self.schedule.needed_u) & set(self.subdomains)
        pieces = [(r, c, A) for (r, c), A in system.matrices.items() if r.kind != "u" != c.kind]
        pieces = gather_to_root(comm, pieces)
        self.surface: _Surface | None = None
        # a subdomain with contact on its own boundary is re-factorised: it sends a new Z
        recondensed = any_rank(comm, any(r.block.kind == "u" for r in contacts))
        if comm.rank == ROOT:
            self.surface = _Surface(self.schedule, log, recondensed)
            for part in pieces:
                for r, c, A in part:
                    self.surface.add_base(r, c, A)
        self._contact: dict[str, sp.csr_array] = {}  # latest contact matrix of each w block
        self._pending_contact: dict[str, sp.csr_array] = {}  # changed since the last solve
        # The surface blocks side by side in one vector, in the same order on every rank: what
        # the ranks sum (right-hand side) and what rank 0 broadcasts (solution).
        sizes = self.schedule.surface
        blocks = sorted(sizes)
        ends = np.cumsum([sizes[b] for b in blocks])
        self._where = {b: slice(end - sizes[b], end) for b, end in zip(blocks, ends, strict=True)}
        self._surface_size = int(ends[-1]) if blocks else 0
        self._x: dict[str, np.ndarray] = {}
        self._complete = False

    def set_contact(self, key: str, matrix: sp.csr_array) -> None:
        """Replace the contact matrix of region ``key`` (surface dof numbering)."""
        block, dofs = self._regions[key].block, self._regions[key].dofs
        if block in self.subdomains:
            self.subdomains[block].matrix.set_contact(key, matrix)
            return
        n = self.system.sizes[block]
        if not np.array_equal(dofs, np.arange(n)):  # to block numbering
            r, c, v = coo_of(matrix)
            matrix = sp.csr_array((v, (dofs[r], dofs[c])), shape=(n, n))
        old = self._contact.get(block)
        if old is None or (old != matrix).nnz:
            self._contact[block] = self._pending_contact[block] = matrix

    def solve(self, rhs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Solve with this rank's right-hand-side contributions (collective).

        Returns the surface blocks solved so far and the owned subdomains the contact check
        needs; the rest follows in :meth:`finish`.
        """
        changed = {"Z": {}, "contact": self._pending_contact}
        self._pending_contact = {}
        g = np.zeros(self._surface_size)  # this rank's part of the surface right-hand side
        for block, sub in self.subdomains.items():
            if sub.changing:
                sub.factorise()
                changed["Z"][block], sub.Z = sub.Z, None  # the surface's from now on
            reduced = sub.surface_rhs(rhs.get(block, np.zeros(self.system.sizes[block])))
            start = 0
            for s, J in sub.layout:
                g[self._where[s]][J] += reduced[start : start + len(J)]
                start += len(J)
        for block, vector in rhs.items():
            if Block.parse(block).kind != "u":
                g[self._where[block]] += vector
        # One meeting of the ranks before the surface solve: a surface vector from each, and
        # a matrix only where one changed (each meeting costs a rank's turn on a busy machine).
        parts = gather_to_root(self.comm, (g, changed), g.nbytes)
        complete = self.schedule.needs_all_surface
        x = np.zeros(self._surface_size)
        if self.comm.rank == ROOT:
            surface = self.surface
            g = np.sum([part for part, _ in parts], axis=0)
            for _, part in parts:
                for block, Z in part["Z"].items():
                    surface.set_condensed(block, Z)
                for block, matrix in part["contact"].items():
                    surface.set_contact((block, block), matrix)
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
        if not self._complete:
            x = np.zeros(self._surface_size)
            if self.comm.rank == ROOT:
                x = self._packed(self.surface.back_substitute(self._x))
            self._x = self._unpacked(bcast_array(self.comm, x), True)
            self._complete = True
        u = {b: s.back_substitute(self._x) for b, s in self.subdomains.items()}
        return {**self._x, **u}

    @property
    def rhs_offset(self) -> dict[str, np.ndarray]:
        """Nothing is subtracted from the right-hand side."""
        return {}

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for sub in self.subdomains.values():
            sub.destroy()
