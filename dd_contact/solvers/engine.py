"""The block-elimination engine: every decomposition order is data for one solver.

System (14) has three kinds of unknowns: subdomain displacements ``u:`` (large, sparse),
the interface displacement ``v:`` and contact-interface displacements ``w:`` (small). The
engine always condenses the ``u`` blocks first, each with its own sparse factorisation
(MUMPS Cholesky) made once for the whole run, which leaves a dense SPD system on the
surface blocks (A14-A18)::

    S = K_surface - sum_k C_k^T K_hat_k^-1 C_k,     g = b_surface - sum_k C_k^T u_hat_k

where ``C_k`` are the non-zero coupling columns of subdomain k (``-P_DI2``, ``-P_CI2``). An
*order* says in which sequence the surface blocks are then eliminated: ``"v-w-u"`` eliminates
the ``w`` blocks (per subdomain) and solves the condensed interface system for ``v``,
``"w-v-u"`` eliminates ``v`` and solves one coupled ``w`` system, ``"w-u"`` and ``"v-u"``
have one surface level only. Each group of blocks eliminated together gets a dense LAPACK
Cholesky factorisation that is redone only when something it depends on changed (a contact
matrix, an earlier group's factor, a subdomain's condensation), which gives exactly the
counts of the paper's Table 1 (``dd_contact.cost``). Contact on a subdomain's own boundary
(``ContactBoundary``, order ``"v-u"``) makes that subdomain's matrix change: it is then
re-factorised and re-condensed on each of its contact changes.

Parallel: ranks own whole subdomains (the owner of ``u:<name>`` factorises, condenses and
back-substitutes it); the dense surface system, small by construction, is solved on rank 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.assembly import BlockSystem
from dd_contact.parallel import ROOT, bcast_from_root, gather_to_root, gathered
from dd_contact.solvers.linalg import (
    DenseCholesky,
    PatternedMatrix,
    SparseCholesky,
    SparseStatistics,
    WorkLog,
    coo_of,
    sparse_statistics,
)
from dd_contact.solvers.schedule import CONDENSATIONS, ORDERS

__all__ = [
    "BlockEliminationSolver",
    "plan_groups",
    "subdomain_statistics",
]

_CHUNK = 256  # right-hand sides per MUMPS multi-RHS solve when condensing


def _kind(block: str) -> str:
    return block.split(":", 1)[0]


# -- the subdomain level ------------------------------------------------------------------
class _Subdomain:
    """One owned subdomain: its factorisation, condensation, u_hat and back-substitution.

    Attributes:
        layout: ``(surface block, columns)`` of each coupling: the surface dofs tied here.
        Z: ``C^T K^-1 C`` over the concatenated coupling columns (dense).
    """

    def __init__(self, block, system: BlockSystem, contacts: dict, log: WorkLog, condensation: str):
        self.block, self.log = block, log
        n = system.sizes[block]
        self.layout, columns = [], []
        for (row, col), A in system.matrices.items():
            if row == col or block not in (row, col):
                continue
            A = sp.csr_array(A if row == block else A.T)
            A.eliminate_zeros()
            J = np.unique(A.indices)
            self.layout.append((col if row == block else row, J))
            columns.append(A[:, J])
        self.C = sp.csr_array(sp.hstack(columns)) if columns else sp.csr_array((n, 0))
        m = self.C.shape[1]
        # MUMPS's Schur complement: factorise [[K, C], [C^T, 0]] with the last m as Schur
        # block; it gives -Z directly, and solves with K alone (zero-padded vectors).
        self.schur = m if condensation == "schur" else 0
        rows, cols, values = coo_of(system.matrices[(block, block)])
        if self.schur:
            cr, cc, cv = coo_of(self.C)
            diagonal = n + np.arange(m)  # the Schur block's pattern, zero
            rows = np.concatenate([rows, cr, cc + n, diagonal])
            cols = np.concatenate([cols, cc + n, cr, diagonal])
            values = np.concatenate([values, cv, cv, np.zeros(m)])
        size = n + self.schur
        self.matrix = PatternedMatrix(MPI.COMM_SELF, size, size, (rows, cols, values), contacts)
        self.factor: SparseCholesky | None = None
        self.Z, self.u_hat, self._b = None, None, None
        self.u: np.ndarray | None = None

    @property
    def changing(self) -> bool:
        """Whether the matrix must be re-factorised (new contact values, or never done)."""
        return self.factor is None or self.matrix.dirty

    def factorise(self) -> None:
        """(Re-)factorise K_hat and condense the coupling columns: Z = C^T K^-1 C."""
        self.matrix.push()
        if self.factor is None:
            self.factor = SparseCholesky(self.matrix.A, self.log, self.block, self.schur)
        else:
            self.factor.refactorise()
        if self.schur:
            self.Z = -self.factor.schur_complement
        else:
            m = self.C.shape[1]
            self.Z = np.zeros((m, m))
            Csc = self.C.tocsc()
            for j0 in range(0, m, _CHUNK):
                j1 = min(m, j0 + _CHUNK)
                X = self.factor.solve_many(Csc[:, j0:j1].toarray(), "condense")
                self.Z[:, j0:j1] = self.C.T @ X
        self.Z = 0.5 * (self.Z + self.Z.T)  # symmetric up to round-off; make it exact
        self._b = None

    def _solve(self, b: np.ndarray, what: str) -> np.ndarray:
        if not self.schur:
            return self.factor.solve_array(b, what)
        return self.factor.solve_array(np.concatenate([b, np.zeros(self.schur)]), what)[: len(b)]

    def surface_rhs(self, b: np.ndarray) -> np.ndarray:
        """-C^T u_hat for right-hand side b (u_hat is solved for only when b or K changed)."""
        if self._b is None or not np.array_equal(b, self._b):
            self.u_hat = self._solve(b, "u_hat")
            self._b = b.copy()
        self.u = None
        return -(self.C.T @ self.u_hat)

    def back_substitute(self, surface: dict[str, np.ndarray]) -> np.ndarray:
        """U = K^-1 (b - C x_surface) (eq. 17), once per new surface solution."""
        if self.u is None:
            xs = np.concatenate([surface[s][J] for s, J in self.layout] or [np.zeros(0)])
            self.u = self._solve(self._b - self.C @ xs, "u")
        return self.u


def subdomain_statistics(
    comm: MPI.Comm, system: BlockSystem, contacts: dict, condensation: str = "schur"
) -> dict[str, tuple[SparseStatistics, list]]:
    """Collective: each subdomain's analysed matrix and coupling layout.

    The matrix is the one the engine factorises: with its Schur block if
    ``condensation="schur"``. Returns ``block -> (statistics, layout)`` on every rank.
    """
    mine = {}
    for block, owner in system.owners.items():
        if _kind(block) == "u" and owner == comm.rank:
            regions = {k: (d, p) for k, (b, d, p) in contacts.items() if b == block}
            sub = _Subdomain(block, system, regions, WorkLog(), condensation)
            sub.matrix.push()
            mine[block] = (sparse_statistics(sub.matrix.A, sub.schur), sub.layout)
            sub.matrix.A.destroy()
    return gathered(comm, mine)


# -- the dense surface levels (rank 0) ----------------------------------------------------
@dataclass
class _Group:
    """Surface blocks eliminated together, and what was computed for them."""

    blocks: list[str]
    last: bool
    name: str
    neighbours: list[str] = field(default_factory=list)  # later blocks coupled to it
    key: tuple | None = None
    factor: DenseCholesky | None = None
    version: int = 0
    xkey: tuple | None = None
    B: np.ndarray | None = None  # the non-zero coupling columns to the neighbours
    BtX: np.ndarray | None = None  # B^T A_GG^-1 B: what eliminating the group subtracts
    columns: list[tuple[str, np.ndarray]] = field(default_factory=list)
    offsets: np.ndarray | None = None
    g_in: np.ndarray | None = None  # right-hand side when last eliminated
    y: np.ndarray | None = None  # A_GG^-1 g_in
    yversion: int = -1


def plan_groups(
    sizes: dict[str, int], base_pairs: set, layouts: dict[str, list], levels: tuple[str, ...]
) -> tuple[dict[str, dict], set, list[list[_Group]]]:
    """The elimination plan of the surface system for one order.

    Args:
        sizes: Size of every surface block.
        base_pairs: Surface block pairs with a matrix of their own (not from condensation).
        layouts: Per subdomain, ``(surface block, coupled dofs)`` of each of its couplings.
        levels: The order's surface levels (:data:`ORDERS`).

    Returns:
        ``where`` (per subdomain, surface block -> (offset in Z, dofs)), the non-zero block
        pairs after condensation, and the groups of each level: the connected blocks of the
        level's kind, given the fill-in of the earlier eliminations.
    """
    pairs = set(base_pairs)
    where = {}
    for block, layout in layouts.items():
        offsets = np.cumsum([0] + [len(J) for _, J in layout])
        where[block] = {s: (offsets[i], J) for i, (s, J) in enumerate(layout)}
        pairs |= {(a, b) for a, _ in layout for b, _ in layout}
    coupled = {frozenset(p) for p in pairs if p[0] != p[1]}
    remaining = set(sizes)
    all_groups = []
    for li, kind in enumerate(levels):
        level = sorted(b for b in remaining if _kind(b) == kind)
        last = li == len(levels) - 1
        groups: list[_Group] = []
        for b in level:
            joined = [g for g in groups if any(frozenset((b, a)) in coupled for a in g.blocks)]
            merged = [b] + [a for g in joined for a in g.blocks]
            groups = [g for g in groups if g not in joined]
            groups.append(_Group(sorted(merged), last, ""))
        remaining -= set(level)
        for g in groups:
            g.name = "+".join(g.blocks)
            g.neighbours = sorted(
                r for r in remaining if any(frozenset((a, r)) in coupled for a in g.blocks)
            )
            for r1 in g.neighbours:  # fill-in of the elimination
                for r2 in g.neighbours:
                    if r1 != r2:
                        coupled.add(frozenset((r1, r2)))
        all_groups.append(groups)
    return where, pairs, all_groups


class _Surface:
    """The condensed surface system on rank 0 and its elimination by groups."""

    def __init__(self, sizes: dict[str, int], levels: tuple[str, ...], log: WorkLog):
        self.sizes, self.log = sizes, log
        self.base: dict[tuple[str, str], np.ndarray] = {}
        self.condensed: dict[str, np.ndarray] = {}  # latest Z of each subdomain
        self.where: dict[str, dict] = {}  # subdomain -> surface block -> (offset in Z, dofs)
        self.pairs: set[tuple[str, str]] = set()  # surface block pairs that are not zero
        self.contact: dict[str, sp.csr_array] = {}
        self.contact_version: dict[str, int] = {}
        self.R: dict[tuple[str, str], np.ndarray] = {}
        self.version: dict[tuple[str, str], int] = {}
        self.levels = levels
        self.groups: list[list[_Group]] = []
        self._eliminated: dict[tuple[str, str], tuple] = {}  # pair -> (key, matrix) cache

    # set-up
    def add_base(self, row: str, col: str, A: sp.sparray) -> None:
        dense = sp.csr_array(A).toarray()
        self.base[(row, col)] = self.base.get((row, col), 0.0) + dense
        if row != col:
            self.base[(col, row)] = self.base[(row, col)].T

    def plan(self, layouts: dict[str, list]) -> None:
        """Where each subdomain's Z lands, and the groups of each level."""
        self.where, self.pairs, self.groups = plan_groups(
            self.sizes, set(self.base), layouts, self.levels
        )

    # updates
    def set_condensed(self, block: str, Z: np.ndarray) -> None:
        """A subdomain's new condensation: rebuild the surface pairs it touches."""
        self.condensed[block] = Z
        touched = {(a, b) for a in self.where[block] for b in self.where[block]}
        for pair in touched:
            R = np.array(self.base.get(pair, np.zeros((self.sizes[pair[0]], self.sizes[pair[1]]))))
            for k, Zk in self.condensed.items():
                where = self.where[k]
                if pair[0] in where and pair[1] in where:
                    (o1, J1), (o2, J2) = where[pair[0]], where[pair[1]]
                    R[np.ix_(J1, J2)] -= Zk[o1 : o1 + len(J1), o2 : o2 + len(J2)]
            self.R[pair] = R
            self.version[pair] = self.version.get(pair, 0) + 1

    def set_contact(self, block: str, matrix: sp.csr_array) -> None:
        self.contact[block] = matrix
        self.contact_version[block] = self.contact_version.get(block, 0) + 1

    def _matrix(self, pair) -> np.ndarray | None:
        if pair in self.R:
            return self.R[pair]
        return self.base.get(pair)

    # elimination
    def factorise(self) -> None:
        """Redo every group factorisation whose inputs changed since the last time."""
        # E: the current (partly eliminated) pair matrices with a key of what they depend on.
        E = {p: (self._matrix(p), ("R", self.version.get(p, 0))) for p in self.pairs}
        for level in self.groups:
            updates: dict[tuple[str, str], list] = {}
            for g in level:
                key = tuple(E[(a, b)][1] for a in g.blocks for b in g.blocks if (a, b) in E)
                key += tuple(self.contact_version.get(b, 0) for b in g.blocks)
                if key != g.key:
                    g.factor = DenseCholesky(self._assemble(g, E), self.log, g.name)
                    g.key, g.version = key, g.version + 1
                if g.last or not g.neighbours:
                    continue
                xkey = (
                    g.version,
                    *(E[(a, r)][1] for a in g.blocks for r in g.neighbours if (a, r) in E),
                )
                if xkey != g.xkey:
                    self._couple(g, E)
                    g.xkey = xkey
                for i, (r1, J1) in enumerate(g.columns):
                    for j, (r2, J2) in enumerate(g.columns):
                        updates.setdefault((r1, r2), []).append((g, i, j))
            for pair, parts in updates.items():
                key = (E.get(pair, (None, None))[1], tuple(g.xkey for g, _, _ in parts))
                cached = self._eliminated.get(pair)
                if cached is None or cached[0] != key:  # else nothing it depends on changed
                    M = E.get(pair, (None, None))[0]
                    shape = (self.sizes[pair[0]], self.sizes[pair[1]])
                    M = np.zeros(shape) if M is None else M.copy()
                    for g, i, j in parts:
                        (_, J1), (_, J2) = g.columns[i], g.columns[j]
                        o1, o2 = g.offsets[i], g.offsets[j]
                        M[np.ix_(J1, J2)] -= g.BtX[o1 : o1 + len(J1), o2 : o2 + len(J2)]
                    self._eliminated[pair] = cached = (key, M)
                E[pair] = (cached[1], key)

    def _assemble(self, g: _Group, E) -> np.ndarray:
        offsets = np.cumsum([0] + [self.sizes[b] for b in g.blocks])
        A = np.zeros((offsets[-1], offsets[-1]))
        for i, a in enumerate(g.blocks):
            for j, b in enumerate(g.blocks):
                if (a, b) in E:
                    A[offsets[i] : offsets[i + 1], offsets[j] : offsets[j + 1]] = E[(a, b)][0]
            if a in self.contact:
                A[offsets[i] : offsets[i + 1], offsets[i] : offsets[i + 1]] += self.contact[
                    a
                ].toarray()
        return A

    def _couple(self, g: _Group, E) -> None:
        """X = A_GG^-1 B with B the non-zero coupling columns to the later blocks."""
        rows = np.cumsum([0] + [self.sizes[b] for b in g.blocks])
        g.columns, parts = [], []
        for r in g.neighbours:
            B = np.zeros((rows[-1], self.sizes[r]))
            for i, a in enumerate(g.blocks):
                if (a, r) in E:
                    B[rows[i] : rows[i + 1]] = E[(a, r)][0]
            J = np.flatnonzero(np.any(B != 0.0, axis=0))
            g.columns.append((r, J))
            parts.append(B[:, J])
        g.B = np.hstack(parts)
        g.offsets = np.cumsum([0] + [len(J) for _, J in g.columns])
        g.BtX = g.factor.congruence(g.B, "condense")

    def solve(self, g: dict[str, np.ndarray], complete: bool) -> dict[str, np.ndarray]:
        """Eliminate the right-hand side forward and solve the last level.

        With ``complete``, back-substitute the earlier levels too.
        """
        g = {b: v.copy() for b, v in g.items()}
        for level in self.groups:
            for grp in level:
                rhs = np.concatenate([g[b] for b in grp.blocks])
                if grp.last:
                    self._split(grp, grp.factor.solve(rhs, "x"), g)
                    continue
                if (
                    grp.y is None
                    or grp.yversion != grp.version
                    or not np.array_equal(rhs, grp.g_in)
                ):
                    grp.y, grp.g_in, grp.yversion = grp.factor.solve(rhs, "y"), rhs, grp.version
                if grp.neighbours:
                    correction = grp.B.T @ grp.y
                    for i, (r, J) in enumerate(grp.columns):
                        g[r][J] -= correction[grp.offsets[i] : grp.offsets[i + 1]]
        x = {b: g[b] for grp in self.groups[-1] for b in grp.blocks}
        if complete:
            x.update(self.back_substitute(x))
        return x

    def back_substitute(self, x: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Solve the earlier levels, last first, given the later blocks in ``x``."""
        x = dict(x)
        for level in reversed(self.groups[:-1]):
            for grp in level:
                rhs = grp.g_in.copy()
                if grp.neighbours:
                    coupled = np.concatenate([x[r][J] for r, J in grp.columns])
                    rhs -= grp.B @ coupled
                self._split(grp, grp.factor.solve(rhs, "x"), x)
        return x

    def _split(self, grp: _Group, values: np.ndarray, out: dict) -> None:
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
        contacts: ``key -> (block, dofs, pattern)`` of this rank's contact regions.
        log: Where factorisations and solves are recorded.
        order: One of :data:`ORDERS`.
        condensation: How ``C^T K^-1 C`` is formed: ``"schur"`` (default: MUMPS computes the
            Schur complement of ``[[K, C], [C^T, 0]]`` within the factorisation; measured
            about 3x faster at 150k dofs) or ``"multi-rhs"`` (one substitution per coupling
            column, in blocks of 256, as the paper counts it).
    """

    def __init__(
        self,
        comm: MPI.Comm,
        system: BlockSystem,
        contacts: dict[str, tuple[str, np.ndarray, sp.csr_array]],
        log: WorkLog,
        order: str,
        condensation: str = "schur",
    ):
        if condensation not in CONDENSATIONS:
            raise ValueError(
                f"unknown condensation {condensation!r}; valid: {', '.join(CONDENSATIONS)}"
            )
        self.comm, self.system, self.log, self.order = comm, system, log, order
        rank = comm.rank
        self._zone_block = {key: block for key, (block, _, _) in contacts.items()}
        self._zone_dofs = {key: dofs for key, (_, dofs, _) in contacts.items()}
        self.subdomains: dict[str, _Subdomain] = {}
        for block, owner in system.owners.items():
            if _kind(block) == "u" and owner == rank:
                mine = {k: (d, p) for k, (b, d, p) in contacts.items() if b == block}
                self.subdomains[block] = _Subdomain(block, system, mine, log, condensation)
        surface_sizes = {b: n for b, n in system.sizes.items() if _kind(b) != "u"}
        # Blocks the contact check reads (any rank): they are solved in every iteration.
        needed = {b for part in comm.allgather(set(self._zone_block.values())) for b in part}
        # Anything but the last level is found by back-substitution; u needs every surface block.
        self._needs_all_surface = any(_kind(b) != ORDERS[order][-1] for b in needed)
        self._needed_u = needed & set(self.subdomains)
        pieces = [(r, c, A) for (r, c), A in system.matrices.items() if _kind(r) != "u" != _kind(c)]
        pieces = gather_to_root(comm, pieces)
        self.surface: _Surface | None = None
        if rank == ROOT:
            self.surface = _Surface(surface_sizes, ORDERS[order], log)
            for part in pieces:
                for r, c, A in part:
                    self.surface.add_base(r, c, A)
        layouts = gather_to_root(comm, {b: s.layout for b, s in self.subdomains.items()})
        if rank == ROOT:
            self.surface.plan({b: layout for part in layouts for b, layout in part.items()})
        self._contact: dict[str, sp.csr_array] = {}  # latest contact matrix of each w block
        self._pending_contact: dict[str, sp.csr_array] = {}  # changed since the last solve
        self._x: dict[str, np.ndarray] = {}
        self._complete = False

    def set_contact(self, key: str, matrix: sp.csr_array) -> None:
        """Replace the contact matrix of region ``key`` (surface dof numbering)."""
        block, dofs = self._zone_block[key], self._zone_dofs[key]
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
        payload = {"Z": {}, "g": [], "contact": self._pending_contact}
        self._pending_contact = {}
        for block, sub in self.subdomains.items():
            if sub.changing:
                sub.factorise()
                payload["Z"][block] = sub.Z
            b = rhs.get(block, np.zeros(self.system.sizes[block]))
            g = sub.surface_rhs(b)
            start = 0
            for s, J in sub.layout:
                payload["g"].append((s, J, g[start : start + len(J)]))
                start += len(J)
        for block, vector in rhs.items():
            if _kind(block) != "u":
                payload["g"].append((block, None, vector))
        received = gather_to_root(self.comm, payload)
        x = None
        if self.comm.rank == ROOT:
            surface = self.surface
            g = {b: np.zeros(n) for b, n in surface.sizes.items()}
            for part in received:
                for block, Z in part["Z"].items():
                    surface.set_condensed(block, Z)
                for block, matrix in part["contact"].items():
                    surface.set_contact(block, matrix)
                for s, J, vector in part["g"]:
                    if J is None:
                        g[s] += vector
                    else:
                        g[s][J] += vector
            surface.factorise()
            x = surface.solve(g, complete=self._needs_all_surface)
        self._x = bcast_from_root(self.comm, x)
        self._complete = self._needs_all_surface
        out = dict(self._x)
        for block in self._needed_u:
            out[block] = self.subdomains[block].back_substitute(self._x)
        return out

    def finish(self) -> dict[str, np.ndarray]:
        """Every block of the last solution, on every rank (collective)."""
        if not self._complete:
            x = self.surface.back_substitute(self._x) if self.comm.rank == ROOT else None
            self._x = bcast_from_root(self.comm, x)
            self._complete = True
        u = {b: s.back_substitute(self._x) for b, s in self.subdomains.items()}
        return {**self._x, **gathered(self.comm, u)}

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for sub in self.subdomains.values():
            if sub.factor is not None:
                sub.factor.destroy()
            sub.matrix.A.destroy()
