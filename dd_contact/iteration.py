"""The contact iteration: solve, update the active sets, repeat until none changes.

:class:`ContactIteration` drives any solver of the block system that follows the
:class:`ContactSolver` protocol (:class:`dd_contact.solvers.MonolithicSolver` and
:class:`dd_contact.solvers.engine.BlockEliminationSolver`) with the contact zones of
:class:`dd_contact.assembly.Model`; :class:`ContactSettings` says how it runs. The contact
term itself (points, gap, matrices) is in :mod:`dd_contact.contact`.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from dd_contact.assembly import ContactZone
from dd_contact.bodies import Body, rigid_motion_rows
from dd_contact.errors import (
    ContactCycleWarning,
    ContactIterationError,
    InaccurateSolutionError,
    SingularMatrixError,
    warn,
)
from dd_contact.parallel import allgathered, any_rank, sum_over_ranks
from dd_contact.solvers.residual import (
    DEFAULT_RESIDUAL_TOLERANCE,
    FREE_ROW_TOLERANCE,
    Residual,
    ResidualCheck,
)

__all__ = ["STATE_BAND", "ContactIteration", "ContactSettings", "ContactSolver", "digest"]


class ContactSolver(Protocol):
    """What the contact iteration needs of a block solver."""

    def set_contact(self, key: str, matrix: sp.csr_array, active: np.ndarray | None = None) -> None:
        """Replace region ``key``'s contact matrix (surface dof numbering; its points' flags)."""
        ...

    def solve(self, rhs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Solve with this rank's right-hand side; at least the blocks of this rank's zones."""
        ...

    def finish(self) -> dict[str, np.ndarray]:
        """The last solution, once the contact state has settled.

        At least every surface block and this rank's subdomains.
        """
        ...

    @property
    def rhs_offset(self) -> dict[str, np.ndarray]:
        """This rank's vector subtracted from the right-hand side of the last solve.

        The stiff ties' forces (:mod:`dd_contact.solvers.stiff_ties`); empty for others.
        """
        ...


#: Solves again for one contact state while a :class:`StepCorrection` settles; then the
#: last one stands (the energy check of a time step reports what is left).
MAX_RELEASES = 10


class StepCorrection(Protocol):
    """Right-hand-side terms of a solve that depend on its outcome (rank-local)."""

    def correction(
        self, active: Mapping[str, np.ndarray], x: Mapping[str, np.ndarray] | None
    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Additions to the right-hand side, and shifts: the solver solves for x - shift."""
        ...

    def settled(self, active: Mapping[str, np.ndarray], x: Mapping[str, np.ndarray]) -> bool:
        """Whether the terms used for the last solve hold for its solution ``x``."""
        ...

    def needs_whole(self, active: Mapping[str, np.ndarray], x: Mapping[str, np.ndarray]) -> bool:
        """Whether :meth:`at_end` needs more blocks than the iterate ``x`` holds."""
        ...

    def at_end(
        self, active: Mapping[str, np.ndarray], x: Mapping[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """The state at the end of the step the solution ``x`` with ``active`` stands for."""
        ...

    def pressed_back(self, x: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Per zone: points let go in this step that ``x`` shows must be in contact again.

        The other points that left the step's first active set stay out for the rest of
        the step: the correction carries their force.
        """
        ...


#: A point changes contact state only when its penetration passes zero by more than this
#: fraction of its contact's size: within it the sign is round-off (a bar landing exactly
#: at a step's end cycled through its points, penetrations +-1e-17 m, 5 state changes). Not
#: wider: a stiff penalty turns 1e-12 of the size into 2.8e-3 of a quasi-static load.
STATE_BAND = 1e-15


def digest(active: np.ndarray) -> str:
    """A short fingerprint of an active set (to detect cycling)."""
    return hashlib.blake2b(np.packbits(active).tobytes(), digest_size=12).hexdigest()


def _state_digest(zone: ContactZone, active: np.ndarray) -> str:
    """A zone's contact state: its active set, and its points' stick or slip (friction)."""
    friction = getattr(zone.operator, "friction", None)
    return digest(active) + ("" if friction is None else friction.digest())


@dataclass
class ContactSettings:
    """How the contact iteration runs.

    Attributes:
        max_iterations: Largest number of solves in one step (or one static solve).
        on_cycle: What to do when an active set repeats within a step: ``"union"`` (default:
            make every point of the cycle active, solve once more and go on, with a
            :class:`ContactCycleWarning` that says where; a few points may then carry a small
            tension) or ``"raise"`` (stop with a :class:`ContactIterationError` that says
            where).
        penetration_tolerance: Largest initial overlap of body and obstacle accepted at the
            start (default: 1e-3 of the mean contact-surface cell size).
        touching_tolerance: Gap up to which a point counts as touching when a solve starts
            from scratch, so it starts active (default: 1e-8 of the mean contact-surface cell
            size): a body that just touches is held from the first solve, whatever the sign
            of the round-off in its computed gap.
        residual_tolerance: Largest accepted relative residual ``|b - A x| / |b|`` of the
            whole system after each solve (:mod:`dd_contact.solvers.residual`): penalty
            round-off grows like kappa, and above this the solve raises
            :class:`InaccurateSolutionError`. The rows without tie or contact terms are
            always checked (against 1e-8: a body that can move freely fails there). ``None``
            switches both checks off.
    """

    max_iterations: int = 50
    on_cycle: str = "union"
    penetration_tolerance: float | None = None
    touching_tolerance: float | None = None
    residual_tolerance: float | None = DEFAULT_RESIDUAL_TOLERANCE

    def __post_init__(self):
        if self.max_iterations < 1:
            raise ValueError("ContactSettings: max_iterations must be >= 1")
        if self.on_cycle not in ("raise", "union"):
            raise ValueError("ContactSettings: on_cycle must be 'raise' or 'union'")
        for name in ("touching_tolerance", "residual_tolerance"):
            value = getattr(self, name)
            if value is not None and not value >= 0:
                raise ValueError(f"ContactSettings: {name} must be >= 0 or None, got {value}")


class ContactIteration:
    """Active-set iteration: solve, update the active sets, repeat until none changes.

    Works with any :class:`ContactSolver` (``solve`` must return at least the blocks of this
    rank's zones; ``finish`` every surface block and this rank's subdomains of the last
    solution: a decomposition solver back-substitutes the rest only once the contact state has
    settled), and with the zones of
    :class:`dd_contact.assembly.Model`. Every iteration in which some active set changed is
    one *contact state change* (gamma); a change on zone k also counts in alpha[k].

    Args:
        comm: Communicator (the zones are spread over ranks).
        zones: This rank's contact zones.
        settings: Iteration settings.
        sizes: Size of every block a zone lives in (the block system's ``sizes``): a zone's
            contact right-hand side goes into a zero vector of that size when the given
            right-hand side has no such block.
        check: The residual check of the solver's system (``None``: no check).
        held: Bodies that only contact can hold (quasi-static problems): before every solve
            their active contact points must resist each of their free rigid motions, or
            the matrix is singular and the solve raises :class:`SingularMatrixError`.
    """

    def __init__(
        self,
        comm,
        zones: Sequence[ContactZone],
        settings: ContactSettings,
        sizes: Mapping[str, int],
        check: ResidualCheck | None = None,
        held: Sequence[Body] = (),
    ):
        self.comm, self.zones, self.settings = comm, zones, settings
        self.sizes = {b: int(sizes[b]) for z in zones for b, _ in z.parts}
        self.check = check if settings.residual_tolerance is not None else None
        self.held = [body for body in held if body.free.shape[1]]
        #: Estimated residuals of the last solve (``None`` before one, or unchecked).
        self.residual: Residual | None = None
        self._touching = {
            z.contact.name: settings.touching_tolerance
            if settings.touching_tolerance is not None
            else 1e-8 * z.length
            for z in zones
        }
        #: This rank's right-hand side (contact terms included) and contact matrices
        #: ``(parts, matrix)`` of the last solve (``parts``: ``(block, dofs)`` in the matrix's
        #: numbering): what its residual is checked against.
        self.last_solve: tuple[dict, list] = ({}, [])
        self.active: dict[str, np.ndarray] = {}
        self.gamma = 0
        self.alpha = {z.contact.name: 0 for z in zones}
        self.cycles_resolved = 0
        #: Solves again for a settled contact state while a step correction settles (all steps).
        self.release_solves = 0
        #: Per zone of this rank: the release solves in which it had points let go (the
        #: solves' new right-hand side is on its block; :meth:`Schedule.release`).
        self.releases = {z.contact.name: 0 for z in zones}
        #: Iterates taken whole (every subdomain substituted) to settle a leaving point's walls.
        self.whole_iterates = 0
        self._held_in_now = False  # whether the last decision pressed points back in
        self._whole: dict[str, np.ndarray] | None = None  # the last solve's, if taken
        self._solved: dict[str, np.ndarray] = {}  # the step's solution the last end state is of
        self._correction: StepCorrection | None = None
        self._shift: dict[str, np.ndarray] = {}
        self._last: dict[str, np.ndarray] | None = None

    def start(self, t: float) -> None:
        """Initial active sets: the points touching the obstacle at ``t`` (within tolerance)."""
        for z in self.zones:
            z.operator.update(t)
            self.active[z.contact.name] = z.operator.gap <= self._touching[z.contact.name]

    def solve(
        self,
        solver: ContactSolver,
        rhs: dict[str, np.ndarray],
        t: float,
        where: str,
        correction: StepCorrection | None = None,
    ):
        """Solve at time ``t`` with the contact iteration; returns the solution blocks.

        Args:
            solver: The block solver.
            rhs: Right-hand side without contact terms (this rank's contributions).
            t: Time (obstacles may move).
            where: Text for messages (e.g. "step 12 (t = 0.0012)").
            correction: Right-hand-side terms that depend on the active sets being tried
                and the last solution (the time step's start forces, :mod:`dd_contact.impact`).
        """
        self._correction, self._shift, self._last = correction, {}, None
        for z in self.zones:
            z.operator.update(t)
        seen = {self._global_digest(): 0}
        released = {n: np.zeros_like(a) for n, a in self.active.items()}
        held_in = {n: np.zeros_like(a) for n, a in self.active.items()}  # pressed back in
        releases = 0  # solves again for the same contact state (the correction settling)
        sets = [dict(self.active)]
        changes_this_solve = 0
        for iteration in range(1, self.settings.max_iterations + 1):
            x = self._solve_once(solver, rhs, where)
            # (collective) no change yet: every point is as at the step's start, none left
            moved = changes_this_solve > 0
            new, changed = self._decide(solver, x, (sets[0], released, held_in), False, moved)
            if not sum_over_ranks(self.comm, len(changed)):
                if releases < MAX_RELEASES and self._unsettled(x):
                    releases += 1  # the same contact state; its releasing forces still move
                    self._count_release(sets[0])
                    continue
                if moved:  # settled: decide on the whole end state (an order's walls too)
                    new, changed = self._decide(solver, x, (sets[0], released, held_in), True)
                if not moved or not sum_over_ranks(self.comm, len(changed)):
                    x = self._shifted(self._checked(solver, self._finished(solver), where))
                    if moved:
                        x = self._at_end(solver, x, whole=True)
                    return self._committed(x, moved), iteration, changes_this_solve
            if self._held_in_now:
                seen = {}  # the points pressed back stay in: no cycle through them
            self._count_change(changed)
            changes_this_solve += 1
            previous = self.active
            self.active = new
            key = self._global_digest()
            if key in seen:
                message = self._cycle_message(previous, new, seen[key], iteration, where)
                changes_this_solve += self._union_of_cycle(sets[seen[key] :], message)
                self._solve_once(solver, rhs, where)
                x = self._shifted(self._checked(solver, self._finished(solver), where))
                x = self._at_end(solver, x, whole=True)
                return self._committed(x), iteration + 1, changes_this_solve
            seen[key] = iteration
            sets.append(dict(self.active))
        raise ContactIterationError(
            f"contact iteration did not settle in {self.settings.max_iterations} iterations at "
            f"{where}; raise ContactSettings(max_iterations=...), or take a smaller time step or "
            "load increment"
        )

    def _decide(
        self,
        solver: ContactSolver,
        x: dict[str, np.ndarray],
        sets: tuple[dict, dict, dict],
        whole: bool,
        moved: bool = True,
    ) -> tuple[dict[str, np.ndarray], list[str]]:
        """Collective: the active sets the end state of ``x`` shows, and where they changed.

        The points let go in this step that the end state shows pressed back in come back
        first (and stay in); they are judged on the ``whole`` end state only, once the
        releases' forces have settled. Before, an iterate that shows such points decides
        nothing: the entries it shows may be theirs (a bar pushed onto its wall cycled
        through the neighbours of the points it let go, and created energy). ``sets``: the
        step's first active sets, the points let go and those held in; ``moved``: whether
        some rank's active sets changed in this solve (none let go otherwise).
        """
        start, released, held_in = sets
        self._held_in_now = False
        end = self._at_end(solver, x, whole)
        if self._correction is None or not moved:
            return self._next_sets(end, start, released, held_in)
        if not whole:
            back = self._correction.pressed_back(end)
            if any_rank(self.comm, any((back[n] & released[n]).any() for n in back)):
                return dict(self.active), []
            # friction decides on the whole end state only where the walls left as solved
            # are stale: else its slip directions went round between the two kinds
            partial = any_rank(self.comm, self._correction.needs_whole(self.active, x))
            return self._next_sets(end, start, released, held_in, not partial)
        back_in = self._pressed_back(end, released, held_in)
        self._held_in_now = bool(sum_over_ranks(self.comm, len(back_in)))
        return self._next_sets(end, start, released, held_in)

    def _next_sets(
        self,
        end: dict[str, np.ndarray],
        start: dict,
        released: dict,
        held_in: dict,
        friction_decides: bool = True,
    ) -> tuple[dict[str, np.ndarray], list[str]]:
        """The active sets the end state ``end`` shows, and the zones where they changed."""
        new = {}
        for z in self.zones:
            name = z.contact.name
            g = z.operator.penetration(z.gather(end))
            # a penetration within round-off of zero is no evidence: the point keeps its state
            undecided = np.abs(g) <= STATE_BAND * z.length
            if self._correction is not None and end is not self._solved:
                undecided |= self._touching_at_end(z, start[name], g)
            new[name] = np.where(undecided, self.active[name], g > 0.0)
        if self._correction is not None:
            self._keep_released_out(new, start, released, held_in)
        changed = [n for n in new if not np.array_equal(new[n], self.active[n])]
        for z in self.zones:  # a point between stick and slip is a contact state change too
            friction = getattr(z.operator, "friction", None) if friction_decides else None
            name = z.contact.name
            if friction is not None and friction.decide(z.gather(end), new[name]):
                changed += [] if name in changed else [name]
        return new, changed

    def _committed(self, x: dict[str, np.ndarray], at_end: bool = True) -> dict[str, np.ndarray]:
        """``x`` after each zone's friction took it as its history (``at_end``: of _at_end)."""
        solved = self._solved if at_end and self._correction is not None else x
        released = getattr(self._correction, "released", None) if at_end else None
        for z in self.zones:
            friction = getattr(z.operator, "friction", None)
            if friction is not None:
                kept = released(z) if released is not None else None
                friction.commit(z.gather(x), z.gather(solved), kept)
        return x

    def _touching_at_end(self, z: ContactZone, start: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Points that came into contact in this step and end in it with zero force.

        The step's solution presses them into the obstacle, but their wall, put in
        equilibrium at the step's end (:meth:`StepCorrection.at_end`, once a point of the
        zone leaves), pulls on them: let go, the step's solution without their force sinks
        them (the pin joint: 6e-15 m of tension in, 1.5e-9 m deep out, a cycle). Such a point
        is in contact at the step's end with the force clipped at zero (every force and
        energy the package reports clips it); it stays in.
        """
        solved = z.operator.penetration(z.gather(self._solved))
        return self.active[z.contact.name] & ~start & (solved > 0.0) & (g <= 0.0)

    def _at_end(
        self, solver: ContactSolver, x: dict[str, np.ndarray], whole: bool
    ) -> dict[str, np.ndarray]:
        """The end-of-step state ``x`` stands for (the correction's ``at_end``).

        An order's iterate holds the contact blocks only: where the correction needs the
        walls' subdomains too (a point leaves), ``whole`` takes the whole iterate
        (collective: a back substitution of each subdomain, once the step's releases have
        settled); else those walls are left as solved.
        """
        if self._correction is None:
            return x
        if whole and any_rank(self.comm, self._correction.needs_whole(self.active, x)):
            self._whole = solver.finish()
            self.whole_iterates += 1
            x = self._shifted(self._whole)
        self._solved = x
        return self._correction.at_end(self.active, x)

    def _finished(self, solver: ContactSolver) -> dict[str, np.ndarray]:
        """Collective: the last solve's whole solution (taken once)."""
        return self._whole if self._whole is not None else solver.finish()

    def _keep_released_out(self, new: dict, start: dict, released: dict, held_in: dict) -> None:
        """A point let go since ``start`` stays out of ``new``: the correction carries it.

        Points pressed back in (``held_in``) stay in; ``released`` gathers the others.
        """
        for name in new:
            let_go = start[name] & self.active[name] & ~new[name]
            released[name] |= let_go & ~held_in[name]
            new[name] = (new[name] & ~released[name]) | held_in[name]

    def _union_of_cycle(self, cycle: list[dict], message: str) -> int:
        """Collective: make every point active in some set of ``cycle`` active.

        Raises :class:`ContactIterationError` instead with ``on_cycle="raise"``. Returns the
        contact state changes this made (0 or 1: the union is one more contact state).
        """
        if self.settings.on_cycle == "raise":
            raise ContactIterationError(
                message + ". Remedies: a smaller time step or load increment, a softer "
                "contact penalty (contact_kappa), or ContactSettings(on_cycle='union')"
            )
        warn(message + "; resolved by making every point of the cycle active", ContactCycleWarning)
        before = dict(self.active)
        for active in cycle:
            for name in self.active:
                self.active[name] = self.active[name] | active[name]
        for friction in filter(None, (getattr(z.operator, "friction", None) for z in self.zones)):
            friction.hold(len(cycle))  # the stick/slip that went round sticks (energy-safe)
        self.cycles_resolved += 1
        grown = [n for n in self.active if not np.array_equal(before[n], self.active[n])]
        if not sum_over_ranks(self.comm, len(grown)):
            return 0
        self._count_change(grown)
        return 1

    def _pressed_back(self, x, released: dict, held_in: dict) -> list[str]:
        """The zones whose let-go points ``x`` shows deeper than at t_n: now held in.

        A point let go may end pressed in again (judged on the settled end state, see
        :meth:`_decide`): kept out it would hold its whole start force at most, and
        ending deeper than it started the penalty would store energy no force worked for;
        back in contact it gets the mean force (exact, or dissipating a small end
        tension), and stays in for the rest
        of the step (docs/contact.md, "Releases without cycles").
        """
        if self._correction is None:
            return []
        back = self._correction.pressed_back(x)
        zones = []
        for name in back:
            again = released[name] & back[name]
            if again.any():
                released[name] &= ~again
                held_in[name] |= again
                zones.append(name)
        return zones

    def _count_change(self, zones: list[str]) -> None:
        """One contact state change of the model (gamma), on each of ``zones`` (alpha)."""
        self.gamma += 1
        for name in zones:
            self.alpha[name] += 1

    def _count_release(self, start: Mapping[str, np.ndarray]) -> None:
        """One release solve (collective count), on each zone with points out since ``start``."""
        self.release_solves += 1
        for name, active in self.active.items():
            if (start[name] & ~active).any():
                self.releases[name] += 1

    def _check_held(self, where: str) -> None:
        """Collective: refuse an active set that leaves a body free to move (singular)."""
        for body in self.held:
            local = []
            for z in self.zones:
                if any(t is s for t in z.subdomains for s in body.subdomains):
                    active = self.active[z.contact.name]
                    r = (z.operator.points.x[active] - body.centre) / body.size
                    local.append(rigid_motion_rows(r, z.operator.normal[active]) @ body.free)
            parts = [p for part in allgathered(self.comm, local) for p in part]
            m = body.free.shape[1]
            rows = np.concatenate(parts) if parts else np.zeros((0, m))
            singular = np.linalg.svd(rows, compute_uv=False) if len(rows) else np.zeros(0)
            resisted = int(np.sum(singular > 1e-8 * max(1.0, singular.max(initial=0.0))))
            if resisted < m:
                names = ", ".join(repr(s.name) for s in body.subdomains)
                raise SingularMatrixError(
                    f"at {where} subdomain(s) {names} are held only by contact "
                    f"({body.describe()} without Dirichlet conditions against it), and the "
                    f"{len(rows)} active contact point(s) resist only {resisted} of them: "
                    "the matrix is singular, there is no equilibrium"
                )

    def _solve_once(self, solver: ContactSolver, rhs: dict[str, np.ndarray], where: str):
        self._check_held(where)
        rhs = dict(rhs)  # the contact terms make new vectors: the caller's stay as they are
        contact = []
        for z in self.zones:
            matrix, vector = z.contribution(active := self.active[z.contact.name])
            solver.set_contact(z.contact.name, matrix, active=active)
            contact.append((z.parts, matrix))
            for key, part in z.scatter(vector, self.sizes).items():
                rhs[key] = rhs[key] + part if key in rhs else part
        if self._correction is not None:
            extra, self._shift = self._correction.correction(self.active, self._last)
            for block, vector in extra.items():
                rhs[block] = rhs[block] + vector if block in rhs else vector
        self.last_solve = (rhs, contact)
        self._last = self._shifted(solver.solve(rhs))
        self._whole = None
        return self._last

    def _unsettled(self, x: dict[str, np.ndarray]) -> bool:
        """Collective: whether the step correction of some rank has not settled on ``x``."""
        local = self._correction is not None and not self._correction.settled(self.active, x)
        return any_rank(self.comm, local)

    def _shifted(self, x: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The solution of the blocks the last solve was shifted on (the others as solved)."""
        if not self._shift:
            return x
        return {b: v + self._shift[b] if b in self._shift else v for b, v in x.items()}

    def solved_system(self, solver: ContactSolver) -> tuple[dict, list]:
        """This rank's right-hand side and contact matrices of the solver's last solve.

        The right-hand side is the one the solver solved with: the stiff ties' forces it
        subtracted (:attr:`ContactSolver.rhs_offset`) are subtracted here too.
        """
        rhs, contact = self.last_solve
        offset = solver.rhs_offset
        if offset:
            rhs = {b: v - offset[b] if b in offset else v for b, v in rhs.items()}
            rhs.update({b: -v for b, v in offset.items() if b not in rhs})
        return rhs, contact

    def _checked(self, solver: ContactSolver, x: dict, where: str) -> dict[str, np.ndarray]:
        """``x`` if it satisfies the system it was solved from (collective)."""
        if self.check is None:
            return x
        rhs, contact = self.solved_system(solver)
        residual = self.residual = self.check.estimate(rhs, x, contact)
        tolerance = self.settings.residual_tolerance
        assert tolerance is not None  # self.check is None without one
        if not np.isfinite(residual.whole):
            raise InaccurateSolutionError(f"the solution at {where} contains NaN or inf")
        if residual.free is not None and not residual.free <= FREE_ROW_TOLERANCE:
            raise InaccurateSolutionError(
                f"the solution at {where} does not satisfy the equilibrium of the elements: "
                f"residual ~{residual.free:.1e} of the load on the dofs without tie or contact "
                f"terms (tolerance {FREE_ROW_TOLERANCE:.0e}); the matrix is singular: part of "
                "the model can move freely"
            )
        if not residual.whole <= tolerance:
            raise InaccurateSolutionError(
                f"the solution at {where} does not satisfy its system: relative residual "
                f"~{residual.whole:.1e} (tolerance {tolerance:.0e}); the tie or contact "
                "penalties are too stiff for double precision"
            )
        return x

    def _global_digest(self) -> tuple:
        local = tuple(_state_digest(z, self.active[z.contact.name]) for z in self.zones)
        return tuple(allgathered(self.comm, local))

    def _cycle_message(self, previous, new, first, iteration, where) -> str:
        lines = []
        for z in self.zones:
            flips = np.flatnonzero(previous[z.contact.name] != new[z.contact.name])
            if flips.size:
                x = np.round(z.operator.points.x[flips[0]], 6)
                lines.append(
                    f"contact {z.contact.name!r}: {flips.size} point(s) flip in/out of contact, "
                    f"e.g. at {x}"
                )

        lines = [line for part in allgathered(self.comm, lines) for line in part]
        if not lines:  # no point flips in or out: the cycle is friction's stick and slip
            lines = [
                "the stick/slip state of points with friction goes round (the load step "
                "cannot decide it: take smaller load steps)"
            ]
        return (
            f"contact iteration cycles at {where}: iteration {iteration} returns to the active "
            f"set of iteration {first}. " + "; ".join(lines)
        )
