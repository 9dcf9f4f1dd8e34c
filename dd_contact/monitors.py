"""What a run watches: its energy balance, its contact episodes and how its contacts are carried.

Each monitor reads the records a problem agrees at the end of a step (or a static solve) and
warns once when the run loses accuracy or creates energy; none changes the results. Each is
independent of the problem and testable alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from mpi4py import MPI

import numpy as np

from dd_contact.blocks import Block
from dd_contact.errors import (
    CoarseContactWarning,
    CoarseTimeStepWarning,
    EnergyGrowthWarning,
    warn,
)
from dd_contact.impact import RELEASE_TOLERANCE
from dd_contact.parallel import any_rank, sum_over_ranks

__all__ = [
    "ENERGY_GROWTH_TOLERANCE",
    "MINOR_EPISODE",
    "MIN_CONTACT_POINTS",
    "MIN_CONTACT_STEPS",
    "ContactEpisodes",
    "ContactResolution",
    "EnergyBalance",
    "EpisodeImpulses",
]

#: A step whose energy grows by more than this fraction of the largest energy of the run
#: beyond the loads' work warns (EnergyGrowthWarning), unless energy-safe contact's release
#: iteration allows it (RELEASE_TOLERANCE of the penalty energy held at the step's start).
#: Round-off is far below it (docs/validation.md, "Free vibration"); a contact release of the
#: classic rule gains far more.
ENERGY_GROWTH_TOLERANCE = 1e-6

#: A contact episode (a region touching from the step its first point enters to the step its
#: last one leaves) closed in fewer steps than this warns (CoarseTimeStepWarning); the
#: measurements behind it are in docs/validation.md, "A time step too coarse for the impact".
MIN_CONTACT_STEPS = 60

#: A contact whose force, at its peak, is carried by fewer effective points than this warns
#: (CoarseContactWarning): ``(sum f)^2 / sum f^2`` over the points' forces, the count of
#: active points when they carry alike. The measurements behind it (a Hertz press resolved
#: by 1 to 400 points, ``benchmarks/coarse_contact.py``) are in docs/contact.md, "A contact
#: carried by too few points".
MIN_CONTACT_POINTS = 8

#: An episode whose impulse (its force summed over its steps) is below this share of the
#: largest impulse of an episode of the run (any region) is minor: neither its time steps
#: nor its points are judged. The worst errors measured on an unresolved episode (37 % of
#: its force on 1-3 points, docs/contact.md; the bar's rebound 15 % slow at 8 steps) are then
#: below 4 % of the run's largest; the pin joint's plates graze a pin between their hits
#: with 0.3-2 % of a hit's impulse.
MINOR_EPISODE = 0.1


class EpisodeImpulses:
    """Each region's open contact episode's impulse, and which closed episodes are minor.

    The impulse is the region's force magnitude summed over the episode's steps (times the
    fixed dt it is the impulse; the ratios below do not need it).
    """

    def __init__(self) -> None:
        #: The impulse of each region's open episode (its force summed so far).
        self.open: dict[str, float] = {}
        #: The largest impulse of a closed episode of the run.
        self.largest = 0.0

    def add(self, name: str, force: float) -> None:
        """One more step of ``name``'s open episode, carrying ``force``."""
        self.open[name] = self.open.get(name, 0.0) + force

    def close(self, name: str) -> bool:
        """Close ``name``'s episode; whether it was major (:data:`MINOR_EPISODE`)."""
        impulse = self.open.pop(name, 0.0)
        self.largest = max(self.largest, impulse)
        return impulse >= MINOR_EPISODE * self.largest

    def major(self, name: str) -> bool:
        """Whether ``name``'s open episode is major so far."""
        impulse = self.open.get(name, 0.0)
        return impulse >= MINOR_EPISODE * max(self.largest, impulse)


def obstacles_moved(contacts: Sequence, t0: float, t1: float) -> bool:
    """Whether an obstacle of ``contacts`` moved between ``t0`` and ``t1`` (pairs have none)."""
    for c in contacts:
        motion = getattr(getattr(c, "obstacle", None), "motion", None)
        if motion is not None and not np.array_equal(motion(t0), motion(t1)):
            return True
    return False


def _force(record: dict, name: str) -> float:
    return float(np.linalg.norm(record["force"][name]))


class EnergyBalance:
    """Collective: warn once if a step's energy grew by more than the loads' work.

    Friction's dissipation over the step (the record's ``dissipated``) is taken out: energy
    now = energy before + loads' work - dissipation.

    The trapezoidal rule conserves energy exactly but for contact points that change state;
    a gain beyond round-off is energy the contact created (:mod:`dd_contact.impact`). A
    scheme that does not conserve energy (generalized-alpha: its energy may swing up within
    a step while it decays overall) is held to the energy at the start plus the loads' work.
    A step in which prescribed displacements move is not checked (their reactions' work is
    not counted); a moving obstacle's work through contact (normal, and tangential with
    friction) is counted with the loads'.

    Args:
        comm: Communicator of the run.
        conserves_energy: Whether the time scheme conserves energy step by step.
        energy_safe: Whether contact is energy-safe (the warning's advice depends on it).
    """

    def __init__(
        self,
        comm: MPI.Comm,
        conserves_energy: bool,
        energy_safe: bool,
        contacts: Sequence = (),
        dt: float = 0.0,
    ):
        self.comm = comm
        #: The scene's contacts and time step: in a step in which an obstacle moved, its
        #: work (through contact, in no load vector) is counted with the loads'.
        self.contacts, self.dt = list(contacts), dt
        self.conserves_energy = conserves_energy
        self.energy_safe = energy_safe
        #: The bound of the next step's energy: the last step's total (``None``: unknown).
        self.before: float | None = None
        #: Whether the warning was given (it is given once a run).
        self.warned = False
        #: The largest energy of the run so far: the scale of its round-off.
        self.largest = 0.0
        #: The contact penalty energy at the start of the step (what a release can settle on).
        self.contact_before = 0.0
        #: Each checked step's books: ``(step, gain, allowed)``, the energy now less the
        #: energy before, the loads' (and moving obstacles') work, plus the dissipation.
        self.gains: list[tuple[int, float, float]] = []

    def start(self, energy: Mapping[str, float]) -> None:
        """The energy at the start of the run (``total`` and ``contact`` parts)."""
        self.before = energy["total"]
        self.contact_before = energy["contact"]
        self.largest = max(self.largest, abs(energy["total"]))

    def loads_work(
        self,
        before: Mapping[Block, np.ndarray],
        after: Mapping[str, np.ndarray],
        previous: Mapping[str, np.ndarray],
        external: Mapping[str, np.ndarray],
        free: Callable[[Block], np.ndarray],
    ) -> tuple[float, bool]:
        """Collective: the loads' work over a step (trapezoidal) and whether supports moved.

        Args:
            before: The owned subdomains' displacement at the start of the step, by block.
            after: Their displacement at its end (more blocks may be there).
            previous: Their load vectors at the start of the step.
            external: Their load vectors at its end.
            free: 1 on a block's free dofs, 0 on its prescribed ones.
        """
        work, moved = 0.0, False
        for block, u in before.items():
            free_dofs = free(block)
            du = after[block] - u
            moved = moved or bool(np.any(du[free_dofs == 0]))
            work += 0.5 * float((free_dofs * (previous[block] + external[block])) @ du)
        return sum_over_ranks(self.comm, work), any_rank(self.comm, moved)

    def check(
        self,
        record: dict,
        work: Callable[[], tuple[float, bool]],
        obstacle_work: Callable[[], float] = lambda: 0.0,
    ) -> None:
        """Collective: hold the step of ``record`` (with its agreed ``energy``) to the balance.

        ``work`` gives the loads' work over the step and whether supports moved
        (:meth:`loads_work`), ``obstacle_work`` the moving obstacles' work through contact
        (:meth:`dd_contact.impact.StartForces.obstacle_work`, this rank's: summed here); both
        are called only while the balance is still watched, the second in steps in which an
        obstacle moves.
        """
        energy_before, contact_before = self.before, self.contact_before
        energy_after = record["energy"]["total"]
        self.before, self.contact_before = energy_after, record["energy"]["contact"]
        self.largest = max(self.largest, abs(energy_after))
        if energy_before is None or self.warned:
            return
        loads_work, moved = work()
        if moved:
            return
        t = record["t"]
        if obstacles_moved(self.contacts, t - self.dt, t):  # its work goes through contact
            loads_work += sum_over_ranks(self.comm, obstacle_work())
        dissipated = record["energy"].get("dissipated", 0.0)  # friction's work, >= 0
        if not self.conserves_energy:
            self.before = energy_before + loads_work - dissipated
        gain = energy_after - energy_before - loads_work + dissipated
        allowed = ENERGY_GROWTH_TOLERANCE * max(self.largest, abs(energy_before))
        if self.energy_safe:  # what its release iteration settles within (classic: none)
            allowed = max(allowed, RELEASE_TOLERANCE * contact_before)
        self.gains.append((record["step"], gain, allowed))
        if gain > allowed:
            self.warned = True
            fix = (
                "this should not happen with energy_safe_contact=True: please report it"
                if self.energy_safe
                else "use TransientProblem(..., energy_safe_contact=True), or a softer "
                "contact penalty (contact_kappa)"
            )
            warn(
                f"step {record['step']} (t = {record['t']:.6g}): the energy grew by "
                f"{gain:.3g} J ({gain / max(self.largest, 1e-300):.2%} of the run's largest "
                f"energy) more than the loads' work, with {record['changes']} contact state "
                f"change(s): the contact created energy; {fix}",
                EnergyGrowthWarning,
            )


class ContactEpisodes:
    """Warn once if an impact's contact episode closed within :data:`MIN_CONTACT_STEPS` steps.

    An episode is an impact when kinetic energy was at least half of the kinetic and elastic
    energy at the step before it opened (unknown without the energy: then every episode
    counts); a load that presses and lets go slowly is followed by any dt. A minor episode
    (a graze between hits: :data:`MINOR_EPISODE`) is not judged. The records are agreed on
    every rank: every rank warns alike.

    Args:
        dt: The run's time step.
    """

    def __init__(self, dt: float):
        self.dt = dt
        #: Steps of each region's open episode (0: none open).
        self.steps: dict[str, int] = {}
        #: Whether motion, not load, opened each region's episode.
        self.impact: dict[str, bool] = {}
        #: Whether the warning was given (it is given once a run).
        self.warned = False
        #: The episodes' impulses (which are minor).
        self.impulses = EpisodeImpulses()

    def observe(self, record: dict, energy_before: Mapping[str, float] | None) -> None:
        """Follow the episodes through the step of ``record`` (its agreed ``active`` counts).

        Args:
            record: The step's record.
            energy_before: The energy record of the step before (``None``: unknown).
        """
        for name, points in record["active"].items():
            steps = self.steps.get(name, 0)
            if points:
                if not steps:
                    self.impact[name] = energy_before is None or (
                        energy_before["kinetic"]
                        >= 0.5 * (energy_before["kinetic"] + energy_before["elastic"])
                    )
                self.steps[name] = steps + 1
                self.impulses.add(name, _force(record, name))
                continue
            self.steps[name] = 0
            if not steps:
                continue
            major = self.impulses.close(name)
            if steps >= MIN_CONTACT_STEPS or self.warned or not major:
                continue
            if not self.impact.get(name, True):
                continue
            self.warned = True
            self._warn(name, record, steps)

    def _warn(self, name: str, record: dict, steps: int) -> None:
        duration = steps * self.dt
        warn(
            f"contact {name!r}: an impact's contact episode ended at step {record['step']} "
            f"(t = {record['t']:.6g}) after only {steps} time step(s), {duration:.3g} s; "
            f"with fewer than {MIN_CONTACT_STEPS} steps per contact an impact's rebound is "
            f"inaccurate (the bar impact: 15 % slow at 8 steps, 2-4 % at 53), though the "
            f"energy is kept; use a smaller time step, dt <= {duration:.3g} / "
            f"{MIN_CONTACT_STEPS} = {duration / MIN_CONTACT_STEPS:.3g} s",
            CoarseTimeStepWarning,
        )


class ContactResolution:
    """Warn once per region if a contact's force was carried by too few points.

    A contact's size and pressure are resolved by its points: carried by a handful, its
    force, radius and pressure are off by up to tens of percent (docs/contact.md). Judged at
    the contact's peak, where it carries most: a static solve is judged as it is; in time
    steps, each episode of a region (from the step its first point enters to the step its
    last one leaves) is judged at its step of largest force when it closes, or when the run
    ends (:meth:`finish`). Every contact starts with a point or two; only the peak tells.
    A region pressed whole (every point active, a flat face) has no contact edge for the
    mesh to resolve and is not judged, nor is a minor episode (a graze between hits:
    :data:`MINOR_EPISODE`). The records are agreed on every rank: every rank warns alike.
    """

    def __init__(self) -> None:
        #: Per region, its open episode's peak: (force, effective points, step, t).
        self.peak: dict[str, tuple[float, float, int | None, float]] = {}
        #: Regions warned about (each once a run).
        self.warned: set[str] = set()
        #: The episodes' impulses (which are minor).
        self.impulses = EpisodeImpulses()

    def observe(self, record: dict, carrying: Mapping[str, tuple[float, bool]]) -> None:
        """Follow the step of ``record`` (its agreed ``force`` and ``active`` per region).

        Args:
            record: The step's record.
            carrying: Per region, the effective points and whether all were active
                (:func:`dd_contact.post.carrying_points`).
        """
        for name, points in record["active"].items():
            if not points:
                if name in self.peak and self.impulses.close(name):
                    self._judge(name, self.peak[name])
                self.peak.pop(name, None)
                continue
            force = _force(record, name)
            self.impulses.add(name, force)
            effective, whole = carrying[name]
            if whole:
                effective = float("inf")
            if force > self.peak.get(name, (-1.0,))[0]:
                self.peak[name] = (force, effective, record.get("step"), record["t"])

    def solved(self, record: dict, carrying: Mapping[str, tuple[float, bool]]) -> None:
        """Judge a static solve's contacts as they are (each solve an episode of its own)."""
        self.peak.clear()
        self.impulses = EpisodeImpulses()
        self.observe(record, carrying)
        for name, peak in self.peak.items():
            self._judge(name, peak)

    def finish(self) -> None:
        """Judge every major open episode at its peak so far (a run's end; they stay open)."""
        for name, peak in self.peak.items():
            if self.impulses.major(name):
                self._judge(name, peak, still_open=True)

    def _judge(
        self,
        name: str,
        peak: tuple[float, float, int | None, float] | None,
        still_open: bool = False,
    ) -> None:
        if peak is None or name in self.warned or peak[1] >= MIN_CONTACT_POINTS:
            return
        self.warned.add(name)
        force, effective, step, t = peak
        when = f"at step {step} (t = {t:.6g})" if step is not None else f"at t = {t:.6g}"
        # A run continued by a later call ends inside an impact's first steps.
        open_note = (
            " (it was still in contact when run() returned: a call that a later one continues "
            "takes run(..., final=False), and its contacts are judged when they close)"
            if still_open
            else ""
        )
        warn(
            f"contact {name!r}: its largest force, {force:.4g} N {when}, was carried by "
            f"{effective:.1f} nodes' worth of contact surface; carried by fewer than "
            f"{MIN_CONTACT_POINTS}, a contact's force, size and pressure are set by the mesh, "
            f"not the solution (a Hertz press: up to 45 % off in force and 42 % in contact "
            f"radius; 3-8 % at 10-14 nodes); refine the body's mesh and the contact surface "
            f"where it touches, to cells of a third of the contact's radius (half-width) or "
            f"less (quadrature contact points on the same mesh do not help){open_note}",
            CoarseContactWarning,
        )
