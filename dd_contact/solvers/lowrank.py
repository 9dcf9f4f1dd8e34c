"""Low-rank contact changes: a Woodbury correction instead of a re-factorisation.

A contact state change changes the condensed surface system S by the difference of the
contact matrices, ``dC = C_now - C_factorised``, non-zero only on the dofs J that the
changed points' shape functions touch: ``S' = S + E M E^T`` with E the unit columns of J
and ``M = dC[J, J]`` (k x k, symmetric, indefinite when points release). With every factor
of the order's chain kept as it is (each group of each level, the interface's condensed
block included),

    S'^-1 g = S^-1 (g - E z),   (I + M G) z = M (S^-1 g)_J,   G = E^T S^-1 E.

G costs one forward elimination of J's k unit columns through the groups they reach (the
group holding J and the later levels it is eliminated into; no other group and no
back-substitution), then a k x k LU of ``I + M G``. A solve is two passes through the chain
instead of one. The correction is on the whole condensed surface system, so it is the same
for every order, and a change re-factorises neither the interface nor the other groups.

Changes accumulate (J and M grow) until re-factorising the groups the change makes stale
is cheaper than the correction (:meth:`LowRankSurface.update_seconds`), or until the
correction's residual degrades. The residual is exact and cheap: off J, ``S' = S`` and the
chain solved ``S x = g - E z``; on J, ``S' x - g = M x_J - z``. A solve whose relative
residual exceeds :data:`UPDATE_TOLERANCE` re-factorises and solves again.

Work log: the forward elimination's substitutions are ``"dense_solve"`` records with
``what="lowrank"``, each correction one ``"dense_update"`` record (size k): their count
against ``"dense_factor"``'s says how many changes were updated and how many re-factorised.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from dd_contact.blocks import Block
from dd_contact.calibration import cached_rates
from dd_contact.solvers.linalg import DenseCholesky
from dd_contact.solvers.schedule import Operation, Schedule
from dd_contact.solvers.surface import Surface
from dd_contact.solvers.worklog import WorkLog

__all__ = ["REFINED", "REFINEMENTS", "UPDATE_TOLERANCE", "Correction", "LowRankSurface", "low_rank"]

#: Largest accepted ``|D U^T x_J - z| / |z|`` of a corrected solve (its residual on J,
#: relative to the correction); beyond it the groups are re-factorised and the solve repeated.
UPDATE_TOLERANCE = 1e-9

#: Defect below which a corrected solve is not refined (round-off of the chain's solves).
REFINED = 1e-13

#: Refinements of a corrected solve at most (each one more pass through the chain).
REFINEMENTS = 2


@dataclass
class Correction:
    """The Woodbury correction of the contact changes since the last factorisation.

    Each change is kept as ``U D U^T`` on its dofs J (its non-zero eigenpairs, found per
    connected cluster of changed dofs): a change of r points' normal penalties has rank r,
    a few times less than the dofs they touch. A change adds its columns to the earlier
    ones (a point that changes back adds the opposite term), so a change costs its own
    rank, not the accumulated one: the forward elimination of each group's columns is kept
    (:attr:`kept`) for the cross terms of the next.

    Attributes:
        pieces: Per change, the dofs J per surface block (sorted) and U (k x its rank).
        D: The eigenvalues, every change's in turn.
        G: ``V^T S^-1 V`` for ``V = E U`` of every change.
        kept: Per group, the columns of V that reach it and their forward elimination
            (``L^-1 R`` in the last level, ``A_GG^-1 R`` before it).
        capacitance: LU factors of ``I + D G``.
    """

    pieces: list[tuple[dict[Block, np.ndarray], np.ndarray]] = field(default_factory=list)
    D: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    kept: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    capacitance: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def rank(self) -> int:
        """Columns of every change so far."""
        return len(self.D)

    def projected(self, x: dict[str, np.ndarray]) -> np.ndarray:
        """``D U^T x_J``: what the changes apply to ``x``, in the columns' coordinates."""
        parts = [
            U.T @ np.concatenate([x[b][J] for b, J in dofs.items()]) for dofs, U in self.pieces
        ]
        return self.D * np.concatenate(parts)

    def shifted(self, g: dict[str, np.ndarray], z: np.ndarray) -> dict[str, np.ndarray]:
        """``g - E U z``."""
        out = {b: v.copy() for b, v in g.items()}
        column = 0
        for dofs, U in self.pieces:
            Uz, start = U @ z[column : column + U.shape[1]], 0
            column += U.shape[1]
            for b, J in dofs.items():
                out[b][J] -= Uz[start : start + len(J)]
                start += len(J)
        return out


def low_rank(M: sp.csr_array, tolerance: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """``M = U diag(D) U^T`` with the eigenpairs above ``tolerance`` times the largest.

    M is sparse, its non-zeros in clusters (the dofs of neighbouring changed points): each
    cluster is decomposed alone, so the cost is the clusters' sizes cubed, not k's.
    """
    k = M.shape[0]
    count, labels = connected_components(M, directed=False)
    vectors, values = [], []
    for c in range(count):
        rows = np.flatnonzero(labels == c)
        lam, Q = np.linalg.eigh(M[rows][:, rows].toarray())
        vectors.append((rows, Q))
        values.append(lam)
    largest = max((np.abs(lam).max(initial=0.0) for lam in values), default=0.0)
    keep = [np.abs(lam) > tolerance * largest for lam in values]
    rank = int(sum(int(np.sum(kept)) for kept in keep))
    U, D, column = np.zeros((k, rank)), np.zeros(rank), 0
    for (rows, Q), lam, kept in zip(vectors, values, keep, strict=True):
        n = int(np.sum(kept))
        U[rows, column : column + n] = Q[:, kept]
        D[column : column + n] = lam[kept]
        column += n
    return U, D


class LowRankSurface(Surface):
    """A :class:`Surface` that corrects contact changes with Woodbury instead of re-factorising.

    Args:
        schedule, log, recondensed: As :class:`Surface`.
        rates: Machine rates pricing the update against a re-factorisation
            (:func:`dd_contact.timing.record_seconds`); default: this machine's if cached
            (:func:`dd_contact.calibration.cached_rates`), else by flops (dense
            factorisations and blocked substitutions run at about the same rate).
        lowrank: ``False``: re-factorise on every change, as :class:`Surface`. Default:
            :attr:`enabled`.
    """

    #: Whether a surface corrects contact changes unless told otherwise (a comparison
    #: with re-factorising sets it ``False``).
    enabled = True

    def __init__(
        self,
        schedule: Schedule,
        log: WorkLog,
        recondensed: bool = True,
        rates=None,
        lowrank: bool | None = None,
    ):
        super().__init__(schedule, log, recondensed)
        self.rates = rates if rates is not None else cached_rates()
        self.lowrank = self.enabled if lowrank is None else lowrank
        #: The contact matrices the factors hold, and those the correction adds up to.
        self.factorised: dict[tuple[Block, Block], sp.csr_array] = {}
        self.corrected: dict[tuple[Block, Block], sp.csr_array] = {}
        self.moved: set[tuple[Block, Block]] = set()  # pairs changed since the factorisation
        self.fresh: set[tuple[Block, Block]] = set()  # pairs changed since the correction
        self.correction = Correction()

    def set_contact(self, pair: tuple[Block, Block], matrix: sp.csr_array) -> None:
        """The new contact matrix of a block pair: corrected for, or re-factorised later."""
        if self.stale or self.changed or not self.lowrank:
            super().set_contact(pair, matrix)
            return
        self.contact[pair] = matrix
        self.moved.add(pair)
        self.fresh.add(pair)

    def factorise(self) -> None:
        """Correct for the contact changes if that is cheaper, else re-factorise."""
        if not (self.stale or self.changed or self.fresh):
            return  # the factors, and the correction if any, are current
        if self.fresh and not (self.stale or self.changed) and self._update():
            self.fresh = set()
            return
        self._refactorise()

    def _refactorise(self) -> None:
        self.changed |= {b for pair in self.moved for b in pair}
        self.moved, self.fresh, self.correction = set(), set(), Correction()
        super().factorise()
        self.factorised = dict(self.contact)
        self.corrected = dict(self.contact)

    def _delta(self) -> tuple[dict[Block, np.ndarray], sp.csr_array]:
        """J per block and ``M = dC[J, J]`` (sparse) of the changes since the correction."""
        pieces = {}
        for pair in sorted(self.fresh):
            old = self.corrected.get(pair)
            new = self.contact[pair]
            piece = sp.coo_array(new - old if old is not None else new).tocsr().tocoo()
            piece.eliminate_zeros()
            pieces[pair] = piece
        touched: dict[Block, list[np.ndarray]] = {}
        for (a, b), piece in pieces.items():
            touched.setdefault(a, []).append(piece.row)
            touched.setdefault(b, []).append(piece.col)
        dofs = {b: np.unique(np.concatenate(touched[b])) for b in sorted(touched)}
        dofs = {b: J for b, J in dofs.items() if len(J)}
        offsets = np.cumsum([0] + [len(J) for J in dofs.values()])
        where = dict(zip(dofs, offsets[:-1], strict=True))
        rows, cols, data = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0)]
        for (a, b), piece in pieces.items():
            if piece.nnz:
                rows.append(where[a] + np.searchsorted(dofs[a], piece.row))
                cols.append(where[b] + np.searchsorted(dofs[b], piece.col))
                data.append(piece.data)
        k = int(offsets[-1])
        triplets = (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols)))
        return dofs, sp.csr_array(triplets, shape=(k, k))

    def _update(self) -> bool:
        """Add the changes since the correction to it; False: re-factorise instead."""
        start = time.perf_counter()
        dofs, M = self._delta()
        if M.nnz and abs(M - M.T).max() > 1e-12 * abs(M).max():
            return False  # an unsymmetric contact block (friction): re-factorised
        U, D = low_rank(M)
        if not len(D):  # the contact matrices are back to the corrected ones
            return True
        blocks = {b for pair in self.moved for b in pair}
        if self.update_seconds(dofs, len(D)) >= self.refactorise_seconds(blocks):
            return False
        first = len(self.log.records)
        c = self.correction
        c.G = self._extend(c, dofs, U)
        c.pieces.append((dofs, U))
        c.D = np.concatenate([c.D, D])
        c.capacitance = sla.lu_factor(np.eye(c.rank) + c.D[:, None] * c.G, check_finite=False)
        self.corrected = dict(self.contact)
        logged = sum(r.seconds for r in self.log.records[first:])  # the elimination's own
        seconds = time.perf_counter() - start - logged
        flops = 2.0 * M.shape[0] ** 3 / 3.0 + (2.0 / 3.0) * c.rank**3
        self.log.add("lowrank", "dense_update", c.rank, len(D), seconds, flops)
        return True

    # -- the chain ------------------------------------------------------------------------
    def _extend(self, c: Correction, dofs: dict[Block, np.ndarray], U: np.ndarray) -> np.ndarray:
        """``G`` with the columns ``V = E U`` of a new change: forward elimination only.

        With S eliminated group by group (``S = L D L^T``, D the groups' eliminated
        matrices), ``V^T S^-1 V`` is the sum over groups of ``R^T A_GG^-1 R``, R the columns
        of V as they arrive at the group: only the groups they reach are touched, only the
        columns non-zero there, and nothing is back-substituted. The cross terms with the
        earlier changes' columns come from what their elimination kept.
        """
        r0, r = c.rank, U.shape[1]
        columns: dict[Block, np.ndarray] = {}
        start = 0
        for b, J in dofs.items():
            columns[b] = np.zeros((self.sizes[b], r))
            columns[b][J] = U[start : start + len(J)]
            start += len(J)
        G = np.zeros((r0 + r, r0 + r))
        G[:r0, :r0] = c.G
        for grp in self.schedule.flat:
            if not columns.keys() & set(grp.blocks):
                continue
            R = np.vstack([columns.pop(b, np.zeros((self.sizes[b], r))) for b in grp.blocks])
            nz = np.flatnonzero(np.any(R != 0.0, axis=0))
            if not len(nz):
                continue
            X = self._eliminate(grp, R[:, nz])
            new = r0 + nz
            G[np.ix_(new, new)] += X.T @ X if grp.last or not grp.neighbours else R[:, nz].T @ X
            if grp.name in c.kept:
                old, X_old = c.kept[grp.name]
                cross = X_old.T @ (X if grp.last or not grp.neighbours else R[:, nz])
                G[np.ix_(old, new)] += cross
                G[np.ix_(new, old)] += cross.T
                c.kept[grp.name] = (np.concatenate([old, new]), np.hstack([X_old, X]))
            else:
                c.kept[grp.name] = (new, X)
            if grp.last or not grp.neighbours:
                continue
            state = self.state[grp.name]
            assert state.B is not None and state.offsets is not None and state.factor is not None
            pushed = state.factor.product(state.B, X, "lowrank", transpose=True)
            for i, (target, J) in enumerate(state.columns):
                arrived = columns.setdefault(target, np.zeros((self.sizes[target], r)))
                arrived[np.ix_(J, nz)] -= pushed[state.offsets[i] : state.offsets[i + 1]]
        return 0.5 * (G + G.T)

    def _eliminate(self, grp, R: np.ndarray) -> np.ndarray:
        """``L^-1 R`` in the last level (its ``W^T W`` is ``R^T A^-1 R``), else ``A^-1 R``."""
        factor = self.state[grp.name].factor
        assert isinstance(factor, DenseCholesky)  # the symmetric changes are corrected
        start = time.perf_counter()
        n, m = R.shape
        if grp.last or not grp.neighbours:
            X = sla.solve_triangular(factor.factor[0], R, lower=True, check_finite=False)
            flops = float(n * n * m)
        else:
            X = sla.cho_solve(factor.factor, R, check_finite=False)
            flops = 2.0 * n * n * m
        seconds = time.perf_counter() - start
        self.log.add(grp.name, "dense_solve", n, m, seconds, flops, "lowrank")
        return X

    def _reached(self, blocks: set[Block]) -> list:
        """The groups a forward elimination from ``blocks`` passes through."""
        reached, out = set(blocks), []
        for grp in self.schedule.flat:
            if reached & set(grp.blocks):
                out.append(grp)
                reached |= set(grp.neighbours)
        return out

    def _price(self, ops: list[Operation]) -> float:
        """Seconds of ``ops`` by the machine rates; without them, their flops."""
        if self.rates is None:
            return sum(
                o.size**3 / 3.0 if o.kind == "dense_factor" else float(o.size**2 * o.nrhs)
                for o in ops
            )
        from dd_contact.timing import record_seconds  # timing imports the solvers

        return sum(record_seconds(r, self.rates) for r in WorkLog.planned(ops).records)

    def update_seconds(self, dofs: dict[Block, np.ndarray], rank: int) -> float:
        """Price of adding a change of ``rank`` on ``dofs`` to the correction.

        The forward elimination of its columns through the groups they reach (the first
        ones each take their own columns only: priced as all of them, an upper bound), the
        cross terms with the earlier columns, and the LU of the grown capacitance matrix.
        """
        ops, r0 = [], self.correction.rank
        for grp in self._reached(set(dofs)):
            n = sum(self.sizes[b] for b in grp.blocks)
            twice = 1 if grp.last or not grp.neighbours else 3  # A^-1 R, then B^T Y
            ops += twice * [Operation(grp.name, "dense_solve", n, rank, "lowrank")]
            if r0:
                ops.append(Operation(grp.name, "dense_solve", n, max(r0 * rank // n, 1)))
        ops += 2 * [Operation("lowrank", "dense_factor", r0 + rank)]  # an LU: twice the flops
        return self._price(ops)

    def refactorise_seconds(self, blocks: set[Block]) -> float:
        """Price of re-factorising the groups a change on ``blocks`` makes stale."""
        stale = self.schedule.stale_groups(set(blocks))
        factorise = self.schedule.factorise_group
        return self._price(
            [op for g in self.schedule.flat if g.name in stale for op in factorise(g)]
        )

    # -- solving --------------------------------------------------------------------------
    def solve(self, g: dict[str, np.ndarray], complete: bool) -> dict[str, np.ndarray]:
        """Solve ``S' x = g``: through the chain, corrected for the changes since it was made.

        ``x = S^-1 (g - E U z)`` is exact when ``z = D U^T x_J``; the defect of that is the
        residual of ``S' x = g`` (on J, the only rows where S' and S differ), so z is refined
        until it is below :data:`REFINED` (at most :data:`REFINEMENTS` times), and the groups
        are re-factorised if it stays above :data:`UPDATE_TOLERANCE`.
        """
        x = super().solve(g, complete)
        c = self.correction
        if c.capacitance is None:
            return x
        z = np.zeros(c.rank)
        for _ in range(1 + REFINEMENTS):
            defect = c.projected(x) - z
            if np.linalg.norm(defect) <= REFINED * np.linalg.norm(z):
                return x
            z += sla.lu_solve(c.capacitance, defect, check_finite=False)
            x = super().solve(c.shifted(g, z), complete)
        if np.linalg.norm(c.projected(x) - z) <= UPDATE_TOLERANCE * np.linalg.norm(z):
            return x
        self._refactorise()
        return super().solve(g, complete)
