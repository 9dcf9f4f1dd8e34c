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
when a condensation changed. Every corrected solve is checked and refined as
:class:`LowRankSurface` 's; one that stays inaccurate falls back to LU factors of the true
matrices for the rest of the run (:mod:`dd_contact.solvers.unsymmetric`).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from dd_contact.blocks import Block
from dd_contact.solvers.lowrank import (
    CAPACITANCE_RCOND,
    UPDATES,
    Correction,
    LowRankSurface,
)
from dd_contact.solvers.surface import Surface

__all__ = ["StuckSurface"]

Pair = tuple[Block, Block]


class StuckSurface(LowRankSurface):
    """A :class:`LowRankSurface` for friction: stuck Cholesky factors, the slip corrected.

    Args:
        schedule, log, recondensed, unsymmetric, rates: As :class:`LowRankSurface`.

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
        pieces = self.correction.pieces
        deviating = self._deviating(self.held)
        made = len(pieces) == 1 and pieces[0][0].keys() == deviating.keys()
        if not (made and all(np.array_equal(pieces[0][0][b], J) for b, J in deviating.items())):
            self.correction = Correction()
            if not self._grown(priced=False):
                self._refactorise()
        return False

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
        z = sla.lu_solve(c.capacitance, c.projected(x), check_finite=False)
        x = self.solve_last(c.shifted(g, z))
        x.update(Surface.back_substitute(self, x))
        return x

    def _deviating(self, since: dict[Pair, sp.csr_array]) -> dict[Block, np.ndarray]:
        """The dofs per block where the contact matrices differ from ``since`` 's."""
        touched: dict[Block, list[np.ndarray]] = {}
        for (a, b), matrix in self.contact.items():
            held = since.get((a, b))
            delta = sp.coo_array(matrix if held is None else matrix - held)
            delta.eliminate_zeros()
            touched.setdefault(a, []).append(delta.row)
            touched.setdefault(b, []).append(delta.col)
        dofs = {b: np.unique(np.concatenate(rows)) for b, rows in sorted(touched.items())}
        return {b: J for b, J in dofs.items() if len(J)}

    def _grown(self, priced: bool) -> bool:
        """The correction for ``C - held`` on its dofs so far and any new ones.

        False: factorise again (``priced``: that is priced below adding the new columns;
        or the capacitance matrix is singular to working precision).
        """
        start, first = time.perf_counter(), len(self.log.records)
        c = self.correction
        none = np.zeros(0, dtype=np.int64)
        known = {
            b: np.concatenate([none] + [d[b] for d, _ in c.pieces if b in d]) for b in self.sizes
        }
        new = {
            b: np.setdiff1d(J, known[b], assume_unique=True)
            for b, J in self._deviating(self.held).items()
        }
        new = {b: J for b, J in new.items() if len(J)}
        r0, r = c.rank, sum(map(len, new.values()))
        if not r0 + r:
            self.correction = Correction()  # the contact is stuck: the factors are exact
            return True
        if priced and r:
            blocks = {b for pair in self.contact for b in pair}
            after = self._deviating(self.stuck)  # what would be left after factorising
            again = self.refactorise_seconds(blocks) + self.update_seconds(
                after, sum(map(len, after.values())), 0
            )
            if self.update_seconds(new, r, r0) >= again:
                return False
        out = Correction(list(c.pieces), G=c.G, kept=dict(c.kept), K=c.K)
        if r:
            out.G = self._extend(out, new, np.eye(r))
            out.pieces.append((new, np.eye(r)))
        out.K = self._coupling(out.pieces)
        C = np.eye(len(out.K)) + out.K @ out.G
        out.capacitance = sla.lu_factor(C, check_finite=False)
        rcond, _ = sla.lapack.dgecon(out.capacitance[0], np.abs(C).sum(axis=0).max(), norm="1")
        out.conditioned = float(rcond)
        if out.conditioned < CAPACITANCE_RCOND[1]:
            return False
        self.correction = out
        logged = sum(rec.seconds for rec in self.log.records[first:])  # the elimination's own
        seconds = time.perf_counter() - start - logged
        self.log.add(UPDATES, "dense_update", out.rank, r, seconds, (2.0 / 3.0) * out.rank**3)
        return True

    def _coupling(self, pieces: list) -> np.ndarray:
        """``M = (C - held)_JJ`` in the correction's column order (dense, unsymmetric)."""
        where = {b: np.full(n, -1) for b, n in self.sizes.items()}
        column = 0
        for dofs, _ in pieces:
            for b, J in dofs.items():
                where[b][J] = column + np.arange(len(J))
                column += len(J)
        M = np.zeros((column, column))
        for (a, b), matrix in self.contact.items():
            held = self.held.get((a, b))
            delta = sp.coo_array(matrix if held is None else matrix - held)
            rows, cols = where[a][delta.row], where[b][delta.col]
            nonzero = delta.data != 0.0
            assert np.all(rows[nonzero] >= 0) and np.all(cols[nonzero] >= 0)  # all in J
            np.add.at(M, (rows[nonzero], cols[nonzero]), delta.data[nonzero])
        return M
