"""Ties stiffer than the factorisations can hold: an augmented-Lagrangian iteration.

A penalty tie adds ``(1/eps) R`` to the matrix (R: the tie operators P1, P2, P4 of (9)-(11)).
In float64 the elements' stiffness behind a tie loses digits like kappa = h / (E eps): at
kappa 1e14 the answer is gone (method.md, section 8). So the 1/eps of a tie stiffer than
``KAPPA_SPLIT`` (1e6) is split as ``rho + sigma``: the matrices hold ``rho`` (kappa =
``KAPPA_ASSEMBLED``, 1e3, for ties to matching facets; ``KAPPA_ASSEMBLED_PROJECTED``, 1e5,
for projected ones; see :mod:`dd_contact.scene`), and the remainder enters as a
force ``y`` on the right-hand side, found by the iteration

    solve  A_rho x = f - y,    y <- (1 - w / sigma) y + w R x,    w = rho sigma / (rho + sigma)

whose fixed point is ``y = sigma R x``, i.e. ``(A_rho + sigma R) x = f``: the stiff tie,
exactly. The update is the augmented-Lagrangian (Uzawa) step for the multiplier ``y``; the
step ``w`` cancels the tie's own stiffness ``rho + sigma`` on the modes it holds, so there
the error contracts by about ``1 / KAPPA_ASSEMBLED`` per solve: a few solves settle it
(fewer when ``y`` starts from the previous solve's). Its round-off is that of a kappa =
KAPPA_ASSEMBLED system, whatever the tie's kappa: the tie force is never formed as ``sigma``
times the tiny jump. The matrices, their factorisations and the schedule are those of kappa =
KAPPA_ASSEMBLED; only substitutions are added, one per extra solve.

It stops when the solution has settled (moved by less than ``SOLUTION_TOLERANCE`` of its
largest value in the last solve), or the tie forces have (``TIE_TOLERANCE`` of the load):
the solution is what is asked for, and a change of the tie forces measured against the
load says little about it (on the decomposed bar of docs/decompose.md the displacement had
settled to 1e-10 of itself while that change sat at its round-off floor for 3-4 more solves).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import StiffTie
from dd_contact.errors import InaccurateSolutionError
from dd_contact.parallel import elementwise_max, sum_over_ranks

__all__ = [
    "ANDERSON_DEPTH",
    "MAX_TIE_ITERATIONS",
    "SOLUTION_TOLERANCE",
    "TIE_TOLERANCE",
    "AugmentedTies",
]

#: Settled when the change of the tie forces is below this, relative to the load.
TIE_TOLERANCE = 1e-11

#: Settled when a solve moved the solution by less than this, relative to its largest value:
#: above the solution's round-off (1e-10 to 3e-10 of it on the decomposed bar) and the
#: contraction (1e-2 or less per solve by then) leaves it well below 1e-8.
SOLUTION_TOLERANCE = 1e-9

#: Also settled when the change has stopped shrinking for two solves below this: the
#: round-off floor of the update, about 1e-16 x KAPPA_ASSEMBLED x the condition of the
#: elements, which the assembled part of the tie absorbs.
TIE_FLOOR = 1e-5

#: Solves allowed for one right-hand side.
MAX_TIE_ITERATIONS = 30

#: Earlier steps the Anderson mixing combines.
ANDERSON_DEPTH = 5


class AugmentedTies:
    """A block solver with the stiff part of some ties carried by iteration.

    Follows the :class:`dd_contact.iteration.ContactSolver` protocol: each :meth:`solve`
    returns every block of a solution of the system with the full tie penalties. The
    fixed-point update is accelerated by Anderson mixing (depth :data:`ANDERSON_DEPTH`):
    two stiff ties that share a surface (the interface between two subdomains) hold each
    other's modes, which the plain update settles only by halves.

    Args:
        comm: Communicator of the solver.
        inner: The solver of the assembled system (the stiff ties at KAPPA_ASSEMBLED).
        ties: This rank's stiff ties.
        free: Block -> 1.0 on its free dofs, 0.0 on prescribed ones (this rank's subdomain
            blocks; a tie force on a prescribed dof is dropped, as in the assembled system).
    """

    def __init__(
        self,
        comm: MPI.Comm,
        inner,
        ties: Sequence[StiffTie],
        free: Mapping[str, np.ndarray],
    ):
        self.comm, self.inner, self.ties = comm, inner, list(ties)
        self.system = inner.system
        sizes = self.system.sizes
        # The tie forces y of every tie, side by side: (tie, block, slice, free mask).
        self._layout, start = [], 0
        for k, tie in enumerate(self.ties):
            for block in (tie.u, tie.s):
                n = sizes[block]
                mask = free.get(block, np.ones(n))
                self._layout.append((k, block, slice(start, start + n), mask))
                start += n
        #: The tie forces (warm start of the next solve).
        self.forces = np.zeros(start)
        #: This rank's vector subtracted from the right-hand side of the last solve.
        self.rhs_offset: dict[str, np.ndarray] = {}
        #: Solves of the last right-hand side, and in all.
        self.iterations, self.solves = 0, 0
        self._x: dict[str, np.ndarray] = {}

    def set_contact(self, key: str, matrix: sp.csr_array, active: np.ndarray | None = None) -> None:
        """Replace the contact matrix of contact region ``key`` (and its points' flags)."""
        self.inner.set_contact(key, matrix, active=active)

    def _offset(self, y: np.ndarray) -> dict[str, np.ndarray]:
        offset: dict[str, np.ndarray] = {}
        for _, block, where, _ in self._layout:
            offset[block] = offset[block] + y[where] if block in offset else y[where].copy()
        return offset

    def _update(self, x: dict[str, np.ndarray], y: np.ndarray) -> np.ndarray:
        """The plain augmented-Lagrangian update of the tie forces ``y`` after solving ``x``."""
        new = np.empty_like(y)
        jumps = [tie.jump(x) for tie in self.ties]
        for k, block, where, mask in self._layout:
            tie = self.ties[k]
            step = tie.rho * tie.sigma / (tie.rho + tie.sigma)
            new[where] = ((1.0 - step / tie.sigma) * y[where] + step * jumps[k][block]) * mask
        return new

    def _dot(self, a: np.ndarray, b: np.ndarray):
        """Collective: the dot product(s) over all ranks' tie forces."""
        return np.asarray(sum_over_ranks(self.comm, a.T @ b))

    def _settled(self, x: dict[str, np.ndarray], last: dict[str, np.ndarray]) -> bool:
        """Collective: whether ``x`` is within SOLUTION_TOLERANCE of the last solve's."""
        moved = max(
            (float(np.abs(v - last[b]).max(initial=0.0)) for b, v in x.items()), default=0.0
        )
        size = max((float(np.abs(v).max(initial=0.0)) for v in x.values()), default=0.0)
        moved, size = elementwise_max(self.comm, np.array([moved, size]))
        return bool(moved <= SOLUTION_TOLERANCE * size)

    def solve(self, rhs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Collective: every block of the solution with the full tie penalties."""
        scale = max(sum_over_ranks(self.comm, sum(float(v @ v) for v in rhs.values())), 1e-300)
        y, best, stalled = self.forces, np.inf, 0
        steps_y: list[np.ndarray] = []
        steps_f: list[np.ndarray] = []
        last: tuple[np.ndarray, np.ndarray] | None = None
        previous: dict[str, np.ndarray] | None = None
        for iteration in range(1, MAX_TIE_ITERATIONS + 1):
            offset = self._offset(y)
            shifted = {b: v - offset[b] if b in offset else v for b, v in rhs.items()}
            shifted.update({b: -v for b, v in offset.items() if b not in rhs})
            self.inner.solve(shifted)
            x = self.inner.finish()
            self.rhs_offset, self.solves = offset, self.solves + 1
            f = self._update(x, y) - y  # the fixed-point residual
            change = float(np.sqrt(self._dot(f, f) / scale))
            stalled = stalled + 1 if change > 0.5 * best else 0
            best = min(best, change)
            settled = previous is not None and self._settled(x, previous)
            previous = {b: v.copy() for b, v in x.items()}
            if settled or change <= TIE_TOLERANCE or (change <= TIE_FLOOR and stalled >= 2):
                self.forces, self.iterations, self._x = y + f, iteration, x
                return x
            if last is not None:  # Anderson mixing over the last few steps
                steps_y = [*steps_y, y - last[0]][-ANDERSON_DEPTH:]
                steps_f = [*steps_f, f - last[1]][-ANDERSON_DEPTH:]
            last = (y, f)
            if steps_f:
                dF, dY = np.column_stack(steps_f), np.column_stack(steps_y)
                gamma = np.linalg.lstsq(self._dot(dF, dF), self._dot(dF, f), rcond=1e-14)[0]
                y = y + f - (dY + dF) @ gamma
            else:
                y = y + f
        raise InaccurateSolutionError(
            f"the stiff ties ({', '.join(t.name for t in self.ties)}) did not settle in "
            f"{MAX_TIE_ITERATIONS} solves (last change {change:.1e} of the load); lower "
            "their kappa"
        )

    def finish(self) -> dict[str, np.ndarray]:
        """Every block of the last solution."""
        return self._x

    def destroy(self) -> None:
        """Free the inner solver's PETSc objects."""
        self.inner.destroy()
