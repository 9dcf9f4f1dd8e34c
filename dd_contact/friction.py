"""Regularised Coulomb friction at the contact points of a rigid obstacle.

A tangential penalty eps_T and a return mapping per contact point (Wriggers,
*Computational Contact Mechanics*, ch. 5; docs/contact.md, "Friction"). With p_N the
point's normal pressure, t_n its tangential traction at the start of the step and du_T the
tangential part of its displacement increment over the step relative to the obstacle's
(the obstacle's prescribed motion counts)::

    trial:  t* = t_n - du_T / eps_T
    stick   if |t*| <= mu p_N:  t = t*
    slip    otherwise:          t = mu p_N s,   s = t* / |t*|

Each point is open, sticking or slipping; the state is a fixed point like the active set
(:mod:`dd_contact.iteration`): a slipping point keeps its direction s for a solve, and the
slip law is linearised about it (the return mapping's tangent), so it is linear in w:
``t = mu p_N s + c Q t*`` with ``Q = I - s s^T`` and ``c = mu p_N / |t*|`` when s was
taken; the second term vanishes once s settles (t* along s) and holds the point across s
meanwhile (without it the direction of a point that just began to slip, its slip ~0, is
ill-posed: the iteration diverged). Stick adds ``(a / eps_T) P`` per point (P = I - n n^T,
symmetric), slip ``-(a mu / eps_C) s n^T + (a c / eps_T) Q P`` (unsymmetric: the orders
factorise :meth:`Friction.stuck` instead and correct for it, :mod:`dd_contact.solvers.stuck`).
Geometry of the undeformed configuration, as the normal contact.
"""

from __future__ import annotations

import hashlib
import itertools
from typing import Any

import numpy as np
import scipy.sparse as sp

__all__ = ["OPEN", "SLIP", "STICK", "TANGENTIAL_PENALTY", "Friction"]

OPEN, STICK, SLIP = 0, 1, 2

#: The tangential penalty eps_T over the contact's normal one eps_C: a point sticks with
#: the stiffness it is pressed with (docs/contact.md, "Friction").
TANGENTIAL_PENALTY = 1.0

#: A slip direction that moved by less than this (unit vectors) is the same state: the
#: fixed point on the direction stops there.
DIRECTION_TOLERANCE = 1e-5

#: A trial traction within this fraction of the Coulomb limit is no evidence: the point
#: keeps its state (round-off at the limit would flip it back and forth).
LIMIT_BAND = 1e-12

_ARRAYS = ("state", "direction", "scale", "traction", "start", "slip")


class Friction:
    """The friction history and law of one contact region against a rigid obstacle.

    Args:
        operator: The region's :class:`~dd_contact.contact.ContactOperator` (points,
            normals, gap, normal penalty).
        mu: The Coulomb coefficient (> 0).
        epsilon: The tangential penalty eps_T (traction = tangential jump / eps_T).

    Attributes:
        state: OPEN, STICK or SLIP per point, as last decided.
        direction: Unit slip direction s of the slipping points (zero elsewhere).
        scale: ``mu p_N / |t*|`` of the slipping points when their direction was taken: the
            stiffness across s of the return mapping's tangent (below the stick's).
        traction: Tangential traction per point at the start of the step (on the body).
        start: The surface displacement at the start of the step.
        t_start: The time at the start of the step (where the obstacle was).
        slip: Accumulated slip (the irreversible tangential displacement) per point.
        dissipation: The work friction took out of the last step (>= 0): the mean
            traction's work over the slip relative to the obstacle less the change of the
            tangential penalty's energy.
        obstacle_work: The work the obstacle's tangential motion did on the body through
            friction over the last step: the mean traction times the obstacle's
            displacement (zero for an obstacle at rest).
    """

    def __init__(self, operator: Any, mu: float, epsilon: float):
        self.operator, self.mu, self.epsilon = operator, float(mu), float(epsilon)
        p = operator.num_points
        coo = sp.coo_array(operator.points.N)
        rows = (3 * coo.row[:, None] + np.arange(3)).ravel()
        cols = (3 * coo.col[:, None] + np.arange(3)).ravel()
        values = np.repeat(coo.data, 3)
        self._E = sp.csr_array((values, (rows, cols)), shape=(3 * p, operator.num_dofs))
        # nodal contact points: E is the identity, and the terms need no products with it
        N = sp.csr_array(operator.points.N)
        self._nodal = N.shape == (p, p) and N.nnz == p and np.array_equal(N.diagonal(), np.ones(p))
        self._terms: tuple | None = None  # the last terms and what they were made for
        self.state = np.zeros(p, np.int8)
        self.direction = np.zeros((p, 3))
        self.scale = np.zeros(p)
        self.traction = np.zeros((p, 3))
        self.start = np.zeros(operator.num_dofs)
        self.t_start = 0.0
        self.slip = np.zeros((p, 3))
        self.dissipation = 0.0
        self.obstacle_work = 0.0
        self._last_turn = np.zeros((p, 3))  # each point's last turn of its slip direction
        self._tried: list[np.ndarray] = []  # the states decided in this step

    # -- kinematics ------------------------------------------------------------------------
    def _tangential(self, v: np.ndarray) -> np.ndarray:
        n = self.operator.normal
        return v - np.einsum("pd,pd->p", v, n)[:, None] * n

    def _moved(self) -> np.ndarray:
        """The obstacle's translation since the start of the step."""
        motion = self.operator.obstacle.motion
        if motion is None:
            return np.zeros(3)
        now, then = (
            np.asarray(motion(t), float).reshape(3) for t in (self.operator.t, self.t_start)
        )
        return now - then

    def trial(self, w: np.ndarray) -> np.ndarray:
        """The trial tangential traction t* of every point for the surface displacement w."""
        du = (self._E @ (w - self.start)).reshape(-1, 3) - self._moved()
        return self._tangential(self.traction) - self._tangential(du) / self.epsilon

    def _limit(self, w: np.ndarray) -> np.ndarray:
        return self.mu * self.operator.point_pressure(w)

    # -- the law -----------------------------------------------------------------------------
    def _law(self, active: np.ndarray) -> np.ndarray:
        """The state a solve uses: a point newly in contact starts sticking."""
        return np.where(active, np.where(self.state == SLIP, SLIP, STICK), OPEN).astype(np.int8)

    def terms(self, active: np.ndarray) -> tuple[sp.csr_array, np.ndarray]:
        """The friction's matrix and right-hand side (surface numbering) for ``active``.

        Kept for the next call with the same active set, state and time (a solve asks for
        the matrix, then the right-hand side).
        """
        arrays = (active, self.state, self.direction, self.scale, self.traction, self.start)
        key = (self.operator.t, *(a.tobytes() for a in arrays))
        if self._terms is None or self._terms[0] != key:
            self._terms = (key, *self._made(active))
        return self._terms[1], self._terms[2]

    def _made(self, active: np.ndarray) -> tuple[sp.csr_array, np.ndarray]:
        op, state = self.operator, self._law(active)
        a, n = op.points.weight, op.normal
        P = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
        stick, slip = state == STICK, state == SLIP
        D = np.zeros((len(a), 3, 3))
        D[stick] = (a[stick] / self.epsilon)[:, None, None] * P[stick]
        s, c = self.direction[slip], (a * self.scale)[slip]
        Q = np.eye(3)[None] - s[:, :, None] * s[:, None, :]
        D[slip] = (
            -(a[slip] * self.mu / op.epsilon)[:, None, None] * s[:, :, None] * n[slip, None, :]
        )
        D[slip] += (c / self.epsilon)[:, None, None] * (Q @ P[slip])
        held = (
            self._tangential(self.traction)
            + self._tangential((self._E @ self.start).reshape(-1, 3) + self._moved()) / self.epsilon
        )
        f = np.zeros((len(a), 3))
        f[stick] = a[stick, None] * held[stick]
        f[slip] = -(a[slip] * self.mu * op.gap[slip] / op.epsilon)[:, None] * s
        f[slip] += c[:, None] * np.einsum("pij,pj->pi", Q, held[slip])
        if self._nodal:
            return self._assembled(D), f.ravel()
        return self._assembled(D), self._E.T @ f.ravel()

    def _assembled(self, D: np.ndarray) -> sp.csr_array:
        """The matrix of the points' 3 x 3 blocks D (surface numbering)."""
        p = len(D)
        blocks = sp.bsr_array((D, np.arange(p), np.arange(p + 1)), shape=(3 * p,) * 2)
        return sp.csr_array(blocks) if self._nodal else sp.csr_array(self._E.T @ blocks @ self._E)

    def stuck(self, active: np.ndarray) -> sp.csr_array:
        """:meth:`terms`' matrix with every point of ``active`` sticking.

        Symmetric positive semi-definite, and equal to :meth:`terms`' but at the slipping
        points: a solver may factorise it and correct for the slip (its only unsymmetric
        part) with a low-rank term (:mod:`dd_contact.solvers.stuck`).
        """
        a, n = self.operator.points.weight, self.operator.normal
        P = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
        D = np.zeros((len(a), 3, 3))
        D[active] = (a[active] / self.epsilon)[:, None, None] * P[active]  # as terms' stick
        return self._assembled(D)

    def tractions(self, w: np.ndarray) -> np.ndarray:
        """The tangential traction on the body at every point for w, in the decided state."""
        t = np.zeros_like(self.traction)
        stick, slip = self.state == STICK, self.state == SLIP
        trial = self.trial(w)
        t[stick] = trial[stick]
        s = self.direction[slip]
        across = trial[slip] - np.einsum("pd,pd->p", trial[slip], s)[:, None] * s
        t[slip] = self._limit(w)[slip, None] * s + self.scale[slip, None] * across
        return t

    def decide(self, w: np.ndarray, active: np.ndarray) -> bool:
        """Stick or slip of every point of ``active`` for the end state w; whether it changed."""
        trial = self.trial(w)
        size, limit = np.linalg.norm(trial, axis=1), self._limit(w)
        undecided = np.abs(size - limit) <= LIMIT_BAND * limit
        slipping = np.where(undecided, self.state == SLIP, size > limit)
        # A slipping point whose trial turned against its slip direction overshot: the
        # full Coulomb force stopped it within the step. Its answer lies between the two
        # directions, so it sticks next (else +s and -s alternate without end: an oblique
        # impact, the edge of a Cattaneo-Mindlin contact).
        along = np.einsum("pd,pd->p", trial, self.direction)
        slipping &= ~((self.state == SLIP) & (along < 0.0))
        state = np.where(active, np.where(slipping, SLIP, STICK), OPEN).astype(np.int8)
        slip = state == SLIP
        direction = np.zeros_like(self.direction)
        direction[slip] = trial[slip] / np.maximum(size[slip], 1e-300)[:, None]
        direction = self._damped(direction, slip)
        turned = np.abs(direction - self.direction)[slip].max(initial=0.0) > DIRECTION_TOLERANCE
        changed = bool(turned or not np.array_equal(state, self.state))
        self.state = state
        self._tried.append(state)
        if turned or not np.array_equal(slip, self.direction.any(axis=1)):
            # else kept bit for bit: the same matrix, settled
            self.direction = direction
            self.scale = np.where(slip, limit / np.maximum(size, 1e-300), 0.0)
        return changed

    def hold(self, decisions: int) -> None:
        """After a cycle of the contact iteration: the points whose state went round stick.

        ``decisions``: how many of the step's last decisions the cycle holds. Neither state
        held (sticking, the trial beyond the limit; slipping, the trial turned against the
        direction); the cycle's last slip committed a direction the point moved along, so
        friction fed the body (the oblique impact at mu = 5, dt 5e-4: the energy doubled).
        Sticking stores what it takes: the step never creates energy.
        """
        went_round = np.any([state != self.state for state in self._tried[-decisions:]], axis=0)
        held = went_round & (self.state != OPEN)
        self.state = np.where(held, STICK, self.state).astype(np.int8)
        self.direction[held], self.scale[held] = 0.0, 0.0

    def _damped(self, direction: np.ndarray, slip: np.ndarray) -> np.ndarray:
        """The new slip directions, with a point's alternating turns cut to their fixed point.

        A point whose direction swings back and forth between solves (a sliding face
        released by its neighbours: +-0.1 rad, 4 % less each solve) is a fixed point
        iteration with a negative rate; the rate measured from its last two turns
        (Aitken) gives the direction it tends to. Turns that do not alternate are left as
        they are (the return mapping's tangent converges those fast).
        """
        kept = slip & (self.state == SLIP)
        step = np.where(kept[:, None], direction - self.direction, 0.0)
        last = self._last_turn
        rate = np.einsum("pd,pd->p", step, last) / np.maximum(
            np.einsum("pd,pd->p", last, last), 1e-300
        )
        swing = kept & (rate < 0.0)
        if swing.any():
            moved = self.direction[swing] + step[swing] / (1.0 - rate[swing, None])
            direction[swing] = moved / np.linalg.norm(moved, axis=1)[:, None]
            step[swing] = direction[swing] - self.direction[swing]
        self._last_turn = step
        return direction

    def commit(
        self, w: np.ndarray, solved: np.ndarray | None = None, kept: np.ndarray | None = None
    ) -> None:
        """The end of a step: its tractions become the history, its slip and dissipation.

        The dissipation follows the path the step took (:mod:`dd_contact.impact`), with the
        force applied on each leg: at t_n a leaving point's start traction drops to its
        kept share ``kept`` (theta; default whole), then the step's mean traction over its
        own displacement to ``solved``, then the end law over its walls' move to
        equilibrium, to w (default: solved is w; a point open at the end holds no force on
        that leg). Counted from the start to w in one go, a released point's start traction
        was charged with its walls' move too: the oblique impact at mu = 5 reported up to
        2.7e-5 J more dissipation than the energy lost.
        """
        before = self._tangential(self.traction)  # the trial at the start of the step
        leaving = (self.state == OPEN)[:, None]
        held = before if kept is None else np.where(leaving, kept[:, None] * before, before)
        path = [(before, before), (held, before)]  # (traction, trial) along the step
        path += [(self.tractions(s), self.trial(s)) for s in (solved, w) if s is not None]
        work = sum(self._work(*a, *b) for a, b in itertools.pairwise(path))
        work[self.state == STICK] = 0.0  # the spring's work is what it stored: round-off
        self.dissipation = float(np.dot(self.operator.points.weight, work))
        # The body moved by the relative slip plus the obstacle's displacement: the mean
        # traction's work over the latter is the obstacle's, beyond the dissipation's books.
        moved = np.einsum("pd,d->p", 0.5 * (path[1][0] + path[2][0]), self._moved())
        self.obstacle_work = float(np.dot(self.operator.points.weight, moved))
        t, trial = path[-1]
        self.slip += np.where((self.state == SLIP)[:, None], self.epsilon * (t - trial), 0.0)
        self.traction, self.start, self.t_start = t, np.array(w, float), self.operator.t
        self._last_turn = np.zeros_like(self.direction)  # a new step's turns
        self._tried = []

    def _work(self, t0: np.ndarray, trial0: np.ndarray, t1: np.ndarray, trial1: np.ndarray):
        """Per point, the dissipation of a move from (t0, trial0) to (t1, trial1).

        The mean traction's work on the body less what the tangential penalty stored: the
        trapezoidal rule's (the mean force over the move), and the whole work of a slipping
        point in steady sliding. P du = -eps_T (trial1 - trial0).
        """
        mean = 0.5 * (t0 + t1)
        stored = 0.5 * (np.sum(t1 * t1, axis=1) - np.sum(t0 * t0, axis=1))
        return self.epsilon * (np.einsum("pd,pd->p", mean, trial1 - trial0) - stored)

    def nodal(self, values: np.ndarray) -> np.ndarray:
        """Point values (points x k) at the nodes, weighted by the points' areas."""
        points = self.operator.points
        weighted = points.N.T @ (points.weight[:, None] * values)
        return weighted / np.maximum(points.lumped, 1e-300)[:, None]

    def fields(self) -> list[np.ndarray]:
        """The nodal slip, tangential traction and stick/slip map (the output's)."""
        state = self.state.astype(float)[:, None]
        return [self.nodal(values) for values in (self.slip, self.traction, state)]

    def start_force(self, points: np.ndarray | None = None) -> np.ndarray:
        """The friction force on the surface dofs at the start of the step (its history).

        ``points``: only these points' (a mask; default all).
        """
        a = self.operator.points.weight if points is None else self.operator.points.weight * points
        return self._E.T @ (a[:, None] * self.traction).ravel()

    def energy(self, w: np.ndarray) -> float:
        """The tangential penalty's stored energy ``(eps_T / 2) int |t|^2``."""
        t = self.tractions(w)
        return 0.5 * self.epsilon * float(np.dot(self.operator.points.weight, np.sum(t * t, 1)))

    def digest(self) -> str:
        """A fingerprint of the stick/slip state (to detect cycling)."""
        data = self.state.tobytes() + np.round(self.direction, 9).tobytes()
        return hashlib.blake2b(data, digest_size=12).hexdigest()

    # -- the run's state ----------------------------------------------------------------
    def arrays(self) -> dict[str, np.ndarray]:
        """The history as arrays (a checkpoint's)."""
        out = {name: np.array(getattr(self, name)) for name in _ARRAYS}
        out["t_start"] = np.array([self.t_start])
        return out

    def restore(self, arrays: dict[str, np.ndarray]) -> None:
        """The history from :meth:`arrays`."""
        for name in _ARRAYS:
            setattr(self, name, np.array(arrays[name], dtype=getattr(self, name).dtype))
        self.t_start = float(arrays["t_start"][0])
