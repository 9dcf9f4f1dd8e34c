"""Low-rank contact changes: a Woodbury correction instead of a re-factorisation.

A contact state change changes the condensed surface system S by the difference of the
contact matrices, ``dC = C_now - C_factorised``, non-zero only on the dofs J that the
changed points' shape functions touch: ``S' = S + E M E^T`` with E the unit columns of J
and ``M = dC[J, J]`` (k x k, symmetric, indefinite when points release). With every factor
of the order's chain kept as it is (each group of each level, the interface's condensed
block included),

    S'^-1 g = S^-1 (g - E z),   (I + M G) z = M (S^-1 g)_J,   G = E^T S^-1 E.

M is kept as ``U D U^T`` (its non-zero eigenpairs: about one per changed point), so the
correction works with ``U`` 's columns: ``U^T G U`` costs one forward elimination of them
through the groups they reach (the group holding J and the later levels it is eliminated
into; no other group and no back-substitution), then an LU of the small capacitance
matrix. A solve is two passes through the chain instead of one, plus refinements. The
correction is on the whole condensed surface system, so it is the same for every order,
and a change re-factorises neither the interface nor the other groups.

Changes accumulate until re-factorising the groups they make stale is priced cheaper than
the correction (:meth:`LowRankSurface.update_seconds`, :data:`UPDATE_MARGIN`, and the
corrected solve's extra passes with the refinements the last ones took,
:meth:`LowRankSurface.solve_seconds`), or until a corrected solve's accuracy degrades: each
one is refined with its true residual, and one whose backward error stays above
:data:`UPDATE_TOLERANCE` re-factorises and solves again. Every later solve pays those extra
passes too: once they add up to the re-factorisation they saved, it is made
(:meth:`LowRankSurface.factorise`), so a correction never costs more than twice that.

Work log: the forward elimination's substitutions are ``"dense_solve"`` records with
``what="lowrank"``, each correction one ``"dense_update"`` record (size its rank): their count
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
from dd_contact.solvers.dense import DenseCholesky
from dd_contact.solvers.schedule import Operation, Schedule
from dd_contact.solvers.surface import Surface, kept_into
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "APPLICATIONS_UNMEASURED",
    "CAPACITANCE_RCOND",
    "EIGEN_FACTORISATIONS",
    "REFINED",
    "REFINEMENTS",
    "REFINEMENTS_KEPT",
    "UPDATES",
    "UPDATE_MARGIN",
    "UPDATE_TOLERANCE",
    "Correction",
    "LowRankSurface",
    "capacitance",
    "low_rank",
    "norm_of",
]

#: The work log's name for the corrections (its row of the work table: their count, size
#: the rank of the last, and their residual products).
UPDATES = "low-rank updates"

#: Largest accepted normwise backward error ``|g - S' x| / (|S'| |x| + |g|)`` of a
#: corrected solve; beyond it the groups are re-factorised and the solve repeated. On the
#: elastic-pin joint a re-factorised solve leaves 1.6e-18 to 2.8e-18, a corrected one 1.4e-18
#: to 1.2e-17 (benchmarks/lowrank_accuracy.py; 2e-17 to 7e-17 on the tests' scenes), one
#: unrefined 1e-17 to 4e-15 (1e-14 to 5e-10 on the tests' scenes): the former 1e-13 let
#: most of those pass. This Frobenius measure reads 30-125x below the whole system's.
UPDATE_TOLERANCE = 1e-15

#: Reciprocal condition numbers of the capacitance matrix ``I + D G``: below the first, the
#: changes (some nearly cancelling) are merged into one; below the second, re-factorised.
#: Releasing a point of penalty kappa from a factor that holds it is ill-conditioned by
#: nature (about 1 / (kappa s), s the compliance there: 1e-6 to 1e-11 at the default
#: penalty); the refinement with the true residual gives the digits back.
CAPACITANCE_RCOND = (1e-10, 1e-14)

#: An update is chosen when priced at most 1 / UPDATE_MARGIN of the re-factorisation: its
#: price counts the BLAS work only, not the eigenproblems of its clusters, the sparse
#: differences and the Python around them (on the 87k elastic-pin joint, updates of rank 200
#: to 700 priced below a re-factorisation measured 1.06 s a change against its 0.69 s).
UPDATE_MARGIN = 3.0

#: Normwise backward error below which a corrected solve is not refined.
REFINED = 1e-16

#: Refinements of a corrected solve at most (each one more pass through the chain).
REFINEMENTS = 3

#: A symmetric eigendecomposition with vectors (LAPACK's syevd, about 4 n^3 flops) priced
#: as this many Cholesky factorisations (n^3 / 3): at a load reversal of the joint with
#: elastic pins a change's cluster is the whole group, whose eigenproblem alone costs more
#: than re-factorising it, so it is priced before it is solved.
EIGEN_FACTORISATIONS = 12

#: Woodbury applications (1 + refinements) a corrected solve is priced at before one was
#: measured; then the mean of the last :data:`REFINEMENTS_KEPT` corrected solves'.
APPLICATIONS_UNMEASURED = 2.0
REFINEMENTS_KEPT = 4


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
        conditioned: Its reciprocal condition number (1-norm, LAPACK's estimate).
        K: A full coupling instead of ``diag(D)`` (friction's unsymmetric correction,
            :mod:`dd_contact.solvers.stuck`), or None.
        points: Per piece, the contact points whose rows its columns are (numbered as
            :meth:`~dd_contact.solvers.pointwise.PointwiseSurface.joined`), or None: unit
            columns or eigenvectors.
    """

    pieces: list[tuple[dict[Block, np.ndarray], np.ndarray]] = field(default_factory=list)
    D: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    kept: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    capacitance: tuple[np.ndarray, np.ndarray] | None = None
    conditioned: float = 1.0  # the capacitance matrix's reciprocal condition number (1-norm)
    K: np.ndarray | None = None  # a full (unsymmetric) coupling instead of diag(D)
    points: list[np.ndarray | None] = field(default_factory=list)
    scale: tuple[np.ndarray, np.ndarray] | None = None  # its factors' row, column scaling

    @property
    def rank(self) -> int:
        """Columns of every change so far."""
        return len(self.D) if self.K is None else len(self.K)

    def solve(self, y: np.ndarray) -> np.ndarray:
        """``(I + D G)^-1 y`` with the capacitance matrix's factors."""
        assert self.capacitance is not None  # factorised before it is applied
        if self.scale is None:
            return sla.lu_solve(self.capacitance, y, check_finite=False)
        rows, cols = self.scale
        return cols * sla.lu_solve(self.capacitance, rows * y, check_finite=False)

    def projected(self, x: dict[str, np.ndarray]) -> np.ndarray:
        """``D U^T x_J``: what the changes apply to ``x``, in the columns' coordinates."""
        parts = [
            U.T @ np.concatenate([x[b][J] for b, J in dofs.items()]) for dofs, U in self.pieces
        ]
        return self.D * np.concatenate(parts) if self.K is None else self.K @ np.concatenate(parts)

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


def capacitance(D: np.ndarray, G: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], float]:
    """LU factors of ``I + D G`` and their reciprocal condition number (1-norm)."""
    C = np.eye(len(D)) + D[:, None] * G
    factors = sla.lu_factor(C, check_finite=False)
    rcond, _ = sla.lapack.dgecon(factors[0], np.abs(C).sum(axis=0).max(), norm="1")
    return factors, float(rcond)


def _flops(o: Operation) -> float:
    """An operation's flops (the price without machine rates)."""
    if o.kind == "dense_factor":
        return o.size**3 / 3.0
    if o.kind == "dense_product" and o.what != "condense":
        return 2.0 * o.size * o.nrhs  # B^T y, B x, S x: one pass over the matrix
    return float(o.size**2 * o.nrhs)


def norm_of(blocks: dict[str, np.ndarray]) -> float:
    """The 2-norm of vectors by block, as one vector."""
    return float(np.sqrt(sum(float(v @ v) for v in blocks.values())))


class LowRankSurface(Surface):
    """A :class:`Surface` that corrects contact changes with Woodbury instead of re-factorising.

    Args:
        schedule, log, recondensed, unsymmetric: As :class:`Surface` (with friction, every
            change is re-factorised: its changes are unsymmetric, its groups LU).
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
        unsymmetric=(),
        rates=None,
        lowrank: bool | None = None,
    ):
        super().__init__(schedule, log, recondensed, unsymmetric)
        self.rates = rates if rates is not None else cached_rates()
        self.lowrank = self.enabled if lowrank is None else lowrank
        #: The contact matrices the factors hold, and those the correction adds up to.
        self.factorised: dict[tuple[Block, Block], sp.csr_array] = {}
        self.corrected: dict[tuple[Block, Block], sp.csr_array] = {}
        self.moved: set[tuple[Block, Block]] = set()  # pairs changed since the factorisation
        self.fresh: set[tuple[Block, Block]] = set()  # pairs changed since the correction
        self.correction = Correction()
        self._solved: dict[str, np.ndarray] | None = None  # the last corrected solve's x
        self._pairs_norm: float | None = None  # |S|_F^2 of the surface pairs
        #: Woodbury applications of the last corrected solves (1 + their refinements).
        self.applications: list[int] = []
        #: Priced seconds the corrected solves spent beyond plain ones since the groups were
        #: factorised, and what re-factorising the groups the correction stands for costs.
        self.extra_seconds, self.break_even = 0.0, np.inf
        self._pass: float | None = None  # price of one complete pass through the chain
        self._residual_price = 0.0  # and of the residual product (priced with it)

    def set_contact(
        self, pair: tuple[Block, Block], matrix: sp.csr_array, stuck: sp.csr_array | None = None
    ) -> None:
        """The new contact matrix of a block pair: corrected for, or re-factorised later."""
        if self.stale or self.changed or not self.lowrank:
            super().set_contact(pair, matrix)
            return
        self.contact[pair] = matrix
        self.moved.add(pair)
        self.fresh.add(pair)

    def factorise(self) -> None:
        """Correct for the contact changes if that is cheaper, else re-factorise."""
        if self.correction.capacitance is not None and self.extra_seconds >= self.break_even:
            self._refactorise()  # the corrected solves have cost what re-factorising saved
            return
        if not (self.stale or self.changed or self.fresh):
            return  # the factors, and the correction if any, are current
        if self.fresh and not (self.stale or self.changed) and self._update():
            self.fresh = set()
            return
        self._refactorise()

    def rebase(self) -> None:
        """A checkpoint: re-factorise at the next solve, as a run resumed from it does.

        Both then step the same numbers bit for bit (a correction differs by round-off).
        """
        if self.moved or self.correction.capacitance is not None:
            self._refactorise()

    def _refactorise(self) -> None:
        self.changed |= {b for pair in self.moved for b in pair}
        self.moved, self.fresh, self.correction = set(), set(), Correction()
        self.extra_seconds, self.break_even = 0.0, np.inf
        super().factorise()
        self.factorised = dict(self.contact)
        self.corrected = dict(self.contact)

    def _delta(self, pairs: set, since: dict) -> tuple[dict[Block, np.ndarray], sp.csr_array]:
        """J per block and ``M = dC[J, J]`` (sparse): the change of ``pairs`` since ``since``."""
        pieces = {}
        for pair in sorted(pairs):
            old = since.get(pair)
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
        """Add the changes since the correction to it; False: re-factorise instead.

        A change that undoes part of an earlier one (a point back in its state) adds the
        opposite term; when that leaves the capacitance matrix ill-conditioned (the terms
        nearly cancel), the correction is built again from every change since the
        factorisation at once, whose rank is then the true one.
        """
        start, first = time.perf_counter(), len(self.log.records)
        blocks = {b for pair in self.moved for b in pair}
        refactorise = self.refactorise_seconds(blocks)
        if self.lu:  # friction: its changes are unsymmetric, its groups' factors LU
            return False
        dofs, M = self._delta(self.fresh, self.corrected)
        if UPDATE_MARGIN * self.eigen_seconds(M) >= refactorise:
            return False  # its eigenproblems alone cost more: not solved to be thrown away
        U, D = low_rank(M)
        if not len(D):  # the contact matrices are back to the corrected ones
            return True
        price = UPDATE_MARGIN * self.update_seconds(dofs, len(D), self.correction.rank)
        if price + self.solve_seconds() >= refactorise:
            return False
        c = self._extended(self.correction, dofs, U, D)
        if c.conditioned < CAPACITANCE_RCOND[0] and self.correction.rank:
            dofs, M = self._delta(self.moved, self.factorised)
            if UPDATE_MARGIN * self.eigen_seconds(M) >= refactorise:
                return False
            U, D = low_rank(M)
            if not len(D):
                self.correction, self.corrected = Correction(), dict(self.contact)
                return True
            if UPDATE_MARGIN * self.update_seconds(dofs, len(D), 0) + self.solve_seconds() >= (
                refactorise
            ):
                return False
            c = self._extended(Correction(), dofs, U, D)
        if c.conditioned < CAPACITANCE_RCOND[1]:
            return False
        self.correction, self.corrected = c, dict(self.contact)
        self.break_even = refactorise
        logged = sum(r.seconds for r in self.log.records[first:])  # the elimination's own
        seconds = time.perf_counter() - start - logged
        flops = 2.0 * M.shape[0] ** 3 / 3.0 + (2.0 / 3.0) * c.rank**3
        self.log.add(UPDATES, "dense_update", c.rank, len(D), seconds, flops)
        return True

    def _extended(self, c: Correction, dofs, U: np.ndarray, D: np.ndarray) -> Correction:
        """A correction with a new change's columns added to ``c``'s (``c`` unchanged)."""
        out = Correction(list(c.pieces), c.D, c.G, dict(c.kept))
        out.G = self._extend(out, dofs, U)
        out.pieces.append((dofs, U))
        out.D = np.concatenate([c.D, D])
        out.capacitance, out.conditioned = capacitance(out.D, out.G)
        return out

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
            kept_into(
                c.kept, G, grp.name, r0 + nz, X, X if grp.last or not grp.neighbours else R[:, nz]
            )
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
            X = factor.half(R, 1)  # in the factor's order, as the solve's forward half
            flops = float(n * n * m)
        else:
            X = factor.substitute(R)
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
            return sum(_flops(o) for o in ops)
        from dd_contact.timing import record_seconds  # timing imports the solvers

        return sum(record_seconds(r, self.rates) for r in WorkLog.planned(ops).records)

    def update_seconds(self, dofs: dict[Block, np.ndarray], rank: int, r0: int) -> float:
        """Price of adding a change of ``rank`` on ``dofs`` to a correction of rank ``r0``.

        The forward elimination of its columns through the groups they reach (the first
        ones each take their own columns only: priced as all of them, an upper bound), the
        cross terms with the earlier columns, and the LU of the grown capacitance matrix.
        """
        ops = []
        for grp in self._reached(set(dofs)):
            n = sum(self.sizes[b] for b in grp.blocks)
            twice = 1 if grp.last or not grp.neighbours else 3  # A^-1 R, then B^T Y
            ops += twice * [Operation(grp.name, "dense_solve", n, rank, "lowrank")]
            if r0:
                ops.append(Operation(grp.name, "dense_solve", n, max(r0 * rank // n, 1)))
        ops += 2 * [Operation(UPDATES, "dense_factor", r0 + rank)]  # an LU: twice the flops
        return self._price(ops)

    def eigen_seconds(self, M: sp.csr_array) -> float:
        """Price of :func:`low_rank` 's eigenproblems on ``M``.

        One per connected cluster, :data:`EIGEN_FACTORISATIONS` Cholesky factorisations each.
        """
        _, labels = connected_components(M, directed=False)
        clusters = [Operation(UPDATES, "dense_factor", int(n)) for n in np.bincount(labels)]
        return EIGEN_FACTORISATIONS * self._price(clusters)

    def solve_seconds(self, applications: float | None = None) -> float:
        """Price of a corrected solve beyond a plain one (one pass through the chain).

        ``applications`` of Woodbury (1 + refinements; default: the mean of the last
        corrected solves', :data:`APPLICATIONS_UNMEASURED` before any), each two complete
        passes and a residual product of the surface pairs.
        """
        if applications is None:
            kept = self.applications[-REFINEMENTS_KEPT:]
            applications = float(np.mean(kept)) if kept else APPLICATIONS_UNMEASURED
        if self._pass is None:
            chain = self.schedule.forward(set(), True) + self.schedule.back_substitution()
            self._pass = self._price(chain)
            sizes = self.sizes
            residual = [
                Operation(UPDATES, "dense_product", sizes[a], sizes[b], "residual")
                for a, b in self.schedule.pairs
            ]
            self._residual_price = self._price(residual)
        return (2.0 * applications - 1.0) * self._pass + applications * self._residual_price

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

        With a correction, every block is solved for (``complete`` or not) and checked by
        its normwise backward error ``|g - S' x| / (|S'| |x| + |g|)`` (Frobenius norms; the
        residual from the surface pairs and contact matrices times x): refined while it is
        above :data:`REFINED` and falling, at most :data:`REFINEMENTS` times. A release of a
        stiff contact point subtracts a penalty from a factor that holds it, which loses
        digits the refinement gives back. Above :data:`UPDATE_TOLERANCE` (a re-factorised
        Cholesky solve stays near 1e-18), the groups are re-factorised and the solve
        repeated.
        """
        self._solved = None
        c = self.correction
        if c.capacitance is None:
            return super().solve(g, complete)
        x = self._corrected(c, g)
        size, before = norm_of(g), np.inf
        for refinement in range(REFINEMENTS + 1):
            r = self._residual(g, x)
            error = norm_of(r) / (self._matrix_norm() * norm_of(x) + size)
            if error <= REFINED or error > 0.5 * before or refinement == REFINEMENTS:
                break
            before = error
            dx = self._corrected(c, r)
            x = {b: v + dx[b] for b, v in x.items()}
        self.applications.append(refinement + 1)
        self.extra_seconds += self.solve_seconds(refinement + 1)
        if error > UPDATE_TOLERANCE:
            self._refactorise()
            return super().solve(g, complete)
        self._solved = x
        return x

    def _matrix_norm(self) -> float:
        """``|S'|`` (Frobenius): the surface pairs' (kept until S changes) and the contact's."""
        if self._pairs_norm is None:
            squares = 0.0
            for pair in self.schedule.pairs:
                matrix = self._schur_pair(pair)
                squares += 0.0 if matrix is None else float(np.sum(matrix * matrix))
            self._pairs_norm = squares
        contact = sum(float(np.sum(m.data * m.data)) for m in self.contact.values())
        return float(np.sqrt(self._pairs_norm + contact))

    def set_condensed(self, block: Block, Z: np.ndarray) -> None:
        """A subdomain's new condensation (S changes: its norm is taken again)."""
        super().set_condensed(block, Z)
        self._pairs_norm = None

    def _corrected(self, c: Correction, g: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Woodbury: ``S^-1 (g - E U z)`` with ``(I + D G) z = D U^T (S^-1 g)_J``."""
        x = super().solve(g, True)
        z = c.solve(c.projected(x))
        return super().solve(c.shifted(g, z), True)

    def _residual(
        self, g: dict[str, np.ndarray], x: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """``g - S' x``: the surface pairs (S) and the contact matrices times x."""
        start = time.perf_counter()
        r = {b: v.copy() for b, v in g.items()}
        for a, b in self.schedule.pairs:
            matrix = self._schur_pair((a, b))
            if matrix is not None:
                r[a] -= matrix @ x[b]
        for (a, b), matrix in self.contact.items():
            r[a] -= matrix @ x[b]
        n, seconds = sum(map(len, x.values())), time.perf_counter() - start
        self.log.add(UPDATES, "dense_product", n, n, seconds, 2.0 * n * n, "residual")
        return r

    def back_substitute(self, x: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The earlier levels: solved already if the last solve was corrected."""
        if self._solved is not None:
            return {**x, **{b: v for b, v in self._solved.items() if b not in x}}
        return super().back_substitute(x)
