"""Every solve checks what it returned: the residual of the whole system (14).

A solver can return a wrong answer without failing. MUMPS's Cholesky does not flag a
singular symmetric positive definite matrix (a body held only by contact, with a
clearance), and a penalty far above the elements' stiffness loses digits to round-off. The
residual ``r = b - A x`` of the whole system, contact terms included, shows both, measured
two ways:

* on the *free rows*: the subdomain dofs no tie or contact term acts on. There the matrix
  holds the elements' stiffness only, so a sound solve leaves a residual near round-off
  (1e-11 of the load) at every penalty, while a body that can move freely leaves one of
  order the load it cannot carry (1e-4 to 1 of it). Checked against
  :data:`FREE_ROW_TOLERANCE`.
* on every row, relative to ``|b|``: penalty rows carry round-off that grows like kappa
  (1e-11 at kappa 1e2, 1e-6 at 1e6, 1e-2 at 1e10 in a tied bar), so this one shows when the
  penalties cost the answer its accuracy. Checked against the user's
  ``ContactSettings.residual_tolerance``.

An exact residual costs a sparse matrix-vector product per block, a good part of a step
of the orders (benchmarks/residual_check.py measures it). Both are estimated instead from a few
fixed Gaussian probe vectors ``z``: ``E[(z . r)^2] = |r|^2``, and
``z . r = z . b - (A z) . x``, where ``A z`` of the constant part of ``A`` is formed once.
Per solve that is a few dot products; each estimate is within a factor of a few of the
exact value, all a threshold needs.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block, BlockSystem
from dd_contact.parallel import sum_over_ranks

__all__ = [
    "DEFAULT_RESIDUAL_TOLERANCE",
    "FREE_ROW_TOLERANCE",
    "PROBES",
    "Residual",
    "ResidualCheck",
    "exact_residual",
    "free_rows",
]

#: Largest accepted estimate of ``|b - A x| / |b|`` over all rows (the user's setting).
DEFAULT_RESIDUAL_TOLERANCE = 1e-3

#: Largest accepted estimate of the free rows' residual relative to ``|b|``.
FREE_ROW_TOLERANCE = 1e-8

#: Gaussian probe vectors of the estimates.
PROBES = 3

_SEED = 20261122


@dataclass(frozen=True)
class Residual:
    """Estimated residuals of one solve, relative to ``|b|`` (``inf``: not finite).

    Attributes:
        whole: Over every row of system (14).
        free: Over the free rows (no tie or contact term); ``None`` if there are none.
    """

    whole: float
    free: float | None


def free_rows(
    system: BlockSystem, contact_dofs: Mapping[Block, np.ndarray] | None = None
) -> dict[str, np.ndarray]:
    """The free rows of this rank's subdomain blocks: no tie or contact term acts on them."""
    tied = {b: np.zeros(n, bool) for b, n in system.sizes.items() if b.kind == "u"}
    for block, rows in tied.items():
        for _, A in system.coupled(block):
            rows[sp.coo_array(A).row] = True
    for block, dofs in (contact_dofs or {}).items():
        if block in tied:
            tied[block][dofs] = True
    owned = {b for (r, c) in system.matrices for b in (r, c) if b in tied}
    return {b: ~tied[b] for b in owned}


def exact_residual(
    system: BlockSystem,
    rhs: Mapping[str, np.ndarray],
    x: Mapping[str, np.ndarray],
    contact: Sequence[tuple[Sequence[tuple[Block, np.ndarray]], sp.sparray]] = (),
) -> Residual:
    """The residuals :class:`ResidualCheck` estimates, exactly (one rank; for verification).

    One matrix-vector product per block: what the estimate saves.
    """
    r: dict[str, np.ndarray] = {b: np.zeros(n) for b, n in system.sizes.items()}
    for block, vector in rhs.items():
        r[block] += vector
    for row, col, A in system.all_blocks():
        r[row] -= A @ x[col]
    for parts, matrix in contact:
        y = matrix @ np.concatenate([x[block][dofs] for block, dofs in parts])
        for block, dofs in parts:
            r[block][dofs] -= y[: len(dofs)]
            y = y[len(dofs) :]
    b = np.linalg.norm(np.concatenate([rhs.get(k, np.zeros(n)) for k, n in system.sizes.items()]))
    free = free_rows(system, {block: dofs for parts, _ in contact for block, dofs in parts})
    on_free = np.concatenate([r[k][f] for k, f in free.items()] or [np.zeros(0)])
    whole = float(np.linalg.norm(np.concatenate(list(r.values()))) / b)
    return Residual(whole, float(np.linalg.norm(on_free) / b) if on_free.size else None)


class ResidualCheck:
    """The residual of system (14) after a solve, estimated with probe vectors.

    Args:
        comm: Communicator; each rank holds its pieces of the system and of the right-hand
            side, and of the solution (every surface block and its own subdomains).
        system: This rank's pieces of the constant (constrained) block system ``A``; the
            contact terms come with each solve.
        contact_dofs: Block -> dofs any contact term may act on (this rank's regions).
        probes: Number of probe vectors.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        system: BlockSystem,
        contact_dofs: Mapping[Block, np.ndarray] | None = None,
        probes: int = PROBES,
    ):
        self.comm, self.probes = comm, probes
        self.sizes: dict[str, int] = {b: n for b, n in system.sizes.items()}
        self._z: dict[str, np.ndarray] = {}
        self._zf: dict[str, np.ndarray] = {}  # probes on the free rows
        self._zc: dict[tuple, tuple[list, np.ndarray]] = {}  # probes on contact dofs
        # Free rows: subdomain dofs without a tie or contact term (known on their owner).
        self._free = {
            b: f.astype(float)[:, None] for b, f in free_rows(system, contact_dofs).items()
        }
        count = sum(int(f.sum()) for f in self._free.values())
        self.has_free_rows = sum_over_ranks(comm, count) > 0
        #: ``A z`` and ``A z_free`` restricted to each block, from this rank's pieces.
        self._az: dict[str, np.ndarray] = {}
        self._az_free: dict[str, np.ndarray] = {}
        # (A^T z)_col = sum over the rows of A[row, col]^T z_row
        for row, col, A in system.all_blocks():
            z = self.probe(row)
            self._add(self._az, col, A.T @ z)
            if row in self._free:
                self._add(self._az_free, col, A.T @ (z * self._free[row]))

    @staticmethod
    def _add(store: dict, block: str, value: np.ndarray) -> None:
        store[block] = store[block] + value if block in store else value

    def probe(self, block: str) -> np.ndarray:
        """The probe vectors on ``block`` (``size x probes``), the same on every rank."""
        if block not in self._z:
            rng = np.random.default_rng([_SEED, zlib.crc32(str(block).encode())])
            self._z[block] = rng.standard_normal((self.sizes[block], self.probes))
        return self._z[block]

    def _free_probe(self, block: str) -> np.ndarray:
        """The probes on ``block`` zero off its free rows (made once: not a copy per solve)."""
        if block not in self._zf:
            self._zf[block] = self.probe(block) * self._free[block]
        return self._zf[block]

    def _contact_probe(self, parts: Sequence[tuple[str, np.ndarray]]) -> np.ndarray:
        """The probes on a contact matrix's dofs, in its numbering (kept for its dofs)."""
        key = tuple((block, id(dofs)) for block, dofs in parts)
        kept = self._zc.get(key)
        if kept is None or any(a is not b for a, (_, b) in zip(kept[0], parts, strict=True)):
            stacked = np.vstack([self.probe(block)[dofs] for block, dofs in parts])
            kept = self._zc[key] = ([dofs for _, dofs in parts], stacked)
        return kept[1]

    def estimate(
        self,
        rhs: Mapping[str, np.ndarray],
        x: Mapping[str, np.ndarray],
        contact: Sequence[tuple[Sequence[tuple[str, np.ndarray]], sp.sparray]] = (),
    ) -> Residual:
        """Collective: the estimated residuals of ``x``.

        Args:
            rhs: This rank's right-hand-side contributions, contact terms included.
            x: The solution: every surface block and this rank's subdomains (at least).
            contact: This rank's contact matrices ``(parts, matrix)`` (``parts``: the
                ``(block, dofs)`` of the matrix's surface numbering) added to ``A`` for this
                solve.
        """
        k = self.probes
        finite = all(np.all(np.isfinite(v)) for v in x.values())
        zb, zr, zr_free = np.zeros(k), np.zeros(k), np.zeros(k)
        if finite:
            for block, vector in rhs.items():
                zb += self.probe(block).T @ vector
                if block in self._free:
                    zr_free += self._free_probe(block).T @ vector
            zr += zb
            for block, az in self._az.items():
                zr -= az.T @ x[block]
            for block, az in self._az_free.items():
                zr_free -= az.T @ x[block]
            for parts, matrix in contact:  # free rows have no contact term
                y = matrix @ np.concatenate([x[block][dofs] for block, dofs in parts])
                zr -= self._contact_probe(parts).T @ y
        local = np.concatenate([zb, zr, zr_free, [0.0 if finite else 1.0]])
        sums = np.array(sum_over_ranks(self.comm, local))
        if sums[-1] > 0:
            return Residual(np.inf, np.inf)
        b2 = float(np.sum(sums[:k] ** 2))
        whole, free = (float(np.sum(sums[i * k : (i + 1) * k] ** 2)) for i in (1, 2))
        if b2 == 0.0:
            return Residual(0.0 if whole == 0.0 else np.inf, 0.0 if free == 0.0 else np.inf)
        ratio = lambda r2: float(np.sqrt(r2 / b2))  # noqa: E731
        return Residual(ratio(whole), ratio(free) if self.has_free_rows else None)
