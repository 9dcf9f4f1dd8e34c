"""The state of a transient run as arrays: what a checkpoint holds and how a run resumes.

A run's state is the owned subdomains' displacement, velocity and acceleration, the
interface's and the owned contact surfaces' displacement (massless, but the next step's
start forces read their tie forces at t_n), the contact iteration's active sets and counts,
and the step, time and integration settings (which a resumed run must share). Files are
:mod:`dd_contact.io`'s.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dd_contact.assembly import ContactZone
from dd_contact.errors import InputError
from dd_contact.iteration import ContactIteration
from dd_contact.subdomains import Subdomain

__all__ = ["RunState"]

#: The fields of a subdomain a checkpoint holds.
KINEMATICS = ("u", "velocity", "acceleration")


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

    def _surfaces(self) -> dict[str, np.ndarray]:
        """The surfaces' displacement arrays by checkpoint key (written in place)."""
        out = {f"w/{z.contact.name}": z.contact.w.x.array for z in self.zones}
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
        for sub in self.owned:
            for name in KINEMATICS:
                state[f"{name}/{sub.name}"] = getattr(sub, name).x.array
        for z in self.zones:
            name = z.contact.name
            state[f"active/{name}"] = it.active[name]
            state[f"alpha/{name}"] = np.array(it.alpha[name])
            state[f"releases/{name}"] = np.array(it.releases[name])
        state.update(self._surfaces())
        return state

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
        for sub in self.owned:
            for name in KINEMATICS:
                key = f"{name}/{sub.name}"
                target = getattr(sub, name).x.array
                if key not in state or state[key].shape != target.shape:
                    raise InputError(
                        f"resume: the checkpoint does not match subdomain {sub.name!r} "
                        "(different scene or mesh); start a new output directory"
                    )
                target[:] = state[key]
        for key, target in self._surfaces().items():
            if key not in state or state[key].shape != target.shape:
                raise InputError(
                    f"resume: the checkpoint holds no {key.split('/')[1]!r} surface of this "
                    "shape (a different scene, or a checkpoint of an earlier version without "
                    "the surfaces' state); start a new output directory"
                )
            target[:] = state[key]
        it = self.iteration
        it.gamma = int(state["gamma"])
        for z in self.zones:
            name = z.contact.name
            it.active[name] = state[f"active/{name}"]
            it.alpha[name] = int(state[f"alpha/{name}"])
            key = f"releases/{name}"  # absent in checkpoints written before the count
            it.releases[name] = int(state[key]) if key in state else 0
        it.release_solves = int(state.get("release_solves", 0))
        return int(state["step"]), float(state["t"])
