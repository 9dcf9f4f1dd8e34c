"""Reduced subdomains: Craig-Bampton with penalty ties (docs/solvers.md, "Reduced subdomains").

A subdomain talks to the rest of the model only through the dofs its tie and contact terms
act on (the boundary dofs b); call the other free dofs i. With A its stiffness (ties
included: they act on b only) and M its mass, the subdomain is represented by

* constraint modes ``Psi = [I; -A_ii^-1 A_ib]``, the static response to each boundary dof;
* m fixed-interface modes ``A_ii phi = omega^2 M_ii phi``, the lowest (a block Lanczos on
  ``A_ii^-1 M_ii``, :mod:`~dd_contact.solvers.eigen`, or SLEPc's shift-invert, both with
  the subdomain's own MUMPS factor of ``A_ii``);
* a load mode ``A_ii^-1 p_i`` per load pattern p (so that quasi-static response is exact),

``T = [Psi, [0; G]]``, G the modes and load modes M-orthonormalised; ``A_r = T^T A T`` and
``M_r = T^T M T`` are small and dense. ``Psi`` is never formed whole: its columns are taken
:data:`REDUCTION_CHUNK` at a time (out of core, a pass's
:data:`~dd_contact.solvers.interior.OUT_OF_CORE_COLUMNS`; ``A_r``'s boundary block is the
Schur complement, ``M_r``'s ``Y_b - A_bi A_ii^-1 Y_i`` with ``Y = M Psi``). With b the
factor's Schur block (:class:`~dd_contact.solvers.interior.SchurInterior`) a block of Psi is
one backward sweep, ``A_bi A_ii^-1 Y_i`` one forward sweep. In ``q = [u_b, g]`` the boundary
dofs stay physical; ``u_i = -A_ii^-1 A_ib u_b + G g`` is one backward sweep, when read.
"""

from __future__ import annotations

from collections.abc import Sequence

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockSystem
from dd_contact.errors import InputError
from dd_contact.solvers import eigen
from dd_contact.solvers.dense import DenseCholesky
from dd_contact.solvers.eigen import KrylovResidual, fixed_interface_modes
from dd_contact.solvers.interior import InteriorMatrix, interior_factor
from dd_contact.solvers.linalg import (
    PatternedMatrix,
    SparseStatistics,
    coo_of,
    petsc_matrix,
    release_freed_memory,
)
from dd_contact.solvers.subdomains import coupling_layout
from dd_contact.solvers.worklog import WorkLog
from dd_contact.subdomains import MODES_TOLERANCE

__all__ = ["DenseCondensation", "ReducedBasis", "fixed_interface_modes", "reduced_subdomains"]

#: Constraint modes taken at once, at most (three n x columns arrays at a block's peak) ...
REDUCTION_CHUNK = 64

#: ... at most so many bytes in each, but 32 columns at least: a MUMPS solve reads the
#: factor once per block of columns, which fewer than 32 do not pay for (335k interior dofs,
#: 293M factor entries: 128 ms a column in blocks of 8 or 16, 84 in blocks of 32, 79 in 64).
CHUNK_BYTES = 8 * 2**20

#: An interior of at most this many dofs is kept whole (every fixed-interface mode, by a
#: dense eigensolve) when as many modes as its dofs or more are asked (SLEPc gives one less): a
#: small block next to its boundary, like the pin joint's hole blocks (12-600 interior dofs).
WHOLE_INTERIOR_LIMIT = 4000

#: A load whose part outside the span of the load patterns is below this fraction of itself
#: is in their span: the rest is the round-off of its assembly, which grows with the mesh
#: (6e-14 of the body-force load at 21k dofs, 6e-13 at 87k, above 1e-12 on most steps at
#: 342k, where a stricter floor projected it with a full substitution, 0.4 s a step).
#: Dropped, it changes the answer by this fraction, far below the 1e-8 of quasi-statics.
LOAD_SPAN_FLOOR = 1e-10

#: A load mode whose part outside the normal modes (and the earlier load modes) is below
#: this fraction of itself adds nothing the basis does not hold: it is dropped.
LOAD_MODE_FLOOR = 1e-10


def _petsc(A: sp.sparray) -> PETSc.Mat:
    rows, cols, values = coo_of(sp.csr_array(A))
    n = A.shape[0]
    return petsc_matrix(MPI.COMM_SELF, n, n, rows, cols, values)


def _pattern_span(patterns: Sequence[np.ndarray], n: int, fixed: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the load patterns' span off the prescribed dofs.

    A pattern may vanish there (a traction component on guided dofs) or repeat another:
    the span's rank, not the patterns' count, gives the load modes.
    """
    if not len(patterns):
        return np.zeros((n, 0))
    P = np.column_stack(patterns)
    P[fixed] = 0.0
    Q, s, _ = np.linalg.svd(P, full_matrices=False)
    return Q[:, s > LOAD_MODE_FLOOR * max(s.max(), 1e-300)]


def _pieces(S: sp.sparray, b: np.ndarray, i: np.ndarray, D: np.ndarray) -> dict:
    """The blocks of S a reduction reads, by rows and columns: ii, ib, bb, bi, Db, Di."""
    S = sp.csr_array(S)
    rows = {"i": S[i], "b": S[b], "D": S[D]}
    columns = {"i": i, "b": b}
    pairs = ("ii", "ib", "bb", "bi", "Db", "Di")
    return {p: sp.csr_array(rows[p[0]][:, columns[p[1]]]) for p in pairs}


def _chunk(n: int) -> int:
    """Columns of an n-row block: REDUCTION_CHUNK at most, CHUNK_BYTES at most, 32 at least."""
    return max(32, min(REDUCTION_CHUNK, CHUNK_BYTES // (8 * max(n, 1))))


def _unit_columns(n: int, at: np.ndarray) -> np.ndarray:
    """Columns ``at`` of the n x n identity (Fortran-ordered)."""
    E = np.zeros((n, at.size), order="F")
    E[at, np.arange(at.size)] = 1.0
    return E


def _columns_read(*blocks: sp.sparray) -> np.ndarray:
    """The columns where any of the sparse blocks has an entry (sorted)."""
    used = [sp.csr_array(S).indices for S in blocks]
    return np.unique(np.concatenate(used)) if used else np.zeros(0, np.int64)


def _add_sparse(Y: np.ndarray, S: sp.sparray) -> None:
    """``Y += S`` in place (no dense copy of S)."""
    S = sp.coo_array(S)
    S.sum_duplicates()
    Y[S.row, S.col] += S.data


def _symmetrise(S: np.ndarray, rows: int = 256) -> None:
    """``S = (S + S^T) / 2`` in place, by blocks of rows (no temporary of S's size)."""
    for r0 in range(0, S.shape[0], rows):
        r1 = min(r0 + rows, S.shape[0])
        S[r0:r1, r0:r1] = 0.5 * (S[r0:r1, r0:r1] + S[r0:r1, r0:r1].T)
        S[r0:r1, r1:] = 0.5 * (S[r0:r1, r1:] + S[r1:, r0:r1].T)
        S[r1:, r0:r1] = S[r0:r1, r1:].T


def _congruence(G: np.ndarray, S: sp.sparray | InteriorMatrix, chunk: int) -> np.ndarray:
    """``G^T S G``, S G taken ``chunk`` columns at a time (never a second G in memory)."""
    out = np.empty((G.shape[1], G.shape[1]))
    for j0 in range(0, G.shape[1], chunk):
        out[:, j0 : j0 + chunk] = G.T @ (S @ G[:, j0 : j0 + chunk])
    return out


def _by_columns(S: sp.sparray, G: np.ndarray, chunk: int) -> np.ndarray:
    """``S G``, G's columns a block at a time: scipy copies the modes whole (F-ordered)."""
    return np.hstack([S @ G[:, j0 : j0 + chunk] for j0 in range(0, max(G.shape[1], 1), chunk)])


def _orthonormal(V: np.ndarray, m: int, L: np.ndarray, M: InteriorMatrix | None) -> np.ndarray:
    """``[Phi, L']``: the load modes L made M-orthonormal to Phi and each other, in place.

    Phi, V's first m columns, is M-orthonormal already; the load modes are written into
    V's next columns (no copy of the modes: they are most of the reduction's memory); a
    load mode whose remainder is below LOAD_MODE_FLOOR of itself is dropped. Without a
    mass matrix the identity is the inner product. Returns V's columns in use (a view).
    """

    def inner(X, y):
        return X.T @ (y if M is None else M @ y)

    j = m
    for k in range(L.shape[1]):
        y = L[:, k].copy()
        size = np.sqrt(inner(y[:, None], y)[0])
        for _ in range(2):  # twice is enough (Kahan)
            if j:
                y -= V[:, :j] @ inner(V[:, :j], y)
        rest = np.sqrt(max(inner(y[:, None], y)[0], 0.0))
        if size > 0 and rest > LOAD_MODE_FLOOR * size:
            V[:, j] = y / rest
            j += 1
    return V[:, :j]


class ReducedBasis:
    """The Craig-Bampton basis of one subdomain and its reduced matrices.

    Args:
        A: The subdomain's stiffness with its tie terms (unconstrained, n x n).
        M: Its mass matrix as the time scheme uses it (``None``: no inertia).
        boundary: The dofs the tie and contact terms act on (b).
        fixed: The prescribed dofs (removed).
        patterns: Load patterns (full vectors): one load mode each.
        modes: Number of fixed-interface modes m.
        log: Where the factorisation and solves are recorded.
        name: The subdomain's name, for the log and messages.
        tolerance: The eigensolver's relative tolerance on the modes.
        eigensolver: ``"block"`` (:func:`~dd_contact.solvers.eigen.lowest_modes`) or
            ``"slepc"`` (:func:`fixed_interface_modes`).
        out_of_core: Its interior's factor on disk (MUMPS's ICNTL(22) = 1).

    Attributes:
        b, i: The boundary and interior dofs (sorted; the prescribed ones in neither).
        G: The normal and load modes on the interior, M-orthonormal (n_i x (m + loads)).
        omega2: The fixed-interface eigenvalues omega^2 found.
        A_r, M_r: ``T^T A T`` and ``T^T M T`` (dense; ``M_r`` is ``None`` without mass).
        size: ``n_b + G``'s columns: the reduced coordinates.
    """

    def __init__(
        self,
        A: sp.sparray,
        M: sp.sparray | None,
        boundary: np.ndarray,
        fixed: np.ndarray,
        patterns: Sequence[np.ndarray],
        modes: int,
        log: WorkLog,
        name: str,
        tolerance: float = MODES_TOLERANCE,
        eigensolver: str = "block",
        out_of_core: bool = False,
    ):
        n = A.shape[0]
        self.n, self.name, self.log = n, name, log
        self.fixed = np.asarray(fixed, dtype=np.int64)
        free = np.setdiff1d(np.arange(n), self.fixed)
        self.b = np.intersect1d(np.asarray(boundary, dtype=np.int64), free)
        self.i = np.setdiff1d(free, self.b)
        if modes < 0 or (modes >= self.i.size and self.i.size > WHOLE_INTERIOR_LIMIT):
            raise InputError(
                f"subdomain {name!r}: reduce(modes={modes}) asks for more fixed-interface modes "
                f"than its {self.i.size} interior dofs allow; ask for fewer (0 to "
                f"{max(self.i.size - 1, 0)})"
            )
        # its pieces; the whole matrices go before the factor (reduce_model keeps none)
        Ap = _pieces(A, self.b, self.i, self.fixed)
        Mp = None if M is None else _pieces(M, self.b, self.i, self.fixed)
        del A, M
        self._A_ib = Ap["ib"]
        Ap["ii"] = A_ii = InteriorMatrix(Ap["ii"])
        M_ii = None if Mp is None else InteriorMatrix(Mp.pop("ii"), whole=True)
        release_freed_memory()  # the slicing's temporaries, before the factor's peak
        self.factor = interior_factor(A_ii, self._A_ib, log, f"{name} (interior)", out_of_core)
        P = _pattern_span(patterns, n, self.fixed)
        self.omega2, V, residual = self._modes(
            A_ii, M_ii, modes, (tolerance, eigensolver), P.shape[1]
        )
        A_ii.release()  # SLEPc's operator (made for it alone)
        del A_ii  # Ap's is the one left: _reduced frees it once read
        raw = self.factor.solve(P[self.i], "load modes") if P.shape[1] else P[self.i]
        self.G = _orthonormal(V, self.omega2.size, raw, M_ii)
        self._M_ii = M_ii
        #: ``G^T M_ii A_ii^-1 A_ib`` (with mass; :meth:`wall_directions`)
        self._constraints_in_modes: np.ndarray | None = None
        self.size = self.b.size + self.G.shape[1]
        #: Its massless coordinates (contact walls; set by :func:`reduce_model`).
        self.massless = np.zeros(0, np.int64)
        self.A_r, self.M_r = self._reduced(Ap, Mp, residual)
        # T^T p of each pattern (p_b - A_bi A_ii^-1 p_i; G^T p_i), for loads in their span
        self._patterns: np.ndarray = P
        self._F = np.vstack([P[self.b] - self._A_ib.T @ raw, self.G.T @ P[self.i]])

    def _modes(self, A_ii, M_ii, modes: int, how: tuple, extra: int) -> tuple:
        """The ``modes`` lowest fixed-interface modes (none: empty; all if that many or more).

        As the first columns of an array with ``extra`` more (:func:`fixed_interface_modes`);
        ``how``: the tolerance and the eigensolver. Returns ``omega^2``, that array and the
        modes' :class:`~dd_contact.solvers.eigen.KrylovResidual` (``None``: SLEPc's, not known).
        """
        n = self.i.size
        if not modes:
            return np.zeros(0), np.zeros((n, extra)), KrylovResidual.exact(n, 0)
        if M_ii is None:
            raise InputError(
                f"subdomain {self.name!r}: reduce(modes={modes}) needs a mass matrix (a "
                "density) for its normal modes; use modes=0 for a static reduction"
            )
        if modes >= n:  # every mode: the interior whole (SLEPc gives n - 1 at most)
            eye = np.eye(n)
            values, vectors = scipy.linalg.eigh(A_ii @ eye, M_ii @ eye)
            exact = KrylovResidual.exact(n, n)
            return values, np.hstack([vectors, np.zeros((n, extra))]), exact
        tolerance, eigensolver = how
        if eigensolver == "slepc":
            try:
                return *fixed_interface_modes(
                    A_ii.mat, self.factor, M_ii.mat, modes, tolerance, self.name, extra
                ), None
            finally:
                M_ii.release()  # SLEPc's copy: the products are the matrix's
        residual, on_disk = KrylovResidual(), self.factor.pass_columns is not None
        values, vectors = eigen.lowest_modes(
            lambda X: self.factor.solve(X, "modes"), M_ii.__matmul__, n, modes, tolerance,
            self.name, eigen.MODES_BLOCK_OUT_OF_CORE if on_disk else eigen.MODES_BLOCK,
            eigen.MODES_WORKSPACE, extra, krylov_residual=residual,
        )  # fmt: skip
        return values, vectors, residual

    def _constraints_seen_by_modes(self, residual: KrylovResidual, A_ib) -> np.ndarray:
        """``G^T M_ii A_ii^-1 A_ib`` (G's columns x n_b) without a solve per boundary dof.

        It is ``(C G)^T A_ib`` with ``C = A_ii^-1 M_ii``: the modes' rows by their Krylov
        relation ``C Phi = Phi diag(1 / omega^2) + Q B`` (``residual``), the load modes' by
        one solve each. The constraint modes' mass then needs no product with G per block of
        them (at 1/4 of the paper's bar, 14 s of the set-up's dgemm).
        """
        G, m, M_ii = self.G, self.omega2.size, self._M_ii
        assert M_ii is not None  # with mass only
        near = np.unique(sp.coo_array(A_ib).row)  # the interior rows A_ib reads
        A_near = sp.csr_array(sp.csr_array(A_ib)[near])

        def seen(X: np.ndarray) -> np.ndarray:  # X^T A_ib from X's rows near the boundary
            return np.asarray((A_near.T @ X[near]).T)

        out = np.empty((G.shape[1], self.b.size))
        out[:m] = seen(G[:, :m]) / self.omega2[:, None]
        out[:m] += residual.coupling.T @ seen(residual.block)
        if G.shape[1] > m:
            loads = self.factor.solve(M_ii @ G[:, m:], "load modes' response")
            out[m:] = seen(loads)
        return out

    def _reduced(self, Ap: dict, Mp: dict | None, residual: KrylovResidual | None) -> tuple:
        """``T^T A T`` and ``T^T M T``, Psi's columns a block at a time (from :func:`_pieces`).

        ``residual``: the modes' Krylov relation, if known (:meth:`_constraints_seen_by_modes`).
        """
        G, M = self.G, Mp
        nb, r = self.b.size, self.size
        A_r = np.zeros((r, r))
        M_r = None if M is None else np.zeros((r, r))
        A_ii, A_bb, A_bi = Ap["ii"], Ap["bb"], Ap["bi"]
        M_ii = self._M_ii
        chunk = _chunk(self.n)
        A_r[nb:, nb:] = _congruence(G, A_ii, chunk)  # (A Psi)_i = 0: no coupling to the modes
        del A_ii, Ap["ii"]  # read no more: gone before the blocks' arrays
        D = self.fixed
        A_Db, A_Di = Ap["Db"], Ap["Di"]
        #: ``A[D, :] T`` and ``M[D, :] T``: the supports' rows, for their reactions.
        self.reaction_rows = np.zeros((D.size, r))
        self.reaction_rows[:, nb:] = _by_columns(A_Di, G, chunk)
        self.reaction_mass: np.ndarray | None = None
        if M is not None:
            self.reaction_mass = np.zeros((D.size, r))
            self.reaction_mass[:, nb:] = _by_columns(M["Di"], G, chunk)
            assert M_r is not None and M_ii is not None  # with M
            M_bb, M_bi, M_ib, M_Db, M_Di = M["bb"], M["bi"], M["ib"], M["Db"], M["Di"]
            M_r[nb:, nb:] = _congruence(G, M_ii, chunk)
            if residual is not None:
                # G^T Y_i = G^T M_ib - G^T M_ii A_ii^-1 A_ib, whole
                seen = self._constraints_seen_by_modes(residual, self._A_ib)
                self._constraints_in_modes = seen
                M_r[nb:, :nb] = _by_columns(M_ib.T, G, chunk).T - seen
                M_r[:nb, nb:] = M_r[nb:, :nb].T
        # the b and D rows' products read X's rows next to them alone, gathered (scipy's
        # products would copy the whole of X, C-ordered, for each)
        near = _columns_read(A_bi, A_Di, *([] if M is None else [M_bi, M_Di]))
        A_bi, A_Di = A_bi[:, near], A_Di[:, near]
        if M is not None:
            M_bi, M_Di = M_bi[:, near], M_Di[:, near]
        width = self.factor.pass_columns or chunk  # out of core: fewer reads of the factor
        ni, work = self.i.size, [self.factor.workspace(min(width, nb)) for _ in range(2)]
        for j0 in range(0, nb, width):
            j1 = min(nb, j0 + width)
            into = [w[:, : j1 - j0] for w in work]  # the same pages block after block
            E = _unit_columns(nb, np.arange(j0, j1))
            X = self.factor.response(E, "constraint modes", into[0])
            X_near = X[near]
            A_r[:nb, j0:j1] = A_bb[:, j0:j1].toarray() - A_bi @ X_near
            self.reaction_rows[:, j0:j1] = A_Db[:, j0:j1].toarray() - A_Di @ X_near
            if M is None:
                continue
            assert M_r is not None and M_ii is not None  # with M
            assert self.reaction_mass is not None  # with M
            self.reaction_mass[:, j0:j1] = M_Db[:, j0:j1].toarray() - M_Di @ X_near
            Y_b = M_bb[:, j0:j1].toarray() - M_bi @ X_near  # Y = M Psi, this block of columns
            Y_i = M_ii.times(X, out=into[1][:ni])
            del X
            Y_i *= -1.0
            _add_sparse(Y_i, M_ib[:, j0:j1])
            if residual is None:
                M_r[nb:, j0:j1] = G.T @ Y_i
                M_r[j0:j1, nb:] = M_r[nb:, j0:j1].T
            M_r[:nb, j0:j1] = Y_b - self.factor.condensed(Y_i, "constraint modes' mass", into[1])
        if M_r is not None and residual is None:
            # G^T M_ii A_ii^-1 A_ib, for the walls' directions without a solve: M_r's modes
            # rows hold G^T Y_i = G^T (M_ib - M_ii A_ii^-1 A_ib), column by column
            # (by columns of G: scipy's sparse product would copy G whole, 0.9 GB at 1/4)
            self._constraints_in_modes = _by_columns(M_ib.T, G, chunk).T - M_r[nb:, :nb]
        _symmetrise(A_r)  # symmetric up to round-off; make it exact
        if M_r is not None:
            _symmetrise(M_r)
        return A_r, M_r

    # -- vectors ---------------------------------------------------------------------------
    def project(self, v: np.ndarray) -> np.ndarray:
        """``T^T v`` exactly: one substitution if v has interior entries, none otherwise."""
        v_i = v[self.i]
        out = np.empty(self.size)
        out[: self.b.size] = v[self.b]
        out[self.b.size :] = self.G.T @ v_i
        if np.any(v_i):
            out[: self.b.size] -= self.factor.condensed(v_i, "projection")
        return out

    def project_load(self, v: np.ndarray) -> np.ndarray:
        """``T^T v``, without a substitution when v is a combination of the load patterns.

        Its entries on the prescribed dofs are dropped: the supports' reaction is given them
        (``v[basis.fixed]``) with the same step's coordinates (:meth:`reaction`).
        """
        if self._patterns.shape[1]:
            Q = self._patterns
            c = Q.T @ v
            rest = v - Q @ c
            rest[self.fixed] = 0.0
            if np.linalg.norm(rest) <= LOAD_SPAN_FLOOR * max(np.linalg.norm(v), 1e-300):
                return self._F @ c
        return self.project(v)

    def expand(self, q: np.ndarray, what: str = "expansion") -> np.ndarray:
        """The full vector ``T q`` (zero on the prescribed dofs): one substitution."""
        nb = self.b.size
        u = np.zeros(self.n)
        u[self.b] = q[:nb]
        u[self.i] = self.G @ q[nb:]
        if np.any(q[:nb]):
            u[self.i] -= self.factor.response(q[:nb], what)
        return u

    def coordinates(self, u: np.ndarray) -> np.ndarray:
        """The reduced coordinates of a full field: ``u_b``, and G's part of the rest.

        Exact for a field in the basis's span (``T q``: a rigid motion, the static response
        to boundary values and the loads); otherwise its M-orthogonal projection (or, without
        mass, the plain one).
        """
        nb = self.b.size
        q = np.zeros(self.size)
        q[:nb] = u[self.b]
        rest = u[self.i].copy()
        if np.any(q[:nb]):
            rest += self.factor.response(q[:nb], "coordinates")
        if self.G.shape[1]:
            q[nb:] = self._in_modes(rest)
        return q

    def _in_modes(self, rest: np.ndarray) -> np.ndarray:
        """G's coordinates of interior fields ``rest``: M-orthogonal projection (or plain)."""
        if self._M_ii is None:
            return np.linalg.lstsq(self.G, rest, rcond=None)[0]
        return self.G.T @ (self._M_ii @ rest)

    def wall_directions(self, wall: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A contact wall's coordinates and the moves of q that shift it alone.

        ``wall``: its dofs (full numbering, all boundary). Returns their positions in q and
        P, one column per wall dof: the coordinates of that dof's unit displacement
        (:meth:`coordinates`), its constraint mode with the interior's motion taken back
        through the modes. With every mode the interior stays exactly put (P is the
        whole subdomain's unit vector in this basis), so settling a massless wall along P
        is the whole subdomain's settle; with fewer, the interior keeps what the modes
        cannot take back.
        """
        at = np.searchsorted(self.b, wall)
        if wall.size and not np.array_equal(self.b[np.minimum(at, self.b.size - 1)], wall):
            raise ValueError(f"subdomain {self.name!r}: a wall dof is not a boundary dof")
        P = np.zeros((self.size, at.size))
        P[at, np.arange(at.size)] = 1.0
        if self._constraints_in_modes is not None:  # formed with M_r: no solve
            P[self.b.size :] = self._constraints_in_modes[:, at]
            return at, P
        chunk = _chunk(self.n)  # a wall may hold most of b: its columns a block at a time
        for j0 in range(0, at.size if self.G.shape[1] else 0, chunk):
            U = _unit_columns(self.b.size, at[j0 : j0 + chunk])
            P[self.b.size :, j0 : j0 + chunk] = self._in_modes(
                self.factor.response(U, "wall directions")
            )
        return at, P

    def destroy(self) -> None:
        """Free the factorisation."""
        self.factor.destroy()
        if self._M_ii is not None:
            self._M_ii.release()

    def prescribed(self, values: np.ndarray, t: float) -> np.ndarray:
        """The values of its prescribed dofs as the reduced block sees them: none (zero)."""
        if np.any(values):
            raise NotImplementedError(
                f"subdomain {self.name!r}: a reduced subdomain with non-zero prescribed "
                f"displacement (at t = {t}) is not built yet; prescribe zero there, or do not "
                "reduce it"
            )
        return np.zeros(0)

    def reaction(
        self, q: np.ndarray, acceleration: np.ndarray | None, load: np.ndarray
    ) -> np.ndarray:
        """The supports' reaction rows ``A[D] T q + M[D] T a - f_D``.

        ``load`` is f_D, the load of the same solve on the prescribed dofs ``fixed`` (passed,
        not remembered: a remembered one was once the previous step's).
        """
        r = self.reaction_rows @ q - load
        if self.reaction_mass is not None and acceleration is not None:
            r += self.reaction_mass @ acceleration
        return r


class DenseCondensation:
    """A reduced subdomain in the block elimination: a small dense Cholesky factor.

    The same surface-facing operations as
    :class:`~dd_contact.solvers.subdomains.SubdomainCondensation`, on the reduced matrix
    (``c M_r + A_r``, the couplings on its boundary rows): Z = C^T K^-1 C, the surface
    right-hand side and the reduced coordinates q given the surface solution (eq. 17).

    Args:
        block: The subdomain's block.
        system: The block system (this rank holds every piece of the block).
        log: Where the work is recorded.
    """

    def __init__(self, block: Block, system: BlockSystem, log: WorkLog):
        self.block, self.log = block, log
        # C is sparse (the ties touch boundary coordinates only): a step's products with
        # it are cheap, and its dense K^-1 C (kept once factorised) is what a step reads
        self.layout, self.C = coupling_layout(block, system)
        self._KC: np.ndarray | None = None
        K = system.block(block, block)
        assert K is not None  # a reduced block's matrix, this rank's
        self.K = K.toarray()
        n = self.K.shape[0]
        empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
        self.matrix = PatternedMatrix(MPI.COMM_SELF, n, n, empty, [], upper_coo=True)
        self.Z: np.ndarray | None = None
        self.factor: DenseCholesky | None = None
        self._b: np.ndarray | None = None
        self._g: np.ndarray | None = None
        self._y: np.ndarray | None = None
        self.u: np.ndarray | None = None

    @property
    def changing(self) -> bool:
        """Whether it must be factorised before the next solve (only once: no contact here)."""
        return self.factor is None

    def analyse(self) -> SparseStatistics:
        """What its dense factorisation costs (for the timing model)."""
        n = self.K.shape[0]
        return SparseStatistics(n, n * n, n**3 / 3.0, n * (n + 1) / 2.0)

    def factorise(self) -> None:
        """Factorise the reduced matrix and condense: Z = C^T K^-1 C."""
        self.factor = DenseCholesky(self.K.copy(), self.log, self.block)
        C = self.C.toarray()
        self.Z = self.factor.congruence(C, "condense")
        self._KC = self.factor.solve(C, "condense")
        self._b = None

    def surface_rhs(self, b: np.ndarray) -> np.ndarray:
        """-C^T K^-1 b, computed only when b changed."""
        if self._b is None or not np.array_equal(b, self._b):
            assert self.factor is not None  # factorised first
            self._b = b.copy()
            self._y = self.factor.solve(b, "u_hat")
            self._g = -(self.C.T @ self._y)
        self.u = None
        assert self._g is not None  # computed with _b
        return self._g

    def back_substitute(self, surface: dict[str, np.ndarray]) -> np.ndarray:
        """Q = K^-1 (b - C x_surface), once per new surface solution.

        ``K^-1 b - (K^-1 C) x_surface``: one product with the kept ``K^-1 C``, which reads
        half what a substitution and the products with C did (the quiet step at 1/4 is bound
        by its reading of the reduced block's arrays).
        """
        if self.u is None:
            assert self.factor is not None and self._y is not None  # surface_rhs came first
            assert self._KC is not None  # made with the factor
            xs = np.concatenate([surface[s][J] for s, J in self.layout] or [np.zeros(0)])
            self.u = self._y - self.factor.product(self._KC, xs, "u", transpose=False)
        return self.u

    def destroy(self) -> None:
        """Free the (empty) PETSc matrix."""
        self.matrix.destroy()


def reduced_subdomains(
    comm: MPI.Comm, system: BlockSystem, log: WorkLog
) -> dict[Block, DenseCondensation]:
    """The reduced subdomains this rank owns, each ready to factorise."""
    return {
        block: DenseCondensation(block, system, log)
        for block in sorted(system.reduced)
        if system.owners[block] == comm.rank
    }
