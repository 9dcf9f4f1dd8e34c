"""The subdomains' velocity and acceleration, stepped alike on every rank.

A time scheme's update (:mod:`dd_contact.timestepping`) is the rate of a dof with mass. A
massless dof (a contact wall under energy-safe contact, :func:`dd_contact.impact.massless_walls`)
has no dynamics of its own: its displacement is in equilibrium with its neighbours' at every
step, and the trapezoidal rule's ``u'_{n+1} = 2 (u_{n+1} - u_n) / dt - u'_n`` would only
carry, undamped, the error of its last jump (a bar's end face read 28x the bar's speed after
it left a wall). Its velocity is therefore the step's mean, ``(u_{n+1} - u_n) / dt``: at rest
while it is pressed on a still obstacle, the body's velocity once it moves with the body; its
acceleration the change of that over the step. No force reads them (the mass matrices have
no row or column there), so the solution is unchanged; docs/contact.md says why this is the
definition.

The ranks that do not own a subdomain keep its velocity and acceleration too, by the owner's
update repeated on the same published displacement: bit for bit the owner's values, with no
message per step.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mpi4py import MPI

import numpy as np
import scipy.sparse as sp

from dd_contact.blocks import Block
from dd_contact.parallel import allgather_blocks
from dd_contact.timestepping import GeneralizedAlpha, Newmark

__all__ = ["Kinematics"]


class Kinematics:
    """Velocity and acceleration of every subdomain of a scene, on every rank.

    Args:
        comm: The scene's communicator.
        subdomains: Every subdomain of the scene (owned here or not).
        owners: Block -> the rank that owns it.
        mass: The owned subdomains' mass matrices as the scheme uses them (none: no
            inertia, nothing is massless).
        scheme: The time scheme.
        reduced: The reduced subdomains' ``(q, q', q'')`` (reduced coordinates), by block:
            their rates are stepped there (Newmark's on every coordinate: each carries the
            mass of its mode).
        walls: The reduced subdomains' massless coordinates (walls), by block: their
            reported rates are the step's mean, kept apart in :attr:`walls`.
    """

    def __init__(
        self,
        comm: MPI.Comm,
        subdomains: Sequence,
        owners: Mapping[Block, int],
        mass: Mapping[Block, sp.sparray],
        scheme: Newmark | GeneralizedAlpha,
        reduced: Mapping[Block, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
        walls: Mapping[Block, np.ndarray] | None = None,
    ):
        self.comm, self.scheme, self.owners = comm, scheme, dict(owners)
        self.reduced = dict(reduced or {})
        #: Block -> (massless coordinates, (their velocity, acceleration)) of a reduced one.
        self.walls = {
            b: (at, (self.reduced[b][1][at].copy(), np.zeros(len(at))))
            for b, at in (walls or {}).items()
        }
        self.owned = [s for s in subdomains if self.owners[s.block] == comm.rank]
        #: Block -> the scheme's end acceleration of an owned reduced one's coordinates
        #: (``scheme.end_acceleration``): the inertia a release's settle of its walls balances.
        self.ends = {
            s.block: np.zeros(len(self.reduced[s.block][2]))
            for s in self.owned
            if s.block in self.reduced
        }
        #: The subdomains other ranks own, updated here from their published displacement.
        self.others = [s for s in subdomains if self.owners[s.block] != comm.rank]
        #: Block -> its massless dofs (zero mass: the rate is the step's mean), every rank.
        self.massless: dict[Block, np.ndarray] = {
            s.block: (
                np.asarray(mass[s.block].diagonal() == 0)
                if s.block in mass
                else np.zeros(len(self.now(s)[0]), bool)
            )
            for s in self.owned
        }
        self._u_before: dict[Block, np.ndarray] = {}
        self._masks_shared = False

    def now(self, sub) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The owned displacement, velocity and acceleration of a subdomain (views).

        A reduced subdomain's are its reduced coordinates (no full field is read).
        """
        if sub.block in self.reduced:
            return self.reduced[sub.block]
        n = sub.num_dofs
        return sub.u.x.array[:n], sub.velocity.x.array[:n], sub.acceleration.x.array[:n]

    def _update(self, sub, u_new: np.ndarray, u: np.ndarray) -> None:
        _, velocity, acceleration = self.now(sub)
        v, a = self.scheme.update(u_new, u, velocity, acceleration)
        if sub.block in self.ends:  # before velocity is overwritten: it reads u'_n
            end = self.ends[sub.block]
            end[:] = self.scheme.end_acceleration(u_new, u, velocity, end)
        massless = self.massless.get(sub.block)
        if massless is not None and massless.any():
            dt = self.scheme.dt
            v[massless] = (u_new[massless] - u[massless]) / dt
            a[massless] = (v[massless] - velocity[massless]) / dt
        velocity[:] = v
        acceleration[:] = a
        if sub.block in self.walls:
            at, (wv, wa) = self.walls[sub.block]
            mean = (u_new[at] - u[at]) / self.scheme.dt
            wa[:] = (mean - wv) / self.scheme.dt
            wv[:] = mean

    def start_walls(self) -> None:
        """The reduced subdomains' walls start at their coordinates' velocity, at rest.

        Their end accelerations start at the initial acceleration (equilibrium at t0).
        """
        for block, end in self.ends.items():
            end[:] = self.reduced[block][2]
        for block, (at, (wv, wa)) in self.walls.items():
            wv[:] = self.reduced[block][1][at]
            wa[:] = 0.0

    def step(self, x: Mapping[Block, np.ndarray]) -> None:
        """The owned subdomains' rates at the end of a step whose solution is ``x``.

        Call before ``x`` is published (the subdomains still hold ``u_n``); then
        :meth:`follow` after it.
        """
        for sub in self.owned:
            self._update(sub, x[sub.block], self.now(sub)[0])
        self._u_before = {s.block: self.now(s)[0].copy() for s in self.others}

    def follow(self) -> None:
        """The other ranks' subdomains' rates, from the displacement just published."""
        for sub in self.others:
            self._update(sub, self.now(sub)[0], self._u_before.pop(sub.block))

    def share(self, with_displacement: bool = False) -> None:
        """Collective: the owners' rates (and u, and massless dofs) of every subdomain here.

        Once, where every rank's copies must start equal (the initial state, a restored
        checkpoint); each step then updates them alike on every rank.
        """
        if self.comm.size == 1:
            return
        sizes = {s.block: len(self.now(s)[0]) for s in self.owned + self.others}
        if not self._masks_shared:  # every rank takes part, owner of all or of none
            self._masks_shared = True
            shared = allgather_blocks(
                self.comm,
                {b: m.astype(float) for b, m in self.massless.items()},
                self.owners,
                sizes,
            )
            for sub in self.others:
                self.massless[sub.block] = shared[sub.block] != 0
        for k in (0, 1, 2) if with_displacement else (1, 2):
            local = {s.block: self.now(s)[k] for s in self.owned}
            shared = allgather_blocks(self.comm, local, self.owners, sizes)
            for sub in self.others:
                self.now(sub)[k][:] = shared[sub.block]
