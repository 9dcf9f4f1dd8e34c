"""What the assembly, the schedule and the solvers share: blocks, contact regions, the system.

A block of system (14) holds the displacement of one mesh: a subdomain (kind ``u``), the
interface (``v``) or a contact interface (``w``). A :class:`Block` is a ``str`` whose value
is ``"<kind>:<name>"``, so dictionaries keyed by blocks also answer to that string (the key
users and the work log see); it is built and read only here. A :class:`BlockSystem` holds
the blocks of the symmetric system, each off-diagonal block stored once: the rule that it
stands for its transpose too lives in its methods only.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

__all__ = [
    "BLOCK_KINDS",
    "Block",
    "BlockKeyed",
    "BlockSystem",
    "ContactRegion",
    "StiffTie",
    "refuse_unsolvable",
    "same_csr",
    "split_by_blocks",
]

#: Kinds of unknowns: subdomain, interface, contact-interface displacement.
BLOCK_KINDS: tuple[str, ...] = ("u", "v", "w")


class Block(str):
    """A block of unknowns: its ``kind`` (``u``, ``v`` or ``w``) and the mesh's ``name``."""

    kind: str
    name: str

    def __new__(cls, kind: str, name: str) -> Block:
        """The block ``kind:name``; ``kind`` must be one of :data:`BLOCK_KINDS`."""
        if kind not in BLOCK_KINDS:
            raise ValueError(f"block kind {kind!r} is not one of {BLOCK_KINDS}")
        block = super().__new__(cls, f"{kind}:{name}")
        block.kind, block.name = kind, str(name)
        return block

    # pickling (blocks travel between ranks); str's takes its one value, Block's __new__ two
    def __getnewargs__(self) -> tuple[str, str]:  # type: ignore[override]
        return self.kind, self.name

    def __repr__(self) -> str:
        return f"Block({self.kind!r}, {self.name!r})"

    @classmethod
    def parse(cls, key: str) -> Block:
        """The block named by ``key`` (a Block or its ``"kind:name"`` string)."""
        if isinstance(key, Block):
            return key
        kind, sep, name = str(key).partition(":")
        if not sep:
            raise ValueError(f"{key!r} is not a block name of the form 'kind:name'")
        return cls(kind, name)


#: A mapping read by block: keyed by :class:`Block` s or by their ``"kind:name"`` strings
#: (a ``Mapping`` is invariant in its key, so ``Mapping[str, V]`` does not take the first).
type BlockKeyed[V] = Mapping[Block, V] | Mapping[str, V]


@dataclass(frozen=True, eq=False)
class ContactRegion:
    """What a solver reserves for one contact region: where its matrix goes, and its shape.

    The last three attributes are the seams of contact between bodies and of friction
    (docs/architecture.md, "Seams"): the schedule already groups a region's blocks; the
    solvers refuse a region they cannot solve yet (:func:`not_yet_solvable`).

    Attributes:
        name: The contact region's name (the key of its contact matrix).
        block: The block holding the contact surface's displacement (``w``, or ``u`` for
            contact on a subdomain's own boundary).
        dofs: Dof in ``block`` of every surface dof (3 per surface node).
        pattern: Sparsity pattern of the contact matrix in surface dof numbering.
        partner: The other block a contact pair's matrix couples (``None``: an obstacle).
        partner_dofs: Dof in ``partner`` of each of its surface dofs; a pair's matrix is
            numbered ``dofs`` first, then ``partner_dofs``.
        symmetric: Whether the contact matrix is symmetric (friction's slip is not).
        history: Whether the region carries state from step to step (friction's traction).
        points: A frictionless pair's contact points as rows ``F`` (each point's gap
            gradient times the square root of its penalty weight; numbered as the matrix):
            its contact matrix for the active flags a is ``F^T diag(a) F``, so a state
            change is known point by point (``None``: not given).
        stuck: Friction against an obstacle: its last contact matrix with every active
            point sticking (symmetric, unlike the matrix; ``None``: not given). An order
            factorises that and corrects for the slip (:mod:`dd_contact.solvers.stuck`).
    """

    name: str
    block: Block
    dofs: np.ndarray
    pattern: sp.csr_array
    partner: Block | None = None
    partner_dofs: np.ndarray | None = None
    symmetric: bool = True
    history: bool = False
    points: sp.csr_array | None = None
    stuck: Callable[[], sp.csr_array] | None = field(default=None, repr=False)
    # the last matrix split by in_blocks (its arrays) and its pieces: a step without a
    # change sends each region's same matrix again, and a split cost about 0.2 ms
    _last_split: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __getstate__(self) -> dict:
        """Pickled (sent to another rank) without the last split."""
        return {**self.__dict__, "_last_split": {}}

    @property
    def blocks(self) -> tuple[Block, ...]:
        """The blocks the contact matrix couples: one for an obstacle, two for a pair."""
        return (self.block,) if self.partner is None else (self.block, self.partner)

    @property
    def parts(self) -> list[tuple[Block, np.ndarray]]:
        """``(block, dofs)`` of each block, in the order the contact matrix numbers them."""
        if self.partner is None or self.partner_dofs is None:
            return [(self.block, self.dofs)]
        return [(self.block, self.dofs), (self.partner, self.partner_dofs)]

    def shifted(self, offsets: int | Mapping[str, int]) -> ContactRegion:
        """The region in one matrix holding each block at ``offsets[block]`` (or ``offsets``).

        Its ``dofs`` are the places of all its surface dofs there (a pair's both blocks).
        """
        at = (lambda b: offsets) if isinstance(offsets, int) else offsets.__getitem__
        places = np.concatenate([dofs + at(block) for block, dofs in self.parts])
        return replace(self, dofs=places, partner_dofs=None)

    def in_blocks(
        self, matrix: sp.sparray, sizes: Mapping[Block, int]
    ) -> dict[tuple[Block, Block], sp.csr_array]:
        """The contact matrix (surface numbering) as the block pairs it fills, block numbered.

        Given the last matrix again (equal arrays), the last pieces themselves: they are
        shared, to be read and never changed in place.
        """
        last = self._last_split
        arrays = _csr_arrays(matrix)
        if arrays is not None and last.get("sizes") == dict(sizes):
            known = last.get("arrays")
            if known is not None and all(map(_same_array, known, arrays)):
                return dict(last["pieces"])
        pieces = split_by_blocks(self.parts, matrix, sizes)
        if arrays is not None:
            last["sizes"], last["arrays"] = dict(sizes), tuple(a.copy() for a in arrays)
            last["pieces"] = pieces
        return dict(pieces)


def _csr_arrays(matrix: sp.sparray) -> tuple[np.ndarray, ...] | None:
    """A CSR matrix's shape, indptr, indices and data (``None`` for another format)."""
    if not isinstance(matrix, sp.csr_array | sp.csr_matrix):
        return None
    return np.array(matrix.shape), matrix.indptr, matrix.indices, matrix.data


def _same_array(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b))


def same_csr(A: sp.sparray, B: sp.sparray) -> bool:
    """Whether two CSR matrices are one, or hold the same shape, pattern and values."""
    if A is B:
        return True
    a, b = _csr_arrays(A), _csr_arrays(B)
    return a is not None and b is not None and all(map(_same_array, a, b))


def split_by_blocks(
    parts: Sequence[tuple[Block, np.ndarray]], matrix: sp.sparray, sizes: BlockKeyed[int]
) -> dict[tuple[Block, Block], sp.csr_array]:
    """A matrix numbered ``parts``' dofs one block after the other, as block pairs.

    ``parts``: ``(block, dofs)`` in the matrix's order (a contact region's); each piece is
    block numbered, of the blocks' ``sizes``.
    """
    coo = sp.coo_array(matrix)
    starts = np.cumsum([0] + [len(dofs) for _, dofs in parts])
    out = {}
    for i, (a, da) in enumerate(parts):
        rows = (coo.row >= starts[i]) & (coo.row < starts[i + 1])
        for j, (b, db) in enumerate(parts):
            keep = rows & (coo.col >= starts[j]) & (coo.col < starts[j + 1])
            r, c = da[coo.row[keep] - starts[i]], db[coo.col[keep] - starts[j]]
            shape = (sizes[a], sizes[b])
            out[(a, b)] = sp.csr_array((coo.data[keep], (r, c)), shape=shape)
    return out


def refuse_unsolvable(regions: Iterable[ContactRegion], monolithic: bool = False) -> None:
    """Raise NotImplementedError for a region the solvers cannot solve yet.

    A contact pair's two blocks are solved (the schedule's groups, the surface's contact
    matrices by block pair, FULL's dofs over both blocks); an unsymmetric contact block
    (friction) is factorised with LU where it lies: a dense surface group, or FULL's
    matrix (``monolithic``). On a subdomain's own boundary (v-u) it would make the
    subdomain unsymmetric, which the orders never factorise.
    """
    for region in regions:
        if region.symmetric or monolithic or region.block.kind != "u":
            continue
        raise NotImplementedError(
            f"contact region {region.name!r} has friction on a subdomain's own boundary: the "
            "orders keep every subdomain symmetric; use a ContactInterface (w-u, v-w-u, w-v-u) "
            "or algorithm='FULL' (docs/contact.md, 'Friction')"
        )


@dataclass
class StiffTie:
    """The part of a stiff tie's penalty kept out of the matrices (kappa > KAPPA_SPLIT).

    The tie's penalty 1/eps is split as ``rho + sigma``: ``rho`` (kappa = KAPPA_ASSEMBLED)
    is assembled like any tie, ``sigma`` is carried by the augmented-Lagrangian iteration of
    :mod:`dd_contact.solvers.stiff_ties` as a force on the right-hand side.

    Attributes:
        name: ``"<surface> on <subdomain>"``, for messages.
        u: The subdomain's block.
        s: The surface's block (``v`` or ``w``).
        P1, P2, P4: The tie operators (9)-(11), blocked, without the 1/eps factor.
        rho: The assembled part of 1/eps.
        sigma: The remainder of 1/eps.
    """

    name: str
    u: Block
    s: Block
    P1: sp.csr_array
    P2: sp.csr_array
    P4: sp.csr_array
    rho: float
    sigma: float

    def jump(self, x: BlockKeyed[np.ndarray]) -> dict[Block, np.ndarray]:
        """``R x``: the tie's unscaled force on u and s, ``(P1 u - P2 s, P4 s - P2^T u)``."""
        u, s = x[self.u], x[self.s]
        return {self.u: self.P1 @ u - self.P2 @ s, self.s: self.P4 @ s - self.P2.T @ u}


@dataclass
class BlockSystem:
    """The local pieces of a symmetric block system ``A x = b``.

    Only one triangle of A is stored: an off-diagonal block is held once, as (row, col) or
    as (col, row), and stands for its transpose too. That rule is applied here and nowhere
    else: read A through :meth:`block`, :meth:`all_blocks`, :meth:`block_row`,
    :meth:`coupled`, :meth:`row_product` and :meth:`triplets`. :attr:`matrices` is the
    storage: for adding to it, changing it in place, or sending its pieces elsewhere.

    Attributes:
        sizes: Size of every block, in block order (same on all ranks).
        owners: Rank that owns every block's rows.
        matrices: ``(row_block, col_block) -> matrix`` contributions; an off-diagonal pair
            is stored once and stands for its transpose too. Contributions with the same key
            from different ranks are added.
        rhs: ``block -> vector`` contributions, added like the matrices.
        penalties: ``(subdomain, surface) -> eps`` of every penalty this rank assembled
            (ties, and ``(subdomain, "contact:<name>")`` for contact).
        kappas: ``(subdomain, surface) -> kappa = h / (E eps)`` of every tie this rank
            assembled.
        stiff_ties: The ties of this rank stiffer than KAPPA_SPLIT: their matrices hold
            kappa = KAPPA_ASSEMBLED, the remainder is here.
        reduced: The subdomain blocks held as reduced models (small dense matrices over
            reduced coordinates; :mod:`dd_contact.solvers.reduced`).
    """

    sizes: dict[Block, int]
    owners: dict[Block, int]
    matrices: dict[tuple[Block, Block], sp.csr_array] = field(default_factory=dict)
    rhs: dict[Block, np.ndarray] = field(default_factory=dict)
    penalties: dict[tuple[str, str], float] = field(default_factory=dict)
    kappas: dict[tuple[str, str], float] = field(default_factory=dict)
    stiff_ties: list[StiffTie] = field(default_factory=list)
    reduced: set[Block] = field(default_factory=set)
    # stored pair -> its transpose (a view sharing the stored arrays), made once: a step
    # reads block rows some 40 times, and each transpose built anew cost about 60 us
    _transposes: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __getstate__(self) -> dict:
        """Pickled (sent to another rank) without the transposes' cache."""
        return {**self.__dict__, "_transposes": {}}

    def copy(self) -> BlockSystem:
        """A copy whose matrices and vectors can be changed independently."""
        return BlockSystem(
            dict(self.sizes),
            dict(self.owners),
            {k: m.copy() for k, m in self.matrices.items()},
            {k: v.copy() for k, v in self.rhs.items()},
            dict(self.penalties),
            dict(self.kappas),
            list(self.stiff_ties),
            set(self.reduced),
        )

    def add(self, row: Block, col: Block, matrix: sp.sparray) -> None:
        """Add a matrix contribution to block (row, col)."""
        matrix = sp.csr_array(matrix)
        key = (row, col)
        self.matrices[key] = self.matrices[key] + matrix if key in self.matrices else matrix

    def add_rhs(self, row: Block, vector: np.ndarray) -> None:
        """Add a right-hand-side contribution to block ``row``."""
        self.rhs[row] = self.rhs[row] + vector if row in self.rhs else np.array(vector)

    def constrain(self, block: Block, dofs: np.ndarray, values: np.ndarray) -> None:
        """Eliminate prescribed dofs of ``block`` (symmetric: rows, columns and lifting).

        The owner of ``block`` must hold every contribution that touches it.
        """
        if dofs.size == 0:
            return
        for row, columns in self.prescribed_columns(block, dofs):
            self.add_rhs(row, -(columns @ values))
        keep = np.ones(self.sizes[block])
        keep[dofs] = 0.0
        mask = sp.diags_array(keep)
        for (row, col), A in list(self.matrices.items()):
            if row == block and col == block:
                A = mask @ A @ mask + sp.diags_array(1.0 - keep)
            elif row == block:
                A = mask @ A
            elif col == block:
                A = A @ mask
            else:
                continue
            self.matrices[(row, col)] = sp.csr_array(A)
        rhs = self.rhs.get(block, np.zeros(self.sizes[block])).copy()
        rhs[dofs] = values
        self.rhs[block] = rhs

    def prescribed_columns(
        self, block: Block, dofs: np.ndarray
    ) -> list[tuple[Block, sp.csr_array]]:
        """``A[r, D]``: the columns of ``block``'s dofs ``dofs`` in every block row r.

        Prescribed values g put ``-A[r, D] g`` on the right-hand side of row block r.
        """
        return [
            (row, sp.csr_array(sp.csc_array(A)[:, dofs]))
            for row, col, A in self.all_blocks()
            if col == block
        ]

    # -- A itself: the only code that knows a block is stored once for both triangles ----
    def block(self, row: Block, col: Block) -> sp.sparray | None:
        """``A[row, col]``, or ``None`` where the two blocks are not coupled.

        The stored matrix, or the transpose of the stored ``(col, row)``: a view (CSC), no copy.
        """
        if (row, col) in self.matrices:
            return self.matrices[(row, col)]
        if (col, row) in self.matrices:
            return self._transposed(col, row)
        return None

    def _transposed(self, row: Block, col: Block) -> sp.sparray:
        """The transpose of the stored ``(row, col)`` block: a view, remade if A was replaced."""
        A = self.matrices[(row, col)]
        arrays = (A, A.data, A.indices, A.indptr)  # a view sees in-place changes, not new arrays
        cached = self._transposes.get((row, col))
        if cached is not None and all(a is b for a, b in zip(cached[0], arrays, strict=True)):
            return cached[1]
        T = A.T
        self._transposes[(row, col)] = (arrays, T)
        return T

    def all_blocks(self) -> Iterator[tuple[Block, Block, sp.sparray]]:
        """``(row, col, A[row, col])`` of every non-zero block of A.

        In storage order, each stored block followed by its transpose (a view) if it is off
        the diagonal. Sums over these blocks depend on that order in their last bits; the
        callers keep it.
        """
        for (row, col), A in self.matrices.items():
            yield row, col, A
            if row != col:
                yield col, row, self._transposed(row, col)

    def block_row(self, row: Block) -> Iterator[tuple[Block, sp.sparray]]:
        """``(col, A[row, col])`` of every non-zero block in block row ``row``.

        The diagonal block included, in the order of :meth:`all_blocks`.
        """
        for (r, col), A in self.matrices.items():  # all_blocks' order, only row's transposed
            if r == row:
                yield col, A
            if r != col and col == row:
                yield r, self._transposed(r, col)

    def coupled(self, block: Block) -> Iterator[tuple[Block, sp.sparray]]:
        """``(other, A[block, other])`` of every other block coupled to ``block``."""
        for other, A in self.block_row(block):
            if other != block:
                yield other, A

    def row_product(self, row: Block, x: BlockKeyed[np.ndarray]) -> np.ndarray:
        """``(A x)_row``, a new array; a block missing from ``x`` counts as zero."""
        out = np.zeros(self.sizes[row])
        for col, A in self.block_row(row):
            if col in x:
                out += A @ x[col]
        return out

    def triplets(self, offsets: Mapping[str, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A's entries, both triangles, as COO ``(rows, cols, values)`` in one numbering.

        Each block starts at ``offsets[block]``. A transposed block is the stored one's
        entries with rows and columns swapped: no arrays of its own before the concatenation.
        """
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        values: list[np.ndarray] = []
        for (row, col), A in self.matrices.items():
            coo = sp.coo_array(A)
            r, c = coo.row + offsets[row], coo.col + offsets[col]
            rows.append(r)
            cols.append(c)
            values.append(coo.data)
            if row != col:
                rows.append(c)
                cols.append(r)
                values.append(coo.data)
        return _joined(rows, np.int64), _joined(cols, np.int64), _joined(values, np.float64)


def _joined(arrays: list[np.ndarray], dtype) -> np.ndarray:
    return np.concatenate(arrays, dtype=dtype) if arrays else np.zeros(0, dtype)
