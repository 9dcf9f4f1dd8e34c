"""A contact's massless dofs put in equilibrium with the rest held (impact.py's settle).

The settle's matrix is the stiffness of those dofs (with a reduced wall's inertia), which
stays the same from step to step, plus the contact matrix of the active set, which does
not. The fixed part is projected and factorised once per zone (:class:`Kept`, kept by the
problem's :class:`Settles` and handed to each step's start forces); a reduced wall moves
along dense directions (``zone.directions``, :class:`Moves`) and takes no contact term
itself: its block is eliminated once (Cholesky), and so is the Schur complement S on the
contact's own blocks. A frictionless contact with fixed normals adds ``F_a^T F_a`` (its
active points' rows), so a settle is a Woodbury correction of S's factor of the rank of the
active points (:class:`Points`), refined with the whole matrix's true residual; otherwise
``S + C`` is factorised at each settle. A reduced wall's residual uses its ``P^T K`` and
``P^T M``, kept: nothing of the reduced block's size is multiplied at a settle.

On the paper's bar at 1/4 reduced to m = 320 (benchmarks/settle_cost.py), the zone's first
settle took 2.4 s (the whole P multiplied into the dense reduced matrix as a sparse one) and
each later one solved a dense 1,107-row system.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.linalg import SuperLU, splu, spsolve

from dd_contact.assembly import ContactZone
from dd_contact.blocks import Block, BlockSystem, same_csr, split_by_blocks
from dd_contact.solvers.reduced_model import WallInertia

__all__ = [
    "DENSE_FILL",
    "REFINED",
    "REFINEMENTS",
    "Kept",
    "Moves",
    "Points",
    "Settles",
    "in_equilibrium",
    "massless_dofs",
]

Rows = list[tuple[Block, np.ndarray]]
type Matrix = np.ndarray | sp.csr_array

#: A Woodbury settle (:class:`Points`) is refined with its true residual when that is above
#: this fraction of the right-hand side's norm (round-off left 1e-10 to 1e-9 on the bar) ...
REFINED = 1e-8
#: ... at most this many times: removing a stiff point's penalty may cancel digits.
REFINEMENTS = 1
#: A sparse matrix filled above this fraction is multiplied by P as a dense one.
DENSE_FILL = 0.2


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
    A, tie = system.block(row, col), _tie_part(system, row, col)
    if tie is not None:
        A = tie if A is None else A + tie
    return None if A is None else sp.csr_array(A)


def _tie_part(system: BlockSystem, row: Block, col: Block) -> sp.csr_array | None:
    """The stiff ties' part of ``A[row, col]`` (carried on the right-hand side), if any."""
    out = None
    for tie in system.stiff_ties:
        pieces = {
            (tie.u, tie.u): tie.P1,
            (tie.u, tie.s): -tie.P2,
            (tie.s, tie.u): -tie.P2.T,
            (tie.s, tie.s): tie.P4,
        }
        if (row, col) in pieces:
            part = tie.sigma * sp.csr_array(pieces[(row, col)])
            out = part if out is None else out + part
    return out


class Moves:
    """A reduced wall's directions P (coordinates x wall dofs), its unit rows apart.

    ``ReducedBasis.wall_directions`` gives each wall dof's own coordinate a unit row of P
    and the modes dense rows; the other coordinates are zero rows. A product with P then
    costs its dense rows only (modes x wall, not coordinates x wall): the zone's first
    settle at 1/4 (m = 320) took 2.4 s as a sparse product with the whole P.
    """

    def __init__(self, P: np.ndarray):
        self.shape = P.shape
        nonzero = P != 0.0
        count, first = nonzero.sum(axis=1), nonzero.argmax(axis=1)
        unit = (count == 1) & (P[np.arange(len(P)), first] == 1.0)
        if len(np.unique(first[unit])) != int(unit.sum()):  # two in one column: all dense
            unit[:] = False
        self.unit_rows, self.unit_cols = np.flatnonzero(unit), first[unit]
        self.dense_rows = np.flatnonzero((count > 0) & ~unit)
        self.dense = np.ascontiguousarray(P[self.dense_rows])

    def times(self, A) -> np.ndarray:
        """``A P`` (A: anything x coordinates, sparse or dense), dense."""
        if sp.issparse(A) and A.nnz > DENSE_FILL * A.shape[0] * A.shape[1]:
            A = A.toarray()  # a reduced block: its columns sliced once, not per sparse copy
        out = np.zeros((A.shape[0], self.shape[1]))
        out[:, self.unit_cols] = _columns(A, self.unit_rows)
        if len(self.dense_rows):
            out += _columns(A, self.dense_rows) @ self.dense
        return out

    def transposed_times(self, A) -> np.ndarray:
        """``P^T A`` (A: coordinates x anything, sparse or dense), dense."""
        return self.times(A.T).T

    def move(self, d: np.ndarray) -> np.ndarray:
        """``P d``: the coordinates' move."""
        out = np.zeros(self.shape[0])
        out[self.unit_rows] = d[self.unit_cols]
        out[self.dense_rows] = self.dense @ d
        return out

    def project(self, r: np.ndarray) -> np.ndarray:
        """``P^T r``."""
        out = self.dense.T @ r[self.dense_rows]
        out[self.unit_cols] += r[self.unit_rows]
        return out


def _columns(A, columns: np.ndarray) -> np.ndarray:
    """``A[:, columns]`` as a dense array."""
    if sp.issparse(A):
        return sp.csc_array(A)[:, columns].toarray()
    return np.asarray(A)[:, columns]


def _part(A, b: Block, i: np.ndarray, c: Block, j: np.ndarray, moves: Mapping) -> Matrix:
    """``A``'s rows i and columns j, or its product with the directions of a reduced wall."""
    rows = moves[b].transposed_times(A) if b in moves else sp.csr_array(A)[i]
    if c in moves:
        return moves[c].times(rows)
    return rows[:, j] if isinstance(rows, np.ndarray) else sp.csr_array(rows[:, j])


@dataclass
class Points:
    """A contact's point rows F on the settle's free unknowns, through the fixed part.

    The contact part of the settle matrix is ``F_a^T F_a`` (F's rows of the active points:
    frictionless, normals fixed), so with ``S`` the fixed part factorised once, a settle is
    a Woodbury correction of rank the active points: ``(S + F_a^T F_a)^-1 r = S^-1 r -
    Y_a (I + W_aa)^-1 F_a S^-1 r``, with ``Y = S^-1 F^T`` and ``W = F Y`` made once.
    """

    F: sp.csr_array
    Y: np.ndarray
    W: np.ndarray
    _capacitance: tuple[bytes, np.ndarray] | None = None  # the last active set's Cholesky

    def solve(self, L: np.ndarray, active: np.ndarray, r: np.ndarray) -> np.ndarray:
        """``(S + F_a^T F_a)^-1 r`` with ``L`` S's Cholesky factor."""
        d = _cho_solve(L, r)
        a = np.flatnonzero(active)
        if not len(a):
            return d
        key = active.tobytes()
        if self._capacitance is None or self._capacitance[0] != key:
            cap = self.W[np.ix_(a, a)]
            cap[np.diag_indices_from(cap)] += 1.0
            self._capacitance = (key, sla.cholesky(cap, lower=True, check_finite=False))
        z = np.zeros(self.F.shape[0])
        z[a] = _cho_solve(self._capacitance[1], self.F[a] @ d)
        return d - self.Y @ z  # Y's active columns, without gathering them


@dataclass
class Kept:
    """A zone's settle matrix without its contact part, and the held blocks eliminated.

    Attributes:
        key: What it was made for (the rows, the inertia's slopes, the stiff ties' sigma).
        sizes: Unknowns of each row block, in the rows' order.
        fixed: The fixed part per pair of row blocks (stiffness, a reduced wall's inertia).
        held: The row blocks eliminated once (reduced walls: no contact term, dense).
        moves: A reduced wall's directions per row block (:class:`Moves`).
        projected: Per reduced wall, ``P^T A`` of its own stiffness and mass blocks
            (``(P^T K, P^T M)``, M ``None`` without inertia): its residual without a
            product of the reduced block's size.
        points: The contact's point rows through the others' fixed part (:class:`Points`),
            when the contact has them.
        point_rows: The operator's G they were made from, and F on the others' unknowns.
    """

    key: tuple
    sizes: dict[Block, int]
    fixed: dict[tuple[Block, Block], Matrix] = field(default_factory=dict)
    held: list[Block] = field(default_factory=list)
    moves: dict[Block, Moves] = field(default_factory=dict)
    projected: dict[Block, tuple[np.ndarray, np.ndarray | None]] = field(default_factory=dict)
    points: Points | None = None
    point_rows: tuple[sp.csr_array, sp.csr_array] | None = None  # (the operator's G, F)
    _factor: np.ndarray | None = None  # Cholesky factor of the held block
    _coupling: sp.csr_array | None = None  # rows (others) x held
    _schur: np.ndarray | None = None  # the others' fixed part less its coupling's
    _schur_factor: np.ndarray | None = None  # its Cholesky factor (None: not definite)

    @property
    def others(self) -> list[Block]:
        """The row blocks solved at each settle (the contact's own)."""
        return [b for b in self.sizes if b not in self.held]

    def eliminate(self) -> None:
        """Factorise the held block and form and factorise the others' fixed Schur complement.

        ``S = A_oo - C H^-1 C^T`` as ``A_oo - V^T V`` with ``V = L^-1 C^T`` (H = L L^T): one
        triangular solve and one symmetric product, half the work of ``H^-1 C^T`` then a
        general product.
        """
        others = self.others
        H = _dense(self.fixed, self.sizes, self.held, self.held)
        self._factor = sla.cholesky(H, lower=True, overwrite_a=True, check_finite=False)
        coupling = _dense(self.fixed, self.sizes, others, self.held)
        self._coupling = sp.csr_array(coupling)  # a tie: sparse
        V = sla.solve_triangular(self._factor, coupling.T, lower=True, check_finite=False)
        self._schur = _dense(self.fixed, self.sizes, others, others)
        self._schur -= V.T @ V
        try:
            self._schur_factor = sla.cholesky(self._schur, lower=True, check_finite=False)
        except np.linalg.LinAlgError:  # S + C factorised at each settle instead
            self._schur_factor = None

    def with_points(self, F: sp.csr_array) -> Points | None:
        """The :class:`Points` of ``F`` (made when F is new), if the others' part is factorised."""
        if self._schur_factor is None:
            return None
        if self.points is None or not same_csr(self.points.F, F):
            Y = _cho_solve(self._schur_factor, F.T.toarray())
            self.points = Points(F, Y, np.asarray(F @ Y))
        return self.points

    def residual(
        self, system: BlockSystem, b: Block, i: np.ndarray, x, given, inertia
    ) -> np.ndarray:
        """Row block b's out-of-balance force at x, on the settle's unknowns.

        ``given``: the loads, the stiff ties' offsets and the contact's force, per block. A
        reduced wall's own block is multiplied through its kept ``P^T K`` and ``P^T M``: no
        product of the reduced block's size at each settle.
        """
        loads, offset, force = given
        held = b in self.projected  # a reduced wall
        r = np.zeros(system.sizes[b])
        for c, A in system.block_row(b):
            if c in x and not (held and c == b):
                r -= A @ x[c]
        r -= offset.get(b, 0.0)
        r += loads.get(b, 0.0)
        if b in force:
            r += force[b]
        moving = inertia[b] if inertia and b in inertia else None
        if held:
            PtK, PtM = self.projected[b]
            out = self.moves[b].project(r) - PtK @ x[b]
            if moving is not None and PtM is not None:  # the end's inertia, -M a(q)
                out -= PtM @ moving.acceleration(x[b])
            return out
        if moving is not None:
            r -= moving.mass @ moving.acceleration(x[b])
        return self.moves[b].project(r) if b in self.moves else r[i]

    def solve(
        self,
        contact: Callable[[], dict],
        r: dict[Block, np.ndarray],
        rows: Callable,
    ) -> dict[Block, np.ndarray]:
        """The settle's move per row block, given the residuals.

        ``contact()``: the contact parts per pair of row blocks; ``rows()``: ``(F, active)``,
        the contact's point rows on the others' unknowns and its active points, or ``None``
        (friction, moving normals): the contact parts are then added and factorised.
        """
        blocks = list(self.sizes)
        if not self.held:
            parts = contact()
            matrix = [
                [
                    _summed(self.fixed.get((b, c)), parts.get((b, c)), self.sizes, b, c)
                    for c in blocks
                ]
                for b in blocks
            ]
            delta = spsolve(sp.csc_array(sp.block_array(matrix)), np.concatenate(list(r.values())))
            return _split(delta, blocks, self.sizes)
        return self._held_solve(r, self._others_inverse(contact, rows))

    def _held_solve(self, r: dict[Block, np.ndarray], inverse: Callable) -> dict[Block, np.ndarray]:
        """The held blocks eliminated, the others solved by ``inverse`` ((S + C)^-1)."""
        names = self.others
        assert self._factor is not None and self._coupling is not None  # eliminated
        r_h = np.concatenate([r[b] for b in self.held])
        r_o = np.concatenate([r[b] for b in names]) if names else np.zeros(0)
        y = _cho_solve(self._factor, r_h)
        d_o = inverse(r_o - self._coupling @ y)
        d_h = y - _cho_solve(self._factor, self._coupling.T @ d_o)
        return _split(d_o, names, self.sizes) | _split(d_h, self.held, self.sizes)

    def _others_inverse(self, contact: Callable, rows: Callable) -> Callable:
        """``(S + C)^-1`` on the others' unknowns, as a function of a vector.

        By :class:`Points` (a Woodbury correction of S's kept factor) where the contact has
        point rows, refined once with its true residual if that is above REFINED of the
        right-hand side; else S + C factorised here (friction, moving normals).
        """
        given = rows() if self.others else None
        points = self.with_points(given[0]) if given is not None else None
        if points is None:
            assert self._schur is not None
            C = _dense(contact(), self.sizes, self.others, self.others)
            lu = sla.lu_factor(self._schur + C, check_finite=False)
            return lambda v: sla.lu_solve(lu, v, check_finite=False)
        assert given is not None and self._schur is not None and self._schur_factor is not None
        F, active, L, S = given[0][given[1]], given[1], self._schur_factor, self._schur

        def inverse(v: np.ndarray) -> np.ndarray:
            d = points.solve(L, active, v)
            for _ in range(REFINEMENTS):  # the correction's cancellation, taken back
                residual = v - S @ d - F.T @ (F @ d)
                if np.linalg.norm(residual) <= REFINED * np.linalg.norm(v):
                    break
                d += points.solve(L, active, residual)
            return d

        return inverse


def _cho_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(L L^T)^-1 b`` by two triangular solves (scipy's cho_solve copied the factor: 12x)."""
    y = sla.solve_triangular(L, b, lower=True, check_finite=False)
    return sla.solve_triangular(L, y, lower=True, trans="T", check_finite=False)


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


def _held(rows: Rows, moves: Mapping, contact: set[Block]) -> list[Block]:
    """The row blocks eliminated once: reduced walls (dense) that take no contact term."""
    return [b for b, _ in rows if b in moves and b not in contact]


@dataclass
class Settles:
    """Each contact zone's :class:`Kept`, kept from step to step (by the zone's contact).

    The problem owns it and hands it to each step's start forces
    (:class:`dd_contact.impact.StartForces`): a zone's fixed part is projected and
    factorised at its first settle and again only when its rows or slopes change.
    """

    kept: dict[str, Kept] = field(default_factory=dict)
    #: Per zone, its surface blocks' matrix with the last contact part, factorised (SuperLU)
    surfaces: dict[str, tuple[tuple, SuperLU]] = field(default_factory=dict)

    def surface_solve(
        self, system: BlockSystem, z: ContactZone, contact: sp.csr_array, rhs: np.ndarray
    ) -> np.ndarray:
        """``(A_ww + C)^-1 rhs`` on the zone's surface blocks (``w``, a pair's two).

        The factorisation is kept while the contact matrix C stays the same: a step's
        corrections ask again with the same points in contact at both ends.
        """
        C = sp.csr_array(contact)
        key = (C.shape, C.indptr.tobytes(), C.indices.tobytes(), C.data.tobytes())
        last = self.surfaces.get(z.contact.name)
        if last is None or last[0] != key:
            blocks = [w for w, _ in z.parts]
            A = sp.block_array([[system.block(a, b) for b in blocks] for a in blocks])
            last = self.surfaces[z.contact.name] = (key, splu(sp.csc_array(A + C)))
        return last[1].solve(rhs)

    def of(self, system: BlockSystem, z: ContactZone, rows: Rows, inertia) -> Kept:
        """The zone's :class:`Kept` for these rows (made again when the rows or slopes change)."""
        slopes = tuple(sorted((str(b), w.slope) for b, w in (inertia or {}).items()))
        ties = tuple(t.sigma for t in system.stiff_ties)
        key = (tuple((b, i.tobytes()) for b, i in rows), slopes, ties)
        kept = self.kept.get(z.contact.name)
        if kept is None or kept.key != key:
            kept = self.kept[z.contact.name] = _kept(system, z, rows, inertia, key)
        return kept


def _kept(system: BlockSystem, z: ContactZone, rows: Rows, inertia, key: tuple) -> Kept:
    """The zone's settle matrix without its contact part, projected, its held part eliminated."""
    # a reduced wall moves along directions (reduced_model), the others' dofs alone
    directions: dict[Block, np.ndarray] = getattr(z, "directions", {})
    moves = {b: Moves(P) for b, P in directions.items()}
    sizes = {b: (moves[b].shape[1] if b in moves else len(i)) for b, i in rows}
    assert len(sizes) == len(rows)  # one row per block
    kept = Kept(key, sizes, moves=moves)
    kept.held = _held(rows, moves, {b for b, _ in z.parts})
    for b, i in rows:
        for c, j in rows:
            if b in moves and b == c:
                kept.fixed[(b, b)] = _moved_part(system, kept, b, inertia)
                continue
            A = _stiffness(system, b, c)
            if inertia and b == c and b in inertia:
                mass, slope = inertia[b].mass, inertia[b].slope
                A = sp.csr_array(slope * mass) if A is None else A + slope * mass
            if A is not None:
                kept.fixed[(b, c)] = _part(A, b, i, c, j, moves)
    if kept.held:
        kept.eliminate()
    return kept


def _moved_part(system: BlockSystem, kept: Kept, b: Block, inertia) -> np.ndarray:
    """A reduced wall's ``P^T (K + s M) P``, its ``P^T K`` and ``P^T M`` kept for its residual."""
    P = kept.moves[b]
    K = system.block(b, b)
    PtK = P.transposed_times(K) if K is not None else np.zeros(P.shape[::-1])
    PtM = P.transposed_times(inertia[b].mass) if inertia and b in inertia else None
    kept.projected[b] = (PtK, PtM)
    out = P.times(PtK)
    if PtM is not None:
        out += inertia[b].slope * P.times(PtM)
    tie = _tie_part(system, b, b)
    if tie is not None:
        out += P.times(P.transposed_times(tie))
    return out


def _point_rows(z: ContactZone, kept: Kept, index: dict, sizes) -> sp.csr_array | None:
    """The contact's point rows F on the settle's others' unknowns (``None``: it has none).

    Frictionless with fixed normals only (``ContactOperator.point_rows``): F is then the
    same at every settle, and the Woodbury data made with it stays.
    """
    op = z.operator
    obstacle = getattr(op, "obstacle", None)
    if getattr(op, "friction", None) is not None or not getattr(obstacle, "fixed_normals", False):
        return None
    if kept.point_rows is not None and kept.point_rows[0] is op.G:  # at rest: the same G
        return kept.point_rows[1]
    F = sp.csr_array(op.point_rows(z.free))
    starts = np.cumsum([0] + [len(dofs) for _, dofs in z.parts])
    segments = {b: (s, dofs) for (b, dofs), s in zip(z.parts, starts, strict=False)}
    pieces = []
    for b in kept.others:
        if b not in segments:  # a wall without contact terms
            pieces.append(sp.csr_array((F.shape[0], kept.sizes[b])))
            continue
        start, dofs = segments[b]
        to_block = sp.csr_array(
            (np.ones(len(dofs)), (np.arange(len(dofs)), dofs)), shape=(len(dofs), sizes[b])
        )
        Fb = sp.csr_array(F[:, start : start + len(dofs)] @ to_block)
        pieces.append(sp.csr_array(kept.moves[b].times(Fb)) if b in kept.moves else Fb[:, index[b]])
    kept.point_rows = (op.G, sp.csr_array(sp.hstack(pieces)))
    return kept.point_rows[1]


def in_equilibrium(
    system: BlockSystem,
    z: ContactZone,
    x: Mapping[Block, np.ndarray],
    active: np.ndarray,
    loads: Mapping[Block, np.ndarray],
    offset: Mapping[Block, np.ndarray],
    free: Callable[[Block], np.ndarray],
    inertia: Mapping[Block, WallInertia] | None = None,
    settles: Settles | None = None,
) -> dict[Block, np.ndarray]:
    """The blocks of ``z``'s massless dofs with those in equilibrium, the rest of x held.

    A block in ``inertia`` (reduced: its walls' moves carry some mass) balances its end's
    inertia too (:func:`dd_contact.solvers.reduced_model.wall_inertia`), as far as that
    adds no energy.
    ``settles``: where the zone's fixed part is kept from one settle to the next (without:
    made for this one).
    """
    rows = massless_dofs(z, free)
    kept = (settles or Settles()).of(system, z, rows, inertia)
    op = z.operator
    C = op.matrix(active)
    # the contact's force at x, on its blocks
    force = z.scatter(op.rhs(active) - C @ z.gather(x), system.sizes)
    residual = {b: kept.residual(system, b, i, x, (loads, offset, force), inertia) for b, i in rows}
    index = dict(rows)

    def contact() -> dict:
        placed = split_by_blocks(z.parts, C, system.sizes)
        return {
            (b, c): _part(P, b, index[b], c, index[c], kept.moves)
            for (b, c), P in placed.items()
            if b in index and c in index
        }

    def point_rows():
        F = _point_rows(z, kept, index, system.sizes)
        return None if F is None else (F, active)

    delta = kept.solve(contact, residual, point_rows)
    share = _adding_no_energy(kept, delta, residual, x, index, inertia) if inertia else 1.0
    out = {}
    for b, _ in rows:
        out[b] = np.array(x[b], dtype=float)
        if b in kept.moves:
            out[b] += kept.moves[b].move(share * delta[b])
        else:
            out[b][index[b]] += share * delta[b]
    return out


def _adding_no_energy(kept: Kept, delta: dict, r: dict, x, index: dict, inertia) -> float:
    """The share of the settle's move that adds no energy: 1, unless the whole move would.

    The move balances the end's inertia (exact as the step is); where a reduced wall's
    move carries mass, that need not lower the energy E = kinetic + potential. Along the
    move E changes by ``t g + t^2 h / 2``, with ``h = delta . r`` (the settle's matrix, as
    solved) plus the kinetic part's ``(s_v^2 - s_a) |P delta|_M^2``, and ``g = -delta . r``
    plus the inertia the balance held, ``delta . P^T M (s_v v - a)``. Above zero at t = 1,
    the share is where it is zero again (none if E grows at once).
    """
    dr = sum(float(delta[b] @ r[b]) for b in delta)
    g, h = -dr, dr
    for b, wall in inertia.items():
        if b not in delta:
            continue
        q, d = x[b], delta[b]
        if b in kept.projected:  # P^T M kept: nothing of the block's size multiplied
            PtM, moved = kept.projected[b][1], kept.moves[b].move(d)
        else:  # the mass's rows of the settled dofs
            PtM, moved = sp.csr_array(wall.mass)[index[b]], np.zeros(len(q))
            moved[index[b]] = d
        g += float(d @ (PtM @ (wall.velocity_slope * wall.velocity(q) - wall.acceleration(q))))
        if curvature := wall.velocity_slope**2 - wall.slope:  # 0 in the trapezoidal rule
            h += curvature * float(d @ (PtM @ moved))
    if g + h / 2.0 <= 0.0:
        return 1.0
    return 0.0 if g >= 0.0 or h <= 0.0 else min(1.0, -2.0 * g / h)
