"""The subdomain level of the block elimination: each owned subdomain factorised and condensed.

A subdomain talks to the surface only through its coupling columns ``C`` (the tie and
contact-interface dofs it is tied to): the engine asks it for its condensation
``Z = C^T K^-1 C`` once per factorisation, for its part of the surface right-hand side in
every solve, and for its displacement given the surface solution (eq. 17).
:class:`SubdomainSolver` names what the engine asks; :class:`SubdomainCondensation` (a sparse
MUMPS factor made once for the run) is the kind there is today.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockSystem, ContactRegion
from dd_contact.parallel import gathered
from dd_contact.solvers.linalg import (
    PatternedMatrix,
    SparseCholesky,
    SparseStatistics,
    coo_of,
    sparse_statistics,
)
from dd_contact.solvers.mumps_schur import SchurFactorisation, bordered
from dd_contact.solvers.schedule import (
    CONDENSATIONS,
    condensation_chunks,
)
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "SubdomainCondensation",
    "SubdomainSolver",
    "coupling_layout",
    "owned_subdomains",
    "subdomain_statistics",
]


def coupling_layout(block: Block, system: BlockSystem) -> tuple[list, sp.csr_array]:
    """The couplings of a subdomain: ``(surface block, tied dofs)`` each, and their columns.

    Returns the layout and ``C``, the subdomain's non-zero coupling columns side by side.
    """
    layout, columns = [], []
    for surface, A in system.coupled(block):
        A = sp.csr_array(A)
        A.eliminate_zeros()
        J = np.unique(A.indices)
        layout.append((surface, J))
        columns.append(A[:, J])
    n = system.sizes[block]
    return layout, (sp.csr_array(sp.hstack(columns)) if columns else sp.csr_array((n, 0)))


class SubdomainSolver(Protocol):
    """What the engine asks of a subdomain: the seam of reduced subdomains.

    :class:`SubdomainCondensation` (a sparse factor, one substitution per step) is the one
    kind today; a reduced model (constraint and normal modes, a small dense matrix) will be
    another, built by :func:`owned_subdomains`, with the same surface-facing operations.
    """

    block: Block
    layout: list
    Z: np.ndarray | None
    matrix: PatternedMatrix  # where the engine sets its contact matrices

    @property
    def changing(self) -> bool:
        """Whether it must be factorised (again) before the next solve."""
        ...

    def analyse(self) -> SparseStatistics:
        """What its factorisation will cost (for the timing model)."""
        ...

    def factorise(self) -> None:
        """(Re-)factorise and condense: Z = C^T K^-1 C."""
        ...

    def surface_rhs(self, b: np.ndarray) -> np.ndarray:
        """Its part of the surface right-hand side, -C^T K^-1 b."""
        ...

    def back_substitute(self, surface: dict[str, np.ndarray]) -> np.ndarray:
        """Its displacement given the surface solution (eq. 17)."""
        ...

    def destroy(self) -> None:
        """Free what it holds."""
        ...


class SubdomainCondensation:
    """One owned subdomain: its factorisation, condensation, u_hat and back-substitution.

    Args:
        block: The subdomain's block.
        system: The block system (this rank holds every piece of the block).
        contacts: The contact regions on the subdomain's own boundary (no contact interface).
        log: Where the work is recorded.
        condensation: ``"schur"`` or ``"multi-rhs"``.
        compact: Compact MUMPS's workspace after the first factorisation (``"schur"`` only; it
            copies the factors: :data:`~dd_contact.solvers.mumps_schur.ICNTL_COMPACT`).

    Attributes:
        layout: ``(surface block, columns)`` of each coupling: the surface dofs tied here.
        Z: ``C^T K^-1 C`` over the concatenated coupling columns (dense).
    """

    def __init__(
        self,
        block: Block,
        system: BlockSystem,
        contacts: Sequence[ContactRegion],
        log: WorkLog,
        condensation: str,
        compact: bool = False,
    ):
        if condensation not in CONDENSATIONS:
            raise ValueError(
                f"unknown condensation {condensation!r}; valid: {', '.join(CONDENSATIONS)}"
            )
        self.block, self.log = block, log
        n = system.sizes[block]
        self.layout, self.C = coupling_layout(block, system)
        m = self.C.shape[1]
        # MUMPS's Schur complement: factorise [[K, C], [C^T, 0]] with the last m as Schur
        # block; it gives -Z directly, and its reduction and expansion phases give the
        # surface right-hand side and u with one forward and one backward sweep.
        self.schur = m if condensation == "schur" else 0
        rows, cols, values = coo_of(system.block(block, block))
        if self.schur:
            rows, cols, values = bordered((rows, cols, values), self.C, mirrored=True)
        size = n + self.schur
        base = (rows, cols, values)
        # Driven through MUMPS's C interface (reduction and expansion apart), the Schur
        # factorisation needs no PETSc matrix: the upper triangle's COO only.
        self.matrix = PatternedMatrix(MPI.COMM_SELF, size, size, base, contacts, bool(self.schur))
        self.factor: SparseCholesky | SchurFactorisation | None = None
        if self.schur:
            rows, cols = self.matrix.take_indices()
            self.factor = SchurFactorisation(rows, cols, size, m, log, block, compact)
        self.Z: np.ndarray | None = None
        self.u_hat: np.ndarray | None = None
        self._b: np.ndarray | None = None
        self._g: np.ndarray | None = None
        self.u: np.ndarray | None = None
        self._factorised = False

    @property
    def changing(self) -> bool:
        """Whether the matrix must be re-factorised (new contact values, or never done)."""
        return not self._factorised or self.matrix.dirty

    def analyse(self) -> SparseStatistics:
        """MUMPS's symbolic analysis of the matrix :meth:`factorise` factorises.

        With ``"schur"`` the analysis is the factorisation's own (not repeated by it).
        """
        if self.schur:
            assert isinstance(self.factor, SchurFactorisation)
            return self.factor.analyse(self.matrix.values)
        self.matrix.push()
        assert self.matrix.A is not None  # a PETSc matrix without a Schur block
        return sparse_statistics(self.matrix.A)

    def factorise(self) -> None:
        """(Re-)factorise K_hat and condense the coupling columns: Z = C^T K^-1 C."""
        self.matrix.push()
        if self.schur:
            assert isinstance(self.factor, SchurFactorisation)
            self.Z = self.factor.factorise(self.matrix.values)  # S = -Z, exactly symmetric
            np.negative(self.Z, out=self.Z)
        else:
            assert not isinstance(self.factor, SchurFactorisation)
            if self.factor is None:
                assert self.matrix.A is not None  # a PETSc matrix without a Schur block
                self.factor = SparseCholesky(self.matrix.A, self.log, self.block)
            else:
                self.factor.refactorise()
            m = self.C.shape[1]
            self.Z = np.zeros((m, m))
            Csc = self.C.tocsc()
            for j0, j1 in condensation_chunks(m):
                X = self.factor.solve_many(Csc[:, j0:j1].toarray(), "condense")
                self.Z[:, j0:j1] = self.C.T @ X
            self.Z = 0.5 * (self.Z + self.Z.T)  # symmetric up to round-off; make it exact
        self._b, self._factorised = None, True

    def surface_rhs(self, b: np.ndarray) -> np.ndarray:
        """-C^T K^-1 b, computed only when b or K changed.

        With ``"schur"``: MUMPS's reduction, one forward sweep whose result MUMPS keeps for
        :meth:`back_substitute`. With ``"multi-rhs"``: a full substitution u_hat = K^-1 b.
        """
        if self._b is None or not np.array_equal(b, self._b):
            self._b = b.copy()
            if self.schur:
                assert isinstance(self.factor, SchurFactorisation)
                self._g = self.factor.reduce(b, "u_hat")
            else:
                assert isinstance(self.factor, SparseCholesky)
                self.u_hat = self.factor.solve_array(b, "u_hat")
                self._g = -(self.C.T @ self.u_hat)
        self.u = None
        assert self._g is not None  # computed with _b
        return self._g

    def back_substitute(self, surface: dict[str, np.ndarray]) -> np.ndarray:
        """U = K^-1 (b - C x_surface) (eq. 17), once per new surface solution.

        With ``"schur"``: MUMPS's expansion, one backward sweep from the forward sweep of
        :meth:`surface_rhs` (a second expansion for the same b sweeps forward again).
        """
        if self.u is None:
            assert self._b is not None  # surface_rhs came first
            xs = np.concatenate([surface[s][J] for s, J in self.layout] or [np.zeros(0)])
            if not self.schur:
                assert isinstance(self.factor, SparseCholesky)
                self.u = self.factor.solve_array(self._b - self.C @ xs, "u")
                return self.u
            assert isinstance(self.factor, SchurFactorisation)
            if not self.factor.reduced:  # MUMPS released the forward sweep
                self.factor.reduce(self._b, "u")
            self.u = self.factor.expand(xs, "u")
        return self.u

    def destroy(self) -> None:
        """Free the PETSc objects."""
        if self.factor is not None:
            self.factor.destroy()
        self.matrix.destroy()


def owned_subdomains(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    log: WorkLog,
    condensation: str,
) -> dict[Block, SubdomainCondensation]:
    """The subdomains this rank owns, each ready to factorise (nothing factorised yet).

    They are factorised in this order: first those without contact on their own boundary,
    then those with (re-factorised on each contact change). Each but the last compacts
    MUMPS's workspace after its first factorisation: what the earlier ones keep adds to
    the later ones' peak. The compaction copies the factors, so the last one does not, nor
    does a re-factorisation: their copy would set the peak (the peaks with and without this
    rule: docs/benchmarks.md, "Which factorisations compact").
    """
    owned = [
        b
        for b, owner in system.owners.items()
        if b.kind == "u" and owner == comm.rank and b not in system.reduced
    ]
    own_contacts = {b: [r for r in contacts if r.block == b] for b in owned}
    owned.sort(key=lambda b: bool(own_contacts[b]))  # stable: the owners' order otherwise
    return {
        block: SubdomainCondensation(
            block, system, own_contacts[block], log, condensation, compact=block != owned[-1]
        )
        for block in owned
    }


def subdomain_statistics(
    comm: MPI.Comm,
    system: BlockSystem,
    contacts: Sequence[ContactRegion],
    condensation: str = "schur",
    subdomains: dict[Block, SubdomainCondensation] | None = None,
) -> dict[Block, tuple[SparseStatistics, list]]:
    """Collective: each subdomain's analysed matrix and coupling layout.

    The matrix is the one the engine factorises: with its Schur block if
    ``condensation="schur"``. Returns ``block -> (statistics, layout)`` on every rank.
    ``subdomains``: this rank's, built already (:func:`owned_subdomains`, analysed here and
    kept for a solver); by default built and freed here.
    """
    owned = subdomains
    if owned is None:
        owned = owned_subdomains(comm, system, contacts, WorkLog(), condensation)
    mine = {block: (sub.analyse(), sub.layout) for block, sub in owned.items()}
    if subdomains is None:
        for sub in owned.values():
            sub.destroy()
    return gathered(comm, mine)
