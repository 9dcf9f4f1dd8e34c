"""A contact's massless dofs put in equilibrium with the rest held (impact.py's settle).

The settle's matrix is the stiffness of those dofs (with a reduced wall's inertia), which
stays the same from step to step, plus the contact matrix of the active set, which does
not. The fixed part is projected once per zone and kept with it (:class:`Kept`); a reduced
wall moves along dense directions (``zone.directions``) and takes no contact term itself:
its block is eliminated once (Cholesky), and each settle solves the Schur complement on the
contact's own blocks only. On the 1/16 bar with its subdomain reduced (m = 20), a settle
took 1.2 s, most of it the dense wall's projection and a sparse solve of its dense block.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from dd_contact.assembly import ContactZone
from dd_contact.blocks import Block, BlockSystem, split_by_blocks

__all__ = ["Kept", "in_equilibrium", "massless_dofs"]

Rows = list[tuple[Block, np.ndarray]]


def massless_dofs(z: ContactZone, free: Callable[[Block], np.ndarray]) -> Rows:
    """The free massless dofs of a contact: its walls, and a contact interface's surface."""
    rows = [(sub, wall[free(sub)[wall] != 0]) for sub, wall in z.wall_parts]
    if z.block.kind != "u":
        starts = np.cumsum([0] + [len(dofs) for _, dofs in z.parts])
        rows += [
            (block, dofs[z.free[start : start + len(dofs)]])
            for (block, dofs), start in zip(z.parts, starts, strict=False)
        ]
    return rows


def _stiffness(system: BlockSystem, row: Block, col: Block) -> sp.csr_array | None:
    """``A[row, col]`` with the stiff ties' part carried on the right-hand side added."""
    A = system.block(row, col)
    for tie in system.stiff_ties:
        pieces = {
            (tie.u, tie.u): tie.P1,
            (tie.u, tie.s): -tie.P2,
            (tie.s, tie.u): -tie.P2.T,
            (tie.s, tie.s): tie.P4,
        }
        if (row, col) in pieces:
            part = tie.sigma * sp.csr_array(pieces[(row, col)])
            A = part if A is None else A + part
    return None if A is None else sp.csr_array(A)


def _part(A, b: Block, i: np.ndarray, c: Block, j: np.ndarray, moves: Mapping) -> sp.csr_array:
    """``A``'s rows i and columns j, or its product with the directions of a reduced wall."""
    rows = moves[b].T @ A if b in moves else A[i]
    return sp.csr_array(rows @ moves[c] if c in moves else sp.csr_array(rows)[:, j])


@dataclass
class Kept:
    """A zone's settle matrix without its contact part, and the held blocks eliminated.

    Attributes:
        key: What it was made for (the rows, the inertia's slopes, the stiff ties' sigma).
        sizes: Unknowns of each row block, in the rows' order.
        fixed: The fixed part per pair of row blocks (stiffness, a reduced wall's inertia).
        held: The row blocks eliminated once (reduced walls: no contact term, dense).
    """

    key: tuple
    sizes: dict[Block, int]
    fixed: dict[tuple[Block, Block], sp.csr_array] = field(default_factory=dict)
    held: list[Block] = field(default_factory=list)
    _factor: tuple | None = None  # Cholesky of the held block
    _coupling: np.ndarray | None = None  # rows (others) x held
    _schur: np.ndarray | None = None  # the others' fixed part less its coupling's
    _solved: np.ndarray | None = None  # held^-1 coupling^T

    def eliminate(self, others: list[Block]) -> None:
        """Factorise the held block and form the others' fixed Schur complement."""
        H = _dense(self.fixed, self.sizes, self.held, self.held)
        self._factor = sla.cho_factor(H, lower=True, check_finite=False)
        self._coupling = _dense(self.fixed, self.sizes, others, self.held)
        self._solved = sla.cho_solve(self._factor, self._coupling.T, check_finite=False)
        self._schur = _dense(self.fixed, self.sizes, others, others)
        self._schur -= self._coupling @ self._solved

    def solve(self, contact: dict, r: dict[Block, np.ndarray]) -> dict[Block, np.ndarray]:
        """The settle's move per row block, given the contact parts and the residuals."""
        blocks = list(self.sizes)
        if not self.held:
            matrix = [
                [
                    _summed(self.fixed.get((b, c)), contact.get((b, c)), self.sizes, b, c)
                    for c in blocks
                ]
                for b in blocks
            ]
            delta = spsolve(sp.csc_array(sp.block_array(matrix)), np.concatenate(list(r.values())))
            return _split(delta, blocks, self.sizes)
        others = [b for b in blocks if b not in self.held]
        assert self._factor is not None and self._coupling is not None  # eliminated
        assert self._schur is not None and self._solved is not None
        r_h = np.concatenate([r[b] for b in self.held])
        r_o = np.concatenate([r[b] for b in others]) if others else np.zeros(0)
        y = sla.cho_solve(self._factor, r_h, check_finite=False)
        S = self._schur + _dense(contact, self.sizes, others, others)
        d_o = sla.solve(S, r_o - self._coupling @ y, assume_a="sym", check_finite=False)
        d_h = y - self._solved @ d_o
        return _split(d_o, others, self.sizes) | _split(d_h, self.held, self.sizes)


def _dense(parts: dict, sizes: dict[Block, int], a: list[Block], b: list[Block]) -> np.ndarray:
    """The pieces ``parts`` of the rows ``a`` and columns ``b`` as one dense array."""
    ends_a, ends_b = np.cumsum([sizes[r] for r in a]), np.cumsum([sizes[c] for c in b])
    out = np.zeros((int(ends_a[-1]) if a else 0, int(ends_b[-1]) if b else 0))
    for r, ea in zip(a, ends_a, strict=True):
        for c, eb in zip(b, ends_b, strict=True):
            part = parts.get((r, c))
            if part is not None:
                block = part.toarray() if sp.issparse(part) else part
                out[ea - sizes[r] : ea, eb - sizes[c] : eb] += block
    return out


def _summed(a, b, sizes: dict[Block, int], r: Block, c: Block) -> sp.csr_array:
    parts = [p for p in (a, b) if p is not None]
    if not parts:
        return sp.csr_array((sizes[r], sizes[c]))
    return sp.csr_array(parts[0] + parts[1]) if len(parts) == 2 else sp.csr_array(parts[0])


def _split(delta: np.ndarray, blocks: list[Block], sizes: dict[Block, int]) -> dict:
    ends = np.cumsum([sizes[b] for b in blocks])
    return {b: delta[e - sizes[b] : e] for b, e in zip(blocks, ends, strict=True)}


def _held(rows: Rows, moves: Mapping, contact) -> list[Block]:
    """The row blocks eliminated once: reduced walls (dense) that take no contact term."""
    return [b for b, _ in rows if b in moves and not any(b in pair for pair in contact)]


def _kept(system: BlockSystem, z: ContactZone, rows: Rows, moves, inertia, contact) -> Kept:
    """The zone's :class:`Kept` for these rows (made again when the rows or slopes change)."""
    slopes = tuple(sorted((str(b), s) for b, (_, s, _) in (inertia or {}).items()))
    ties = tuple(t.sigma for t in system.stiff_ties)
    key = (tuple((b, i.tobytes()) for b, i in rows), slopes, ties)
    kept = getattr(z, "settle_kept", None)
    if kept is not None and kept.key == key:
        return kept
    sizes = {b: (moves[b].shape[1] if b in moves else len(i)) for b, i in rows}
    assert len(sizes) == len(rows)  # one row per block
    kept = Kept(key, sizes)
    for b, i in rows:
        for c, j in rows:
            A = _stiffness(system, b, c)
            if inertia and b == c and b in inertia:
                mass, slope, _ = inertia[b]
                A = sp.csr_array(slope**2 * mass) if A is None else A + slope**2 * mass
            if A is not None:
                kept.fixed[(b, c)] = _part(A, b, i, c, j, moves)
    kept.held = _held(rows, moves, contact)
    if kept.held:
        kept.eliminate([b for b, _ in rows if b not in kept.held])
    setattr(z, "settle_kept", kept)  # kept with the zone, from step to step
    return kept


def in_equilibrium(
    system: BlockSystem,
    z: ContactZone,
    x: Mapping[Block, np.ndarray],
    active: np.ndarray,
    loads: Mapping[Block, np.ndarray],
    offset: Mapping[Block, np.ndarray],
    free: Callable[[Block], np.ndarray],
    inertia: Mapping[Block, tuple] | None = None,
) -> dict[Block, np.ndarray]:
    """The blocks of ``z``'s massless dofs with those in equilibrium, the rest of x held.

    A block in ``inertia`` (reduced: its walls' moves carry some mass) minimises its
    kinetic energy with the potential (:func:`dd_contact.solvers.reduced_model.wall_inertia`).
    """
    rows = massless_dofs(z, free)
    # a reduced wall moves along directions (reduced_model), the others' dofs alone
    moves: dict[Block, np.ndarray] = getattr(z, "directions", {})
    op = z.operator
    C = op.matrix(active)
    placed = split_by_blocks(z.parts, C, system.sizes)
    # the contact's force at x, on its blocks
    force = z.scatter(op.rhs(active) - C @ z.gather(x), system.sizes)
    residual = {}
    for b, i in rows:
        r = -system.row_product(b, x)
        r -= offset.get(b, 0.0)
        r += loads.get(b, 0.0)
        if b in force:
            r += force[b]
        if inertia and b in inertia:  # -dv/dq M v(q): the kinetic energy's gradient
            mass, slope, velocity = inertia[b]
            r -= slope * (mass @ velocity(x[b]))
        residual[b] = moves[b].T @ r if b in moves else r[i]
    index = dict(rows)
    contact = {
        (b, c): _part(P, b, index[b], c, index[c], moves)
        for (b, c), P in placed.items()
        if b in index and c in index
    }
    delta = _kept(system, z, rows, moves, inertia, placed).solve(contact, residual)
    out = {}
    for b, _ in rows:
        out[b] = np.array(x[b], dtype=float)
        if b in moves:
            out[b] += moves[b] @ delta[b]
        else:
            out[b][index[b]] += delta[b]
    return out
