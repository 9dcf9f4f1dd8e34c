"""The surface level of the block elimination: the condensed dense system on rank 0.

After every subdomain is condensed, the surface blocks (interface ``v`` and contact
interfaces ``w``) hold a dense SPD system (A14-A18). :class:`Surface` eliminates it group
by group as the order's :class:`~dd_contact.solvers.schedule.Schedule` says, re-factorising
only the groups a change made stale.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block
from dd_contact.solvers.dense import DenseCholesky
from dd_contact.solvers.schedule import (
    Group,
    Schedule,
)
from dd_contact.solvers.unsymmetric import DenseLU, lu_groups
from dd_contact.solvers.worklog import WorkLog

__all__ = ["Surface", "kept_into"]


@dataclass
class _GroupState:
    """What was computed for one group of the schedule."""

    factor: DenseCholesky | None = None
    B: np.ndarray | None = None  # the non-zero coupling columns to the neighbours
    C: np.ndarray | None = None  # the rows' coupling, transposed, if not B (an LU group)
    subtracted: np.ndarray | None = None  # B^T A_GG^-1 B: what eliminating the group subtracts
    columns: list[tuple[Block, np.ndarray]] = field(default_factory=list)
    offsets: np.ndarray | None = None
    g_in: np.ndarray | None = None  # right-hand side when last eliminated
    y: np.ndarray | None = None  # A_GG^-1 g_in


class Surface:
    """The condensed surface system on rank 0, eliminated group by group as scheduled.

    Args:
        schedule: The elimination schedule.
        log: Where the dense work is recorded.
        unsymmetric: Blocks with an unsymmetric contact block (friction).
        recondensed: Whether a subdomain can send a new Z (it has contact on its own boundary
            and is re-factorised on a change). The Schur pairs are then rebuilt from the
            base and every subdomain's Z, which are kept. Otherwise both are freed once every
            subdomain's Z is in them (dense copies the peak memory need not hold; a new Z
            then raises).

    Attributes:
        base: The surface pairs' own matrices, dense (an off-diagonal one and its transpose
            share their memory).
        schur_pairs: The pairs of S = base - sum_k Z_k (A14-A18), each subdomain's
            condensation Z_k subtracted where it touches.
        eliminated: The pairs after the earlier levels' groups are eliminated.
    """

    def __init__(self, schedule: Schedule, log: WorkLog, recondensed: bool = True, unsymmetric=()):
        self.schedule, self.sizes, self.log = schedule, schedule.surface, log
        self.lu = lu_groups(schedule, unsymmetric)  # groups friction makes unsymmetric
        self.recondensed = recondensed
        self.base: dict[tuple[Block, Block], np.ndarray] = {}
        self.condensed: dict[Block, np.ndarray] = {}  # latest Z of each subdomain (if kept)
        self._sources_freed = False  # base pairs in S and every Z freed (not recondensed)
        #: Contact matrices by the block pair they couple: ``(w, w)`` for an obstacle's
        #: region; a contact pair's off-diagonal pieces will go in as ``(a, b)``.
        self.contact: dict[tuple[Block, Block], sp.csr_array] = {}
        self.schur_pairs: dict[tuple[Block, Block], np.ndarray] = {}
        self.eliminated: dict[tuple[Block, Block], np.ndarray] = {}
        self.state = {g.name: _GroupState() for g in schedule.flat}
        self.changed: set[str] = set()  # surface blocks changed since the last factorise
        self.new_pairs: set[tuple[Block, Block]] = set()  # Schur pairs changed since then
        self.stale: set[str] = {g.name for g in schedule.flat}  # nothing factorised yet

    def add_base(self, row: Block, col: Block, A: sp.sparray) -> None:
        """Add a stored piece of a surface pair's own matrix (``BlockSystem.matrices``).

        The dense pair it stands for in both orientations: the transpose is a view.
        """
        dense = sp.csr_array(A).toarray()
        self.base[(row, col)] = self.base.get((row, col), 0.0) + dense
        if row != col:
            self.base[(col, row)] = self.base[(row, col)].T

    def set_condensed(self, block: Block, Z: np.ndarray) -> None:
        """A subdomain's new condensation: rebuild the surface pairs it touches."""
        if self._sources_freed:
            raise RuntimeError(
                f"subdomain {block!r} sent a second condensation, but no subdomain has contact "
                "on its own boundary, so the surface freed what its pairs were built from"
            )
        self.condensed[block] = Z
        where = self.schedule.tied_at
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

    def set_contact(
        self, pair: tuple[Block, Block], matrix: sp.csr_array, stuck: sp.csr_array | None = None
    ) -> None:
        """The new contact matrix of a block pair (``(w, w)``: a block's own).

        ``stuck``: the pair's matrix with every point sticking (friction), which only a
        surface that factorises it uses (:class:`~dd_contact.solvers.stuck.StuckSurface`).
        """
        self.contact[pair] = matrix
        self.changed |= set(pair)

    # -- what only some surfaces use: every surface takes it, so the engine needs no kinds --
    def add_points(self, name: str, parts: list[tuple[Block, np.ndarray]], rows) -> None:
        """A frictionless region's point rows: unused here (corrections from matrices)."""

    def set_active(self, name: str, active: np.ndarray | None) -> None:
        """A region's present flags: unused here."""

    def restart(self) -> None:
        """A step ended: nothing to make again here."""

    def rebase(self) -> None:
        """A checkpoint: nothing to drop (the factors follow from the matrices alone)."""

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
            updates: dict[tuple[Block, Block], list] = {}
            for g in level:
                state = self.state[g.name]
                if g.name in self.stale:
                    state.factor = None  # freed before its successor is assembled: not two at once
                    order = None if g.name in self.lu else self._row_order(g)
                    A = self._assemble(g, level_pairs, order)
                    state.factor = self._dense_factor(A, g, order)
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

    def _dense_factor(self, A: np.ndarray, g: Group, order=None) -> DenseCholesky:
        """The factor of a group's matrix: Cholesky, or LU where friction made it unsymmetric.

        ``order``: A's rows and columns are the group's in that order (Cholesky only).
        """
        if g.name in self.lu:
            return DenseLU(A, self.log, g.name)
        return DenseCholesky(A, self.log, g.name, order)

    def _row_order(self, g: Group) -> np.ndarray | None:
        """The order a group's rows are factorised in; ``None``: its blocks' one after the other."""
        return None

    def held_contact(self) -> dict[tuple[Block, Block], sp.csr_array]:
        """The contact matrices the factors are made of: those given."""
        return self.contact

    def _assemble(self, g: Group, level_pairs, order: np.ndarray | None = None) -> np.ndarray:
        """A group's matrix, its rows and columns in ``order`` (written there: no copy)."""
        offsets = np.cumsum([0] + [self.sizes[b] for b in g.blocks])
        place = None if order is None else np.argsort(order)

        def at(i: int, j: int):  # where block pair (i, j) is in A
            if place is None:
                return slice(offsets[i], offsets[i + 1]), slice(offsets[j], offsets[j + 1])
            return np.ix_(place[offsets[i] : offsets[i + 1]], place[offsets[j] : offsets[j + 1]])

        held = self.held_contact()
        A = np.zeros((offsets[-1], offsets[-1]))
        for i, a in enumerate(g.blocks):
            for j, b in enumerate(g.blocks):
                if level_pairs.get((a, b)) is not None:
                    A[at(i, j)] = level_pairs[(a, b)]
                if (a, b) in held:  # a contact piece of row a, on top
                    A[at(i, j)] += held[(a, b)].toarray()
        return A

    def _couple(self, g: Group, state: _GroupState, level_pairs) -> None:
        """X = A_GG^-1 B with B the non-zero coupling columns to the later blocks."""
        rows = np.cumsum([0] + [self.sizes[b] for b in g.blocks])
        lu = g.name in self.lu  # the rows' coupling is not the columns' transposed
        state.columns, parts, left = [], [], []
        for r in g.neighbours:
            B = np.zeros((rows[-1], self.sizes[r]))
            C = np.zeros_like(B) if lu else B
            for i, a in enumerate(g.blocks):
                if level_pairs.get((a, r)) is not None:
                    B[rows[i] : rows[i + 1]] = level_pairs[(a, r)]
                if lu and level_pairs.get((r, a)) is not None:
                    C[rows[i] : rows[i + 1]] = level_pairs[(r, a)].T
            nonzero = np.any(B != 0.0, axis=0)
            if lu:
                nonzero |= np.any(C != 0.0, axis=0)
            J = np.flatnonzero(nonzero)
            state.columns.append((r, J))
            parts.append(B[:, J])
            if lu:
                left.append(C[:, J])
        state.B = np.hstack(parts)
        state.C = np.hstack(left) if lu else None
        state.offsets = np.cumsum([0] + [len(J) for _, J in state.columns])
        assert state.factor is not None  # factorised before it is coupled
        if lu:
            assert isinstance(state.factor, DenseLU)
            state.subtracted = state.factor.congruence(state.B, "condense", left=state.C)
        else:
            state.subtracted = state.factor.congruence(state.B, "condense")

    def solve(self, g: dict[str, np.ndarray], complete: bool) -> dict[str, np.ndarray]:
        """Eliminate the right-hand side forward and solve the last level.

        With ``complete``, back-substitute the earlier levels too.
        """
        g = self.forward(g)
        x = self.solve_last(g)
        if complete:
            x.update(self.back_substitute(x))
        return x

    def solve_last(self, g: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The last level's blocks from the eliminated right-hand side ``g``."""
        x: dict[str, np.ndarray] = {}
        for grp in self.schedule.groups[-1]:
            state = self.state[grp.name]
            assert state.factor is not None  # every group is factorised before a solve
            self._split(grp, state.factor.solve(np.concatenate([g[b] for b in grp.blocks]), "x"), x)
        return x

    def forward(self, g: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The right-hand side with the earlier levels eliminated (theirs kept for later)."""
        g = {b: v.copy() for b, v in g.items()}
        for level in self.schedule.groups[:-1]:
            for grp in level:
                state = self.state[grp.name]
                assert state.factor is not None  # every group is factorised before a solve
                rhs = np.concatenate([g[b] for b in grp.blocks])
                # y and g_in are set together
                new_rhs = (
                    state.y is None or state.g_in is None or not np.array_equal(rhs, state.g_in)
                )
                if self.schedule.solves(grp, self.stale, new_rhs):
                    state.y, state.g_in = state.factor.solve(rhs, "y"), rhs
                if grp.neighbours:
                    assert state.B is not None and state.y is not None and state.offsets is not None
                    rows = state.B if state.C is None else state.C
                    correction = state.factor.product(rows, state.y, "y", transpose=True)
                    for i, (r, J) in enumerate(state.columns):
                        g[r][J] -= correction[state.offsets[i] : state.offsets[i + 1]]
        self.stale = set()
        return g

    def back_substitute(self, x: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Solve the earlier levels, last first, given the later blocks in ``x``."""
        x = dict(x)
        for level in reversed(self.schedule.groups[:-1]):
            for grp in level:
                state = self.state[grp.name]
                assert state.factor is not None and state.g_in is not None  # solved forward
                rhs = state.g_in.copy()
                if grp.neighbours:
                    assert state.B is not None
                    coupled = np.concatenate([x[r][J] for r, J in state.columns])
                    rhs -= state.factor.product(state.B, coupled, "x", transpose=False)
                self._split(grp, state.factor.solve(rhs, "x"), x)
        return x

    def _split(self, grp: Group, values: np.ndarray, out: dict) -> None:
        start = 0
        for b in grp.blocks:
            out[b] = values[start : start + self.sizes[b]]
            start += self.sizes[b]


def kept_into(kept: dict, G, name: str, new, X, Y, spare: bool = False) -> None:
    """A correction's columns ``new``, eliminated in group ``name``, into G and ``kept``.

    ``kept`` holds per group the columns eliminated there and what it keeps of them (X
    here); Y is what that meets: X itself in the last level (``L^-1 R``, G ``+= X^T X``),
    else the columns' rows R (``A^-1 R``, G ``+= R^T A^-1 R``). Used by
    :mod:`~dd_contact.solvers.lowrank` and :mod:`~dd_contact.solvers.pointwise`. ``spare``:
    the kept columns (none, or a view of zero columns) are the first of a larger array, the
    next ones written after them (no copy of the earlier ones; a larger array when full);
    only where nothing else extends the same ``kept``.
    """
    G[np.ix_(new, new)] += Y.T @ X
    old, X_old = kept.get(name, (np.zeros(0, int), np.zeros((len(X), 0))))
    if len(old):
        cross = X_old.T @ Y
        G[np.ix_(old, new)] += cross
        G[np.ix_(new, old)] += cross.T
    if not spare:
        kept[name] = (np.concatenate([old, new]), np.hstack([X_old, X]) if len(old) else X)
        return
    r, k, base = len(old), X.shape[1], X_old.base
    prefix = base is not None and X_old.ctypes.data == base.ctypes.data  # base[:, :r]
    if not (prefix and base.flags.f_contiguous and base.shape[1] >= r + k):
        base = np.zeros((len(X), max(2 * (r + k), 64)), order="F")
        base[:, :r] = X_old
    base[:, r : r + k] = X
    kept[name] = (np.concatenate([old, new]), base[:, : r + k])
