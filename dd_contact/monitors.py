"""What a transient run watches: its energy balance and its contact episodes.

Each monitor reads the records a :class:`~dd_contact.problem.TransientProblem` agrees at the
end of a step and warns once when the run loses accuracy or creates energy; neither changes
the results. Both are independent of the problem and testable alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from mpi4py import MPI

import numpy as np

from dd_contact.blocks import Block
from dd_contact.errors import CoarseTimeStepWarning, EnergyGrowthWarning, warn
from dd_contact.impact import RELEASE_TOLERANCE
from dd_contact.parallel import any_rank, sum_over_ranks

__all__ = ["ENERGY_GROWTH_TOLERANCE", "MIN_CONTACT_STEPS", "ContactEpisodes", "EnergyBalance"]

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


class EnergyBalance:
    """Collective: warn once if a step's energy grew by more than the loads' work.

    The trapezoidal rule conserves energy exactly but for contact points that change state;
    a gain beyond round-off is energy the contact created (:mod:`dd_contact.impact`). A
    scheme that does not conserve energy (generalized-alpha: its energy may swing up within
    a step while it decays overall) is held to the energy at the start plus the loads' work.
    A step in which prescribed displacements move is not checked (their reactions' work is
    not counted).

    Args:
        comm: Communicator of the run.
        conserves_energy: Whether the time scheme conserves energy step by step.
        energy_safe: Whether contact is energy-safe (the warning's advice depends on it).
    """

    def __init__(self, comm: MPI.Comm, conserves_energy: bool, energy_safe: bool):
        self.comm = comm
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

    def check(self, record: dict, work: Callable[[], tuple[float, bool]]) -> None:
        """Collective: hold the step of ``record`` (with its agreed ``energy``) to the balance.

        ``work`` gives the loads' work over the step and whether supports moved
        (:meth:`loads_work`); it is called only while the balance is still watched.
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
        if not self.conserves_energy:
            self.before = energy_before + loads_work
        gain = energy_after - energy_before - loads_work
        allowed = ENERGY_GROWTH_TOLERANCE * max(self.largest, abs(energy_before))
        if self.energy_safe:  # what its release iteration settles within (classic: none)
            allowed = max(allowed, RELEASE_TOLERANCE * contact_before)
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
    counts); a load that presses and lets go slowly is followed by any dt. The records are
    agreed on every rank: every rank warns alike.

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
                continue
            self.steps[name] = 0
            if not steps or steps >= MIN_CONTACT_STEPS or self.warned:
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
