"""Friction on the surface: Cholesky factors with every point sticking, the slip by Woodbury.

A slipping point makes its contact block unsymmetric (:mod:`dd_contact.friction`): an LU
of its group (twice a Cholesky's flops, and in v-w-u its condensation's too), redone at
every change, and friction's changes turn the direction of every slipping point at once,
which :mod:`dd_contact.solvers.lowrank` 's corrections would take at full rank each time.
:class:`StuckSurface` instead factorises the surface with each region's *stuck* matrix F
(every active point sticking: symmetric positive semi-definite, ``Friction.stuck``) and
carries the difference to the true contact matrices C, non-zero only on the dofs J of the
slipping points and of the changes since the factorisation, as one Woodbury correction on
the unit columns of J::

    S'^-1 g = S^-1 (g - E z),   (I + M G) z = M (S^-1 g)_J,   G = E^T S^-1 E,   M = (C - F)_JJ

M is unsymmetric; G depends on J only. A change on dofs already in J (a slip direction that
turned, a point between stick and slip) rebuilds M and the LU of the small capacitance
matrix ``I + M G``, and eliminates nothing; new dofs add their columns to G (the forward
elimination of those only, :meth:`LowRankSurface._extend`). The groups are factorised again
(with the stuck matrices of then) when that is priced below the correction's growth, or
when a condensation changed. A frictionless pair's changes join the correction as its
points' rows (:class:`PointwiseSurface` 's columns): one column per point whose flag differs
from the one the factors hold, coupled by its sign, instead of the unit columns of the dofs
it touches. Every corrected solve is checked and refined as
:class:`LowRankSurface` 's; one that stays inaccurate falls back to LU factors of the true
matrices for the rest of the run (:mod:`dd_contact.solvers.unsymmetric`).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from dd_contact.blocks import Block
from dd_contact.solvers.lowrank import CAPACITANCE_RCOND, UPDATES, Correction
from dd_contact.solvers.pointkernels import equilibrated, point_columns
from dd_contact.solvers.pointwise import PointwiseSurface
from dd_contact.solvers.surface import Surface

__all__ = ["StuckSurface"]

Pair = tuple[Block, Block]


class StuckSurface(PointwiseSurface):
    """A :class:`PointwiseSurface` for friction: stuck Cholesky factors, the slip corrected.

    The frictionless pairs' changes join the same correction with their points' rows
    (:class:`PointwiseSurface` 's columns, against the flags the factors hold), the rest
    with the unit columns of the dofs where the true matrices differ from the held ones.

    Args:
        schedule, log, recondensed, unsymmetric, rates: As :class:`PointwiseSurface`.

    Attributes:
        stuck: Per contact block pair, the matrix with every active point sticking (the
            contact matrix itself where a region gave none: no friction).
        held: The stuck matrices the factors hold.
        exact: The factors are LU of the true matrices (a corrected solve failed).
    """

    def __init__(self, schedule, log, recondensed: bool = True, unsymmetric=(), rates=None):
        super().__init__(schedule, log, recondensed, unsymmetric, rates, lowrank=True)
        self._lu_groups, self.lu = self.lu, set()  # Cholesky while the correction holds
        self.stuck: dict[Pair, sp.csr_array] = {}
        self.held: dict[Pair, sp.csr_array] = {}
        self.exact = False
        self._restart = False  # a step ended: see restart()

    def held_contact(self) -> dict[Pair, sp.csr_array]:
        """The stuck matrices, or the true ones once :attr:`exact`."""
        return self.contact if self.exact else self.held

    def set_contact(
        self, pair: Pair, matrix: sp.csr_array, stuck: sp.csr_array | None = None
    ) -> None:
        """The new contact matrix of a block pair and its stuck one (default: itself)."""
        self.contact[pair] = matrix
        self.stuck[pair] = matrix if stuck is None else stuck
        if self.exact:
            self.changed |= set(pair)
        else:
            self.fresh.add(pair)

    def factorise(self) -> None:
        """Grow the correction for the changes, or factorise the stuck matrices again."""
        if self.exact:
            Surface.factorise(self)
            return
        if not (self._restart and self._restarted()):
            if not (self.stale or self.changed or self.fresh):
                return
            if not (self.stale or self.changed) and self._grown(priced=True):
                self.fresh = set()
                return
        for pair, matrix in self.stuck.items():
            held = self.held.get(pair)
            if held is None or (held != matrix).nnz:
                self.changed |= set(pair)
        self.held, self.correction = dict(self.stuck), Correction()
        self.reference = {
            n: flags.copy() for n in self._pointable() if (flags := self.active[n]) is not None
        }
        Surface.factorise(self)
        self.fresh = set()
        if not self._grown(priced=False):
            self._refactorise()

    def restart(self) -> None:
        """At the next solve, be what a run resumed from a checkpoint here would be.

        Called at a step's end: a resumed run factorises the stuck matrices of then and
        makes its correction at once; a correction grown over the step's changes holds
        other round-off, and a resumed run must step the same numbers.
        """
        self._restart = not self.exact

    def rebase(self) -> None:
        """A checkpoint: nothing more to drop (:meth:`restart` did at the step's end)."""

    def _restarted(self) -> bool:
        """What a resumed run would hold: the stuck matrices factorised, the correction.

        True: factorise again (the held matrices are not the stuck ones; the groups they
        make stale only: the others' factors are those a resumed run makes, bit for bit).
        Else the correction is made again at once if it was grown or its dofs are not
        those that deviate.
        """
        self._restart = False
        if self.held.keys() != self.stuck.keys() or any(
            (self.held[p] != m).nnz for p, m in self.stuck.items()
        ):
            return True
        if not self._made():
            self.correction = Correction()
            if not self._grown(priced=False):
                self._refactorise()
        return False

    def _made(self) -> bool:
        """Whether the correction is the one made at once: its deviating dofs, its points."""
        c, deviating = self.correction, self._deviating(self.held)
        ids = np.flatnonzero(self.flags()[1]) if self._pointed() else np.zeros(0, int)
        kinds: list[np.ndarray | None] = [None] if deviating else []
        kinds += [ids] if len(ids) else []
        if len(c.pieces) != len(kinds):
            return False
        for (dofs, _), points, kind in zip(c.pieces, c.points, kinds, strict=True):
            if kind is None:
                same = points is None and dofs.keys() == deviating.keys()
                if not (same and all(np.array_equal(dofs[b], J) for b, J in deviating.items())):
                    return False
            elif points is None or not np.array_equal(points, kind):
                return False
        return True

    def _pointed(self) -> set[Pair] | None:
        """The block pairs the regions held point by point fill (:meth:`_pointable`).

        None: a region's flags are unknown now but were known when factorised (its
        columns would not hold: factorise again).
        """
        if any(self.active.get(n) is None for n in self.reference):
            return None
        return {(a, b) for n in self.reference for a in self.regions[n] for b in self.regions[n]}

    def _pointable(self) -> set[str]:
        """The regions with point rows and known flags whose block pairs no other fills.

        A pair another region fills too differs by both: it takes unit columns.
        """
        pairs = {n: {(a, b) for a in bl for b in bl} for n, bl in self.schedule.regions.items()}
        out = {n for n in self.regions if self.active.get(n) is not None}
        while True:
            others = {p for n, ps in pairs.items() if n not in out for p in ps}
            shared = {n for n in out if pairs[n] & others}
            if not shared:
                return out
            out -= shared

    def _refactorise(self) -> None:
        """LU factors of the true matrices, from now on (the correction did not hold)."""
        self.exact, self.lu, self.correction = True, self._lu_groups, Correction()
        self.stale = {g.name for g in self.schedule.flat}
        Surface.factorise(self)

    def _corrected(self, c: Correction, g: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Woodbury on the last level alone when the correction's dofs are all there.

        The earlier levels are eliminated once, not once per pass (w-v-u, w-u: the
        contact blocks are the last level); else as :class:`LowRankSurface`.
        """
        last = {b for grp in self.schedule.groups[-1] for b in grp.blocks}
        if not all(b in last for dofs, _ in c.pieces for b in dofs):
            return super()._corrected(c, g)
        assert c.capacitance is not None  # a correction is made before it is applied
        g = self.forward(g)
        x = self.solve_last(g)
        z = c.solve(c.projected(x))
        x = self.solve_last(c.shifted(g, z))
        x.update(Surface.back_substitute(self, x))
        return x

    def _deviating(
        self, since: dict[Pair, sp.csr_array], skip: set[Pair] | None = None
    ) -> dict[Block, np.ndarray]:
        """The dofs per block where the contact matrices differ from ``since`` 's.

        ``skip``: pairs left out (corrected by their points' rows; default: those of
        :meth:`_pointed`).
        """
        skip = (self._pointed() or set()) if skip is None else skip
        touched: dict[Block, list[np.ndarray]] = {}
        for (a, b), matrix in self.contact.items():
            if (a, b) in skip:
                continue
            held = since.get((a, b))
            delta = sp.coo_array(matrix if held is None else matrix - held)
            delta.eliminate_zeros()
            touched.setdefault(a, []).append(delta.row)
            touched.setdefault(b, []).append(delta.col)
        dofs = {b: np.unique(np.concatenate(rows)) for b, rows in sorted(touched.items())}
        return {b: J for b, J in dofs.items() if len(J)}

    def _new_columns(self, pointed: set[Pair]) -> tuple[dict[Block, np.ndarray], np.ndarray]:
        """What the correction lacks: dofs deviating from the held matrices, points differing."""
        c = self.correction
        none = np.zeros(0, dtype=np.int64)
        known = {
            b: np.concatenate(
                [none] + [d[b] for (d, _), p in zip(c.pieces, c.points) if b in d and p is None]
            )
            for b in self.sizes
        }
        new = {
            b: np.setdiff1d(J, known[b], assume_unique=True)
            for b, J in self._deviating(self.held, pointed).items()
        }
        ids = np.flatnonzero(self.flags()[1]) if pointed else none
        have = np.concatenate([none] + [p for p in c.points if p is not None])
        return {b: J for b, J in new.items() if len(J)}, np.setdiff1d(ids, have)

    def _grown(self, priced: bool) -> bool:
        """The correction for ``C - held`` on its columns so far and any new ones.

        Unit columns of the dofs where the matrices differ, except on the pairs only
        frictionless regions with point rows fill: there their points' rows, the points
        whose flags differ from the reference. False: factorise again (``priced``: that is
        priced below adding the new columns; or the capacitance matrix is singular to
        working precision).
        """
        start, first = time.perf_counter(), len(self.log.records)
        c, pointed = self.correction, self._pointed()
        if pointed is None:  # a region's flags went unknown: its points no longer hold
            if any(p is not None for p in c.points):
                return False
            pointed = set()
        new, ids = self._new_columns(pointed)
        pieces: list[tuple[dict[Block, np.ndarray], np.ndarray, np.ndarray | None]] = []
        if new:
            pieces.append((new, np.eye(sum(map(len, new.values()))), None))
        if len(ids):
            P, at, _ = self.joined()
            pieces.append((*point_columns(P[:, ids], at), ids))
        r0, r = c.rank, sum(U.shape[1] for _, U, _ in pieces)
        if not r0 + r:
            self.correction = Correction()  # the contact is stuck: the factors are exact
            return True
        if priced and r:
            blocks = {b for pair in self.contact for b in pair}
            after = self._deviating(self.stuck, pointed)  # what would be left after factorising
            again = self.refactorise_seconds(blocks) + self.update_seconds(
                after, sum(map(len, after.values())), 0
            )
            reached = {b: np.zeros(0) for dofs, _, _ in pieces for b in dofs}
            if self.update_seconds(reached, r, r0) >= again:
                return False
        out = Correction(list(c.pieces), G=c.G, kept=dict(c.kept), K=c.K, points=list(c.points))
        for dofs, U, points in pieces:
            out.G = self._extend(out, dofs, U)
            out.pieces.append((dofs, U))
            out.points.append(points)
            out.K = np.zeros_like(out.G)  # its rank so far (the coupling is made below)
        out.K = self._coupling(out, pointed)
        C = np.eye(len(out.K)) + out.K @ out.G
        if any(p is not None for p in out.points):  # a slip's rows beside points' rows
            out.capacitance, out.conditioned, out.scale = equilibrated(C)
        else:
            out.capacitance = sla.lu_factor(C, check_finite=False)
            norm = np.abs(C).sum(axis=0).max()
            rcond, _ = sla.lapack.dgecon(out.capacitance[0], norm, norm="1")
            out.conditioned = float(rcond)
        if out.conditioned < CAPACITANCE_RCOND[1]:
            return False
        self.correction = out
        logged = sum(rec.seconds for rec in self.log.records[first:])  # the elimination's own
        seconds = time.perf_counter() - start - logged
        self.log.add(UPDATES, "dense_update", out.rank, r, seconds, (2.0 / 3.0) * out.rank**3)
        return True

    def _coupling(self, c: Correction, pointed: set[Pair]) -> np.ndarray:
        """``K``: ``(C - held)_JJ`` on the unit columns, ``now - reference`` on the points'.

        Dense, in the correction's column order; unsymmetric where points slip.
        """
        where = {b: np.full(n, -1) for b, n in self.sizes.items()}
        column, diagonal = 0, []
        now, changed = self.flags() if pointed else (None, None)
        for (dofs, U), points in zip(c.pieces, c.points, strict=True):
            if points is not None:
                assert now is not None and changed is not None  # flags known with points
                sign = np.where(now[points], 1.0, -1.0) * changed[points]
                diagonal.append((column + np.arange(len(points)), sign))
                column += len(points)
                continue
            for b, J in dofs.items():
                where[b][J] = column + np.arange(len(J))
                column += len(J)
        M = np.zeros((column, column))
        for (a, b), matrix in self.contact.items():
            if (a, b) in pointed:
                continue
            held = self.held.get((a, b))
            delta = sp.coo_array(matrix if held is None else matrix - held)
            rows, cols = where[a][delta.row], where[b][delta.col]
            nonzero = delta.data != 0.0
            assert np.all(rows[nonzero] >= 0) and np.all(cols[nonzero] >= 0)  # all in J
            np.add.at(M, (rows[nonzero], cols[nonzero]), delta.data[nonzero])
        for columns, sign in diagonal:
            M[columns, columns] = sign
        return M
