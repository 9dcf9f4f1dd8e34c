"""Contact pairs' changes corrected point by point against the factorised state.

A frictionless pair's contact matrix is ``F^T diag(a) F``, one row of F per contact point
(:attr:`dd_contact.blocks.ContactRegion.points`), a its active flags. The contact matrices
of any state therefore differ from those the groups were factorised with (the *reference*
state) by ``V D V^T``: V the rows of the points whose flag differs from the reference's,
D = +1 where a point is active now and was not then, -1 the other way. The surface
corrects with Woodbury as :class:`~dd_contact.solvers.lowrank.LowRankSurface` does, but

* with no eigenproblem: a change's columns are its points' own rows;
* against the reference, not the last corrected state: the forward elimination of a
  point's column through the chain, and its products with the other points' columns
  (``G = V^T S^-1 V``), are computed the first time the point differs from the reference
  and kept until the groups are re-factorised. A change then costs the LU of ``I + D G``
  over the points that differ from the reference, plus the elimination of points that
  never differed before; no group is re-factorised, the interface neither.

When the points' columns reach the last level alone (their blocks are eliminated last, as
a contact interface's in w-u and w-v-u), their kept elimination is ``W = L^-1 V`` and a
corrected solve is one pass, a plain solve's substitutions with ``W z`` subtracted between
them (:meth:`PointwiseSurface.solve`), checked by its residual on the points' rows: it costs
no more than a solve after re-factorising. Points much stiffer than the rest (the bar on its
wall) leave that answer short of the tolerance; it is refined with its true residual, one
more pass each, priced, and re-factorised once that has cost a re-factorisation.
Everything else is :class:`LowRankSurface` 's (the price rule, the two-pass corrected solve).
A change of a region without point rows (an obstacle) on blocks apart from the pairs' joins
the points' correction as the eigenvectors of its change since the factorisation; one on
blocks that a region without point rows fills too is corrected from the matrices by
:class:`LowRankSurface`; with friction against an obstacle,
:class:`~dd_contact.solvers.stuck.StuckSurface` puts the points' columns in its correction
beside the slip's unit columns.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from dd_contact.blocks import Block
from dd_contact.solvers.dense import DenseCholesky
from dd_contact.solvers.lowrank import (
    CAPACITANCE_RCOND,
    REFINEMENTS,
    REFINEMENTS_KEPT,
    UPDATE_MARGIN,
    UPDATE_TOLERANCE,
    UPDATES,
    Correction,
    LowRankSurface,
    low_rank,
    norm_of,
)
from dd_contact.solvers.pointkernels import PointCorrection, forward_columns, local_rows
from dd_contact.solvers.schedule import Operation
from dd_contact.solvers.surface import Surface, kept_into

__all__ = ["CACHE_BUDGET", "POINT_APPLICATIONS", "PointwiseSurface"]

#: The eliminations of the points kept with a factorisation (each point's once, reused by
#: every later change until the groups are re-factorised) may cost this many times the
#: re-factorisation a change would make, in all; beyond it a change re-factorises.
CACHE_BUDGET = 2.0

#: Woodbury applications a corrected solve is priced at before one was measured: the
#: capacitance matrix is formed from the points' exact rows and the chain's own
#: eliminations (the 87k joint with elastic pins: one application, no refinement, in every
#: corrected solve, its reciprocal condition number 1e-4).
POINT_APPLICATIONS = 1.0


class PointwiseSurface(LowRankSurface):
    """A :class:`LowRankSurface` that corrects contact pairs' changes point by point.

    Attributes:
        regions: Per region with point rows, the blocks its matrix couples.
        active: Per such region, its points' present flags (``None``: unknown).
        reference: Per such region, the flags the groups were factorised with.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.regions: dict[str, tuple[Block, ...]] = {}
        self.active: dict[str, np.ndarray | None] = {}
        self.reference: dict[str, np.ndarray] = {}
        self._rows: list[tuple[str, list, sp.csr_array]] = []  # as added
        self._points: tuple[sp.csc_array, list, dict[str, int]] | None = None  # all, joined
        self._cache = Correction()  # the points eliminated so far: their G and kept columns
        self._cached: dict[int, int] = {}  # a point's column (in P) -> its column in the cache
        self._pending = np.zeros(0, int)  # P's columns given a cache column, not eliminated yet
        self._scratches: dict[str, np.ndarray] = {}  # per group, for their elimination
        self._spaces: dict[str, np.ndarray] = {}  # per group, for their kept columns
        self._invested = 0.0  # priced seconds of the eliminations kept with the reference
        self._saved = 0.0  # priced re-factorisations the updates since then saved
        self._prices: dict[tuple, float] = {}  # lists of operations, priced
        self._reach: np.ndarray | None = None  # per group of the chain, the columns reaching it
        self._orders: dict[str, np.ndarray | None] = {}  # per group, its rows' (points' last)
        self._refinements: list[int] = []  # of the last one-pass corrected solves
        # priced refinements since the factorisation, and its price then (:meth:`factorise`)
        self._refined, self._refactorise_price = 0.0, np.inf

    def add_points(self, name: str, parts: list[tuple[Block, np.ndarray]], rows) -> None:
        """A region's point rows, numbered as its matrix (``parts`` one after the other)."""
        self.regions[name] = tuple(block for block, _ in parts)
        self._rows.append((name, parts, sp.csr_array(rows)))
        self._points, self._orders = None, {}

    def _row_order(self, g) -> np.ndarray | None:
        """A last-level group's rows with those the points touch last.

        A first flip's columns are eliminated from their first non-zero row on
        (:meth:`_eliminate`, :meth:`_forward_last`), so through the trailing triangle of the
        touched rows alone (the bar's end on its wall: its 369 normal dofs of 1,107 rows).
        """
        if g.name not in self._orders:
            n, order = sum(self.sizes[b] for b in g.blocks), None
            if self._rows and (g.last or not g.neighbours):
                P, at, _ = self.joined()
                touched_rows = np.unique(P.indices[P.data != 0.0])
                local = local_rows(g.blocks, self.sizes, touched_rows, dict(at))
                touched = np.zeros(n, bool)
                touched[local[local >= 0]] = True
                order = np.concatenate([np.flatnonzero(~touched), np.flatnonzero(touched)])
            same = order is None or np.array_equal(order, np.arange(n))
            self._orders[g.name] = None if same else order
        return self._orders[g.name]

    def joined(self) -> tuple[sp.csc_array, list[tuple[Block, slice]], dict[str, int]]:
        """Every region's points as columns over their blocks, one block after the other.

        Returns the columns, each block with its rows, and each region's first column.
        """
        if self._points is None:
            blocks = sorted({b for _, parts, _ in self._rows for b, _ in parts})
            ends = np.cumsum([self.sizes[b] for b in blocks])
            offset = {b: int(e) - self.sizes[b] for b, e in zip(blocks, ends, strict=True)}
            at = [(b, slice(offset[b], int(e))) for b, e in zip(blocks, ends, strict=True)]
            rows, cols, data, first, count = [], [], [], {}, 0
            for name, parts, F in self._rows:
                starts = np.cumsum([0] + [len(dofs) for _, dofs in parts])
                coo = sp.coo_array(F)
                places = np.concatenate([offset[b] + dofs for b, dofs in parts])
                assert len(places) == starts[-1]  # the matrix's numbering
                rows.append(places[coo.col])
                cols.append(count + coo.row)
                data.append(coo.data)
                first[name], count = count, count + F.shape[0]
            shape = (int(ends[-1]) if len(ends) else 0, count)
            triplets = (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols)))
            P = sp.csc_array(triplets, shape=shape)
            P.sum_duplicates()
            self._points, self._reach = (P, at, first), None
        return self._points

    def _columns(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rows where P's columns ``ids`` are non-zero (sorted), and those columns there.

        From P's compressed columns directly: a change's few points, not a sparse slice.
        """
        P = self.joined()[0]
        starts, counts = P.indptr[ids], np.diff(P.indptr)[ids]
        take = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
        rows, place = np.unique(P.indices[take], return_inverse=True)
        values = np.zeros((len(rows), len(ids)))
        values[place, np.repeat(np.arange(len(ids)), counts)] = P.data[take]
        return rows, values

    def _dofs(self, rows: np.ndarray) -> dict[Block, np.ndarray]:
        """Rows of the joined numbering (sorted) as each block's dofs."""
        at, dofs = self.joined()[1], {}
        for b, where in at:
            lo, hi = np.searchsorted(rows, (where.start, where.stop))
            if hi > lo:
                dofs[b] = rows[lo:hi] - where.start
        return dofs

    def _price(self, ops: list[Operation]) -> float:
        """As :class:`LowRankSurface` 's, kept per list of operations (the rates do not change)."""
        key = tuple(ops)
        if key not in self._prices:
            self._prices[key] = super()._price(ops)
        return self._prices[key]

    def set_active(self, name: str, active: np.ndarray | None) -> None:
        """A region's present flags (sent with its matrix; ``None``: unknown)."""
        self.active[name] = None if active is None else np.array(active, bool)

    def factorise(self) -> None:
        """As :class:`LowRankSurface`; re-factorised once the refinements cost one.

        One-pass solves refined for stiff points the reference lacks (the bar on its wall)
        go on being refined while they differ from it: once that has cost a
        re-factorisation, the groups are factorised with the present state, which holds them.
        """
        if self._refined < self._refactorise_price or not self.correction.rank:
            super().factorise()
        else:
            self._refactorise()

    def _refactorise(self) -> None:
        super()._refactorise()
        self.reference = {n: a.copy() for n, a in self.active.items() if a is not None}
        self._cache, self._cached, self._pending = Correction(), {}, np.zeros(0, int)
        self._invested = self._saved = 0.0
        self._refined, self._refactorise_price = 0.0, np.inf

    def elimination_seconds(self, ids: np.ndarray, r0: int) -> float:
        """Price of eliminating P's columns ``ids`` forward and their products with ``r0`` kept.

        Each group is priced with the columns that reach it: its own blocks' and those its
        earlier groups push into it.
        """
        reach = self._reached_by()[:, ids]
        ops = []
        for grp, here in zip(self.schedule.flat, reach, strict=True):
            if not (count := int(np.count_nonzero(here))):
                continue
            n = sum(self.sizes[b] for b in grp.blocks)
            twice = 1 if grp.last or not grp.neighbours else 3  # A^-1 R, then B^T Y
            ops += twice * [Operation(grp.name, "dense_solve", n, count, "lowrank")]
            if r0:
                ops.append(Operation(grp.name, "dense_solve", n, max(r0 * count // n, 1)))
        return self._price(ops)

    def _reached_by(self) -> np.ndarray:
        """Per group of the chain (flat), which of P's columns its forward elimination reaches."""
        if self._reach is None:
            P, at, _ = self.joined()
            column = np.repeat(np.arange(P.shape[1]), np.diff(P.indptr))
            reach: dict[Block, np.ndarray] = {}
            for b, rows in at:
                inside = (P.indices >= rows.start) & (P.indices < rows.stop)
                reach[b] = np.bincount(column[inside], minlength=P.shape[1]) > 0
            out = np.zeros((len(self.schedule.flat), P.shape[1]), bool)
            for k, grp in enumerate(self.schedule.flat):
                for b in grp.blocks:
                    out[k] |= reach.pop(b, False)
                for r in grp.neighbours:
                    reach[r] = reach.get(r, False) | out[k]
            self._reach = out
        return self._reach

    def flags(self) -> tuple[np.ndarray, np.ndarray]:
        """The points' present flags and where they differ from the reference (P's columns)."""
        P, _, offset = self.joined()
        now = np.zeros(P.shape[1], bool)
        changed = np.zeros(P.shape[1], bool)
        for n, flags in self.active.items():
            if n in offset and flags is not None and n in self.reference:
                now[offset[n] : offset[n] + len(flags)] = flags
                changed[offset[n] : offset[n] + len(flags)] = flags != self.reference[n]
        return now, changed

    def _filled(self) -> tuple[set, set] | None:
        """The block pairs the regions with point rows fill, and those the others fill.

        ``None``: no such region, or one whose flags are not known against the reference.
        """
        if not self.regions or any(
            self.active.get(n) is None or n not in self.reference for n in self.regions
        ):
            return None
        pointed = {(a, b) for blocks in self.regions.values() for a in blocks for b in blocks}
        others = {
            (a, b)
            for name, blocks in self.schedule.regions.items()
            if name not in self.regions
            for a in blocks
            for b in blocks
        }
        return pointed, others

    def _pointwise(self) -> bool:
        """Whether every contact change since the factorisation is known point by point."""
        if (filled := self._filled()) is None:
            return False
        pointed, others = filled
        return self.moved <= pointed and not self.moved & others

    def _separable(self) -> set[tuple[Block, Block]] | None:
        """The pairs the regions with point rows fill, if no other region fills them too."""
        if self.lu or (filled := self._filled()) is None:
            return None
        pointed, others = filled
        return None if pointed & others else pointed

    def _update(self) -> bool:
        """Correct point by point where every change is known so; else as LowRankSurface.

        Changes of both kinds (a pair's and an obstacle's, on blocks apart): the points'
        rows, and the eigenvectors of the other regions' change since the factorisation.
        """
        if self._pointwise() and not self.lu:
            return self._point_update(set())
        if (pointed := self._separable()) is not None:
            return self._point_update(self.moved - pointed)
        if isinstance(self.correction, PointCorrection):
            return False  # not to be mixed with a correction from matrices: re-factorise
        return super()._update()

    def _point_update(self, rest: set[tuple[Block, Block]]) -> bool:
        """The correction of the points that differ from the reference; False: re-factorise.

        With it, ``rest`` 's change since the factorisation (pairs without point rows).
        Points eliminated for the first time are given their cache columns here and, where
        the corrected solve is one pass, eliminated by it (:meth:`_forward_last`).
        """
        start, first = time.perf_counter(), len(self.log.records)
        refactorise = self.refactorise_seconds({b for pair in self.moved for b in pair})
        now, changed = self.flags()
        ids = np.flatnonzero(changed)
        dofs: dict[Block, np.ndarray] = {}
        U, D = np.zeros((0, 0)), np.zeros(0)
        if rest:  # the other regions' change: its eigenvectors, as LowRankSurface's
            dofs, M = self._delta(rest, self.factorised)
            if UPDATE_MARGIN * self.eigen_seconds(M) >= refactorise:
                return False
            U, D = low_rank(M)
        if not len(ids) + len(D):  # back to the factorised state
            self.correction, self.corrected = Correction(), dict(self.contact)
            return True
        missing = np.array([i for i in ids.tolist() if i not in self._cached], dtype=int)
        price = self.update_seconds(dofs, len(D), len(ids))  # rest's elimination, the LU
        earlier = [not grp.last for grp in self.schedule.flat]
        one_pass = not len(D) and not self._reached_by()[earlier][:, ids].any()
        # a corrected solve of one pass costs a plain one's and its refinements (:meth:`solve`)
        solve = (
            self._refinement_seconds()
            if one_pass
            else self.solve_seconds(None if self.applications else POINT_APPLICATIONS)
        )
        if UPDATE_MARGIN * price + solve >= refactorise:
            return False
        if len(missing):  # eliminated once, kept with the reference: an investment, budgeted
            invest = self._invested + self.elimination_seconds(missing, self._cache.rank)
            if invest > CACHE_BUDGET * refactorise:
                return False
            self._invested = invest
            self._cached.update((i, len(self._cached)) for i in missing.tolist())
            self._pending = np.concatenate([self._pending, missing])
        if not (one_pass and self._cache.kept.keys() <= {g.name for g in self.schedule.groups[-1]}):
            self._flush()  # the solve does not eliminate them: now
        where = np.array([self._cached[i] for i in ids.tolist()], dtype=int)
        rows, values = self._columns(ids)
        c = PointCorrection(D=np.where(now[ids], 1.0, -1.0), rows=rows, values=values)
        c.at = self.joined()[1]
        if len(self._pending):  # made by the first solve, which eliminates the new points
            c.slots = where
        elif not self._completed(c, where, dofs, U, D):
            return False
        self.correction, self.corrected = c, dict(self.contact)
        self._refactorise_price = refactorise
        # every update saved a re-factorisation: the corrected solves may cost them all
        self._saved += refactorise
        self.break_even = self._saved
        logged = sum(r.seconds for r in self.log.records[first:])  # the elimination's own
        seconds = time.perf_counter() - start - logged
        self.log.add(UPDATES, "dense_update", c.rank, len(missing), seconds, 2.0 * c.rank**3 / 3)
        return True

    def _completed(self, c: PointCorrection, where, dofs, U: np.ndarray, D: np.ndarray) -> bool:
        """``c`` 's G (its points' cache columns ``where``), its factors; False: ill-conditioned.

        With ``rest`` 's columns ``(dofs, U, D)`` eliminated beside the kept points' (not kept).
        """
        if len(D):
            cache = Correction(G=self._cache.G, kept=dict(self._cache.kept), D=self._cache.D)
            G = self._extend(cache, dofs, U)
            where = np.concatenate([where, self._cache.rank + np.arange(len(D))])
            c.pieces, c.D = [(dofs, U)], np.concatenate([c.D, D])
        else:
            G = self._cache.G
        c.G = G[np.ix_(where, where)]
        c.last = None if len(D) else self._last_columns(where)
        c.slots = None
        c.factorise()
        return c.conditioned >= CAPACITANCE_RCOND[1]

    def _flush(self) -> None:
        """Eliminate the points given cache columns and not eliminated yet."""
        if len(self._pending):
            self._keep(self._pending)
            self._pending = np.zeros(0, int)

    def _keep(self, ids: np.ndarray) -> None:
        """Eliminate P's columns ``ids`` forward and keep them (and their G) with the cache."""
        rows, U = self._columns(ids)
        self._cache.G = self._extend(self._cache, self._dofs(rows), U)
        self._cache.D = np.concatenate([self._cache.D, np.ones(len(ids))])

    def _eliminate(self, grp, R: np.ndarray) -> np.ndarray:
        """As :class:`LowRankSurface` 's; in the last level from R's first non-zero row on.

        ``L^-1 R`` is zero above it, and a few points' columns often start part-way down.
        """
        if not (grp.last or not grp.neighbours):
            return super()._eliminate(grp, R)
        factor = self.state[grp.name].factor
        assert isinstance(factor, DenseCholesky)  # the symmetric changes are corrected
        start, (n, m), R = time.perf_counter(), R.shape, factor.into_order(R)
        lead = int(np.argmax(np.any(R != 0.0, axis=1)))
        X = np.zeros_like(R)
        L = factor.factor[0].T[lead:, lead:]  # LAPACK's upper factor, as DenseCholesky's
        X[lead:] = sla.lapack.dtrtrs(L, R[lead:], lower=0, trans=1)[0]
        seconds, flops = time.perf_counter() - start, float((n - lead) ** 2 * m)
        self.log.add(grp.name, "dense_solve", n - lead, m, seconds, flops, "lowrank")
        return X

    def _last_columns(self, where: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
        """Per last-level group, which cached columns ``where`` reach it and their ``L^-1 V``.

        None if one reaches an earlier level (its kept columns are ``A^-1 R`` there).
        """
        last = {grp.name for grp in self.schedule.groups[-1]}
        if not self._cache.kept.keys() <= last:
            return None
        out = {}
        for name, (columns, X) in self._cache.kept.items():
            place = np.full(self._cache.rank, -1)
            place[columns] = np.arange(len(columns))
            found = place[where]
            mask = found >= 0
            if not mask.any():
                continue
            here = found[mask]  # a run of kept columns (a first flip's): a view, no copy
            run = here[-1] - here[0] + 1 == len(here) and np.all(np.diff(here) == 1)
            out[name] = (mask, X[:, here[0] : here[-1] + 1] if run else X[:, here])
        return out

    def solve(self, g: dict[str, np.ndarray], complete: bool) -> dict[str, np.ndarray]:
        """Solve ``S' x = g``; a point correction on the last level alone in one pass.

        With ``S = L L^T`` there (the earlier levels eliminated as in a plain solve) and
        ``W = L^-1 V`` kept, ``S'^-1 = L^-T (I - W (I + D G)^-1 D W^T) L^-1``: the forward
        and back substitutions of a plain solve with ``W z`` subtracted between them. Its
        residual ``g - S' x`` is ``V (z - D V^T x)`` (the points' rows alone) plus the
        substitutions' round-off, a plain solve's and ``eps |L| |W z|`` (bounded with
        ``|L|_F^2 <= sqrt(n) |S'|_F``). That bound reads 2e-16 to 3e-16 where the true
        backward error is 8e-18 to 4e-17 (the 1/16 bar's releases). Above
        :data:`~dd_contact.solvers.lowrank.UPDATE_TOLERANCE` the answer is refined with its
        true residual, each refinement one more pass (points much stiffer than the rest of
        S, added to or released from it, cancel digits in ``W z``: the bar on its wall in
        w-u, 189 points against a factor without them, missed by 1e6 in one pass and met
        it after one refinement); if it stays above after
        :data:`~dd_contact.solvers.lowrank.REFINEMENTS`, the solve is made again as
        :class:`LowRankSurface` 's (two passes, refined, re-factorised if it stays
        inaccurate). Otherwise as :class:`LowRankSurface`.
        """
        c = self.correction
        lazy = isinstance(c, PointCorrection) and c.slots is not None
        if not lazy and (
            not isinstance(c, PointCorrection) or c.last is None or c.capacitance is None
        ):
            return super().solve(g, complete)
        assert isinstance(c, PointCorrection)
        self._solved = None
        u = self._forward_last(self.forward(g))
        if lazy and not self._completed(c, c.slots, {}, np.zeros((0, 0)), np.zeros(0)):
            self._refactorise()  # its capacitance matrix is ill-conditioned
            return super().solve(g, complete)
        if c.last is None:
            return super().solve(g, complete)
        size, scale, passes = self._matrix_norm(), norm_of(g), 1
        x, lost = self._one_pass(c, u, size)
        while lost > UPDATE_TOLERANCE * (size * norm_of(x) + scale):
            if passes > REFINEMENTS:
                return super().solve(g, complete)
            # every block: the residual reads the pairs of the earlier levels too
            x.update(Surface.back_substitute(self, x))
            r = self._residual(g, x)
            d, lost = self._one_pass(c, self._forward_last(self.forward(r)), size)
            d.update(Surface.back_substitute(self, d))
            x = {b: v + d[b] for b, v in x.items()}
            lost += np.finfo(float).eps * (size * norm_of(x) + scale)  # r's own
            passes += 1
        self.applications.append(1)
        self._refinements = [*self._refinements[-REFINEMENTS_KEPT + 1 :], passes - 1]
        self.extra_seconds += (passes - 1) * self.solve_seconds(1.0)  # toward re-factorising
        self._refined += (passes - 1) * self.solve_seconds(1.0)
        if complete and passes == 1:  # else the earlier levels wait for back_substitute
            x.update(Surface.back_substitute(self, x))
        if complete or passes > 1:  # a refined x has every block (the earlier levels' state
            self._solved = x  # is the refinement's now: not to be back-substituted again)
        return x

    def _refinement_seconds(self) -> float:
        """Price of a one-pass corrected solve's refinements (the last few solves' mean)."""
        mean = float(np.mean(self._refinements)) if self._refinements else 0.0
        return mean * self.solve_seconds(1.0)

    def _one_pass(
        self, c: PointCorrection, u: dict[str, np.ndarray], size: float
    ) -> tuple[dict[str, np.ndarray], float]:
        """The last level's blocks of ``S'^-1 h`` and a bound on its residual's norm.

        ``u`` is ``L^-1 h`` there (changed in place), ``size`` is ``|S'|_F``; the bound is
        :meth:`solve` 's.
        """
        assert c.last is not None  # a one-pass correction
        t = np.zeros(c.rank)
        for grp in self.schedule.groups[-1]:
            if grp.name in c.last:
                mask, X = c.last[grp.name]
                t[mask] += X.T @ u[grp.name]
        z, lost = c.solve(c.D * t), 0.0
        x: dict[str, np.ndarray] = {}
        for grp in self.schedule.groups[-1]:
            if grp.name in c.last:
                mask, X = c.last[grp.name]
                Wz = X @ z[mask]
                u[grp.name] -= Wz
                n = len(Wz)
                lost += np.sqrt(np.sqrt(n) * size) * float(np.linalg.norm(Wz))
            self._split(grp, self._half(grp, u[grp.name], 0), x)
        e = c.values @ (c.D * c.points_of(x) - z)
        return x, float(np.linalg.norm(e) + np.finfo(float).eps * lost)

    def _forward_last(self, h: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``L^-1 h`` per last-level group, the points not eliminated yet beside it.

        A substitution through a large dense factor costs its reading from memory more than
        its flops: the new points' columns ride along the solve's own, one reading for both
        (on the 306k bar's 1,107-row group, read apart they cost 0.2-1.5 ms). They join the
        cache as :meth:`_keep` would add them.
        """
        u, pending = {}, self._pending
        if len(pending):
            rows, values = self._columns(pending)
            at, r0 = dict(self.joined()[1]), self._cache.rank
            G = np.zeros((r0 + len(pending), r0 + len(pending)))
            G[:r0, :r0] = self._cache.G
        for grp in self.schedule.groups[-1]:
            b = np.concatenate([h[block] for block in grp.blocks])
            local = local_rows(grp.blocks, self.sizes, rows, at) if len(pending) else None
            if local is None or not (inside := local >= 0).any():
                u[grp.name] = self._half(grp, b, 1)
                continue
            here, factor = values[inside], self.state[grp.name].factor
            assert isinstance(factor, DenseCholesky)  # a point correction's groups: symmetric
            cols = np.flatnonzero(np.any(here != 0.0, axis=0))
            B = self._scratch(grp.name, len(b), 1 + len(cols))
            B[:, 0] = factor.into_order(b)  # the factor's order, as the kept columns
            B[factor.rows(local[inside])[:, None], 1 + np.arange(len(cols))] = here[:, cols]
            X = self._columns_forward(grp, B)
            u[grp.name] = X[:, 0].copy()  # the scratch is written again by the next one
            if grp.name not in self._cache.kept:  # its kept columns: in the group's space
                self._cache.kept[grp.name] = (np.zeros(0, int), self._space(grp)[:, :0])
            kept_into(self._cache.kept, G, grp.name, r0 + cols, X[:, 1:], X[:, 1:], spare=True)
        if len(pending):
            self._cache.G = 0.5 * (G + G.T)
            self._cache.D = np.concatenate([self._cache.D, np.ones(len(pending))])
            self._pending = np.zeros(0, int)
        return u

    def _space(self, grp) -> np.ndarray:
        """Room for the group's kept columns: every point that reaches it.

        Kept across factorisations: a new array's pages fault in at first write (0.1-0.2 ms
        a first flip at 1/4).
        """
        if grp.name not in self._spaces:
            k = self.schedule.flat.index(grp)
            count = int(np.count_nonzero(self._reached_by()[k]))
            n = sum(self.sizes[b] for b in grp.blocks)
            self._spaces[grp.name] = np.zeros((n, count), order="F")
        return self._spaces[grp.name]

    def _scratch(self, name: str, n: int, m: int) -> np.ndarray:
        """A zero n x m Fortran-ordered array kept per group (a fresh one costs page faults)."""
        if name not in self._scratches or self._scratches[name].shape[1] < m:
            self._scratches[name] = np.zeros((n, max(m, 64)), order="F")
        B = self._scratches[name][:, :m]
        B[:] = 0.0
        return B

    def _columns_forward(self, grp, B: np.ndarray) -> np.ndarray:
        """``L^-1 B``, each column from its first non-zero row (B overwritten)."""
        factor = self.state[grp.name].factor
        assert isinstance(factor, DenseCholesky)  # a point correction's groups: symmetric
        start, (n, m) = time.perf_counter(), B.shape
        flops = forward_columns(factor.factor[0], B)
        self.log.add(grp.name, "dense_solve", n, m, time.perf_counter() - start, flops, "x")
        return B

    def _half(self, grp, b: np.ndarray, trans: int) -> np.ndarray:
        """``L^-1 b`` (``trans`` 1) or ``L^-T b`` (0) with the group's Cholesky factor.

        ``L^-1 b`` is in the factor's order (:meth:`DenseCholesky.half`), as the kept columns.
        """
        factor = self.state[grp.name].factor
        assert isinstance(factor, DenseCholesky)  # a point correction's groups: symmetric
        start, n = time.perf_counter(), len(b)
        out = factor.half(b, trans)
        self.log.add(grp.name, "dense_solve", n, 1, time.perf_counter() - start, n * n, "x")
        return out
