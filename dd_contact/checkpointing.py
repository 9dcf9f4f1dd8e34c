"""The state of a transient run as arrays: what a checkpoint holds and how a run resumes.

A run's state is the owned subdomains' displacement, velocity and acceleration (a reduced
subdomain's: its coordinates, their end acceleration and its walls' rates), the
interface's and the owned contact surfaces' displacement (massless, but the next step's
start forces read their tie forces at t_n), the contact iteration's active sets and counts,
each friction's history (:meth:`dd_contact.friction.Friction.arrays`), and the step, time
and integration settings (which a resumed run must share). Its files are
:class:`Checkpoint`'s, written so that a process killed at any moment, on any rank, leaves a
state every rank holds.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from dd_contact.assembly import ContactZone
from dd_contact.errors import InputError, OutputError
from dd_contact.iteration import ContactIteration
from dd_contact.parallel import ROOT, allgathered, bcast_from_root
from dd_contact.subdomains import Subdomain
from dd_contact.writing import TEMPORARY, failure, logger, make_durable, set_aside

__all__ = ["Checkpoint", "RunState"]

#: The fields of a subdomain a checkpoint holds.
KINEMATICS = ("u", "velocity", "acceleration")


def _friction_of(zone) -> Any:
    """A zone's friction (``None``: frictionless, or a stand-in zone without an operator)."""
    return getattr(getattr(zone, "operator", None), "friction", None)


class RunState:
    """Collective where it says so: a run's state to arrays and back.

    Args:
        owned: This rank's subdomains.
        zones: This rank's contact zones.
        iteration: The run's contact iteration (active sets, state-change counts).
        interface: The scene's interface (``None``: none).
    """

    def __init__(
        self,
        owned: Sequence[Subdomain],
        zones: Sequence[ContactZone],
        iteration: ContactIteration,
        interface=None,
    ):
        self.owned, self.zones, self.iteration = list(owned), list(zones), iteration
        self.interface = interface
        #: The run's :class:`~dd_contact.kinematics.Kinematics` when it has reduced
        #: subdomains (set by the problem): their state is their coordinates.
        self.kinematics: Any = None

    def _reduced(self) -> dict[str, np.ndarray]:
        """The owned reduced subdomains' coordinates, end accelerations, wall rates (in place).

        Their coordinates, not their expanded fields: a resumed run steps the same numbers
        (an expansion and its projection back would be a round-off away) and nothing is
        expanded to save them.
        """
        out: dict[str, np.ndarray] = {}
        k = self.kinematics
        for sub in self.owned:
            if k is not None and sub.block in k.reduced:
                for name, values in zip(KINEMATICS, k.reduced[sub.block], strict=True):
                    out[f"reduced/{name}/{sub.name}"] = values
                if sub.block in k.ends:
                    out[f"reduced/end_acceleration/{sub.name}"] = k.ends[sub.block]
                if sub.block in k.walls:
                    wv, wa = k.walls[sub.block][1]
                    out |= {f"walls/velocity/{sub.name}": wv, f"walls/acceleration/{sub.name}": wa}
        return out

    def _surfaces(self) -> dict[str, np.ndarray]:
        """The surfaces' displacement arrays by checkpoint key (written in place)."""
        out = {f"w/{side.name}": side.w.x.array for z in self.zones for side in z.sides}
        if self.interface is not None:
            out[f"v/{self.interface.name}"] = self.interface.v.x.array
        return out

    def arrays(self, step: int, t: float, dt: float, integration: str) -> dict[str, np.ndarray]:
        """This rank's state at ``step`` (time ``t``) as named arrays."""
        it = self.iteration
        state = {
            "step": np.array(step),
            "t": np.array(t),
            "dt": np.array(dt),
            "gamma": np.array(it.gamma),
            "integration": np.array(integration),
            "release_solves": np.array(it.release_solves),
        }
        reduced = self._reduced()
        for sub in self.owned:
            if f"reduced/u/{sub.name}" not in reduced:
                for name in KINEMATICS:
                    state[f"{name}/{sub.name}"] = getattr(sub, name).x.array
        state.update(reduced)
        for z in self.zones:
            name = z.contact.name
            state[f"active/{name}"] = it.active[name]
            state[f"alpha/{name}"] = np.array(it.alpha[name])
            state[f"releases/{name}"] = np.array(it.releases[name])
        state.update(self._surfaces())
        for name, friction in self._frictions().items():
            state.update({f"friction/{name}/{k}": v for k, v in friction.arrays().items()})
        return state

    def _frictions(self) -> dict:
        """The friction of each zone that has one, by contact name (its history is state)."""
        out = {z.contact.name: _friction_of(z) for z in self.zones}
        return {name: friction for name, friction in out.items() if friction is not None}

    def _restore_friction(self, state: dict[str, np.ndarray]) -> None:
        """Each zone's friction history (tractions, slip, stick/slip states) from ``state``."""
        for name, friction in self._frictions().items():
            prefix = f"friction/{name}/"
            arrays = {k[len(prefix) :]: v for k, v in state.items() if k.startswith(prefix)}
            if arrays.keys() != friction.arrays().keys():
                raise InputError(
                    f"resume: the checkpoint holds no friction history of contact {name!r} "
                    "(written without friction, or by an earlier version); start a new "
                    "output directory"
                )
            friction.restore(arrays)

    def restore(
        self, state: dict[str, np.ndarray], dt: float, integration: str
    ) -> tuple[int, float]:
        """Put ``state`` back; ``(step, t)`` it was taken at.

        Refuses a state taken with another time step or integration settings, or for
        other subdomains or meshes, with an :class:`InputError` saying what to do.
        """
        if float(state["dt"]) != dt:
            raise InputError(
                f"resume: the checkpoint was written with dt = {float(state['dt'])}, this run "
                f"has dt = {dt}; use the same time step or start a new output directory"
            )
        written = str(state["integration"]) if "integration" in state else None
        if written is not None and written != integration:
            raise InputError(
                f"resume: the checkpoint was written with {written}; this run has "
                f"{integration}; use the same settings or start a new output directory"
            )
        reduced = self._reduced()
        targets = {
            f"{name}/{sub.name}": getattr(sub, name).x.array
            for sub in self.owned
            if f"reduced/u/{sub.name}" not in reduced
            for name in KINEMATICS
        }
        _copy_into(
            targets | reduced,
            state,
            lambda key: (
                f"the checkpoint does not match subdomain {key.split('/')[-1]!r} "
                "(different scene or mesh, reduced otherwise, or an earlier version's)"
            ),
        )
        _copy_into(
            self._surfaces(),
            state,
            lambda key: (
                f"the checkpoint holds no {key.split('/')[1]!r} surface of this shape "
                "(a different scene, or a checkpoint of an earlier version without the surfaces' "
                "state)"
            ),
        )
        it = self.iteration
        it.gamma = int(state["gamma"])
        for z in self.zones:
            name = z.contact.name
            it.active[name] = state[f"active/{name}"]
            it.alpha[name] = int(state[f"alpha/{name}"])
            key = f"releases/{name}"  # absent in checkpoints written before the count
            it.releases[name] = int(state[key]) if key in state else 0
        it.release_solves = int(state.get("release_solves", 0))
        self._restore_friction(state)
        return int(state["step"]), float(state["t"])


class Checkpoint:
    """A run's state on disk: one ``.npz`` per rank, and the one before it.

    Saving is two collective phases: every rank writes ``checkpoint.rank<r>.npz.tmp``
    (:meth:`write`); once every rank has, each renames its current file to
    ``checkpoint.rank<r>.previous.npz`` and the new one to ``checkpoint.rank<r>.npz``
    (:meth:`commit`). Killed at any moment, each rank holds the new state or the old one,
    complete, among these files: :meth:`exists` finds the latest step every rank holds,
    :meth:`load` reads it and tidies the rest. Rank 0's file also holds the history.

    Args:
        directory: Where the checkpoint lives.
        comm: Communicator of the run.
    """

    def __init__(self, directory: str | Path, comm: MPI.Comm):
        self.directory = Path(directory)
        self.comm = comm
        self.path = self.directory / f"checkpoint.rank{comm.rank}.npz"
        self.previous = self.directory / f"checkpoint.rank{comm.rank}.previous.npz"
        self.pending = self.path.with_name(self.path.name + TEMPORARY)
        #: The step :meth:`exists` found (``None``: none).
        self.step: int | None = None

    def _held(self) -> dict[int, Path]:
        """The steps of this rank's complete checkpoint files."""
        held = {}
        for path in (self.previous, self.path, self.pending):
            try:
                with np.load(path) as data:
                    held[int(data["step"])] = path
            except Exception:  # missing, cut short, not a checkpoint: not held
                continue
        return held

    def exists(self) -> bool:
        """Collective: whether every rank holds a checkpoint of one step (kept in :attr:`step`).

        Raises :class:`InputError` if some ranks hold checkpoint files and no step is common
        to all (written by another number of ranks).
        """
        held = allgathered(self.comm, sorted(self._held()))
        some = [rank for rank, steps in enumerate(held) if steps]
        common = set.intersection(*(set(steps) for steps in held))
        self.step = max(common) if common else None
        if some and not common:
            raise InputError(
                f"resume: {str(self.directory)!r} holds checkpoint files of rank(s) {some} but "
                f"no step that all {self.comm.size} ranks saved (written by another number of "
                "ranks?); run with as many ranks as wrote them, or start a new output directory"
            )
        return self.step is not None

    def write(self, arrays: dict[str, np.ndarray], history: list[dict]) -> None:
        """Rank-local: this rank's arrays (rank 0: and ``history``) to its pending file.

        Raises :class:`~dd_contact.errors.OutputError` (the pending file removed).
        """
        arrays = {**arrays, "ranks": np.array(self.comm.size)}
        if self.comm.rank == ROOT:
            arrays["history"] = np.frombuffer(json.dumps(history).encode(), dtype=np.uint8)
        what = f"the checkpoint of step {int(arrays['step'])} ({self.pending.name})"
        try:
            make_durable(what=what)  # the steps it says are done are on the disk before it
            with open(self.pending, "wb") as f:
                np.savez(f, **arrays)  # type: ignore[arg-type]
                f.flush()
                os.fsync(f.fileno())
        except BaseException as error:
            self.discard()
            if isinstance(error, OutputError):
                raise
            if isinstance(error, OSError):
                raise failure(error, what, self.directory) from error
            raise

    def discard(self) -> None:
        """Rank-local: remove the pending file (a write failed on some rank)."""
        self.pending.unlink(missing_ok=True)

    def commit(self) -> None:
        """Rank-local, once every rank wrote: the pending file becomes the checkpoint."""
        if self.path.exists():
            os.replace(self.path, self.previous)
        os.replace(self.pending, self.path)
        try:  # rank-local, after every rank wrote: a late error here must not split the ranks
            make_durable(self.directory, what="the checkpoint's renames")
        except OutputError as error:
            logger.warning("%s (a crash of the machine may keep the previous checkpoint)", error)

    def load(self) -> tuple[dict[str, np.ndarray], list[dict] | None]:
        """Collective: this rank's arrays at :attr:`step` and the history on every rank.

        The history is ``None`` in a checkpoint of an earlier version (``history.json`` has
        it). Files of later steps, which not every rank saved, are removed, saying so.
        """
        held = self._held()
        assert self.step is not None and self.step in held  # found by exists()
        path = held[self.step]
        with np.load(path) as data:
            state = {k: data[k] for k in data.files}
        for step, other in held.items():
            if step > self.step:
                other.unlink()
                logger.warning(
                    "%s: step %d, which not every rank saved: removed (resuming from step %d)",
                    other,
                    step,
                    self.step,
                )
        if path != self.path:
            if self.path.exists() and self.path not in held.values():
                set_aside(self.path, "it cannot be read")
            elif self.path.exists():
                os.replace(self.path, self.previous)
            os.replace(path, self.path)
        self.discard()
        ranks = int(state.pop("ranks", self.comm.size))
        if ranks != self.comm.size:
            raise InputError(
                f"resume: the checkpoint in {str(self.directory)!r} was written by {ranks} "
                f"rank(s), this run has {self.comm.size}; run with mpiexec -n {ranks}, or "
                "start a new output directory"
            )
        history = state.pop("history", None)
        text = None if history is None else bytes(history).decode()
        text = bcast_from_root(self.comm, text)
        return state, None if text is None else json.loads(text)


def _copy_into(targets: dict, state, mismatch: Callable[[str], str]) -> None:
    """Each target array filled from the checkpoint's array of its key.

    A key the checkpoint lacks, or holds in another shape, is refused (``mismatch`` says
    why, from the key).
    """
    for key, target in targets.items():
        if key not in state or state[key].shape != target.shape:
            raise InputError(f"resume: {mismatch(key)}; start a new output directory")
        target[:] = state[key]
