"""A run stopped cleanly: SIGTERM and SIGUSR1 end it at the next step boundary.

A cluster's scheduler sends SIGTERM at the wall-time limit (SIGUSR1 as an early warning,
where configured), then SIGKILL a little later. :class:`StopRequests` catches both signals
while a run steps (instead of the default action, or PETSc's handler, which aborts the
process mid-write) and notes the request; the run then checkpoints, closes its files and
raises :class:`~dd_contact.errors.RunStopped` with a line saying how to resume.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import Any

from mpi4py import MPI

from dd_contact.errors import RunStopped
from dd_contact.parallel import any_rank

__all__ = ["STOP_SIGNALS", "StopRequests", "raise_stopped"]

#: The signals that stop a run at the next step boundary.
STOP_SIGNALS = (signal.SIGTERM, signal.SIGUSR1)


class StopRequests:
    """Context manager: catch :data:`STOP_SIGNALS` while a run steps; restore after.

    Only the main thread can install signal handlers: elsewhere nothing is caught (the
    signals keep their usual action).
    """

    def __init__(self):
        #: The last stop signal received (``None``: none).
        self.signum: int | None = None
        #: What ``signal.signal`` returned per signal: a handler, an int, or ``None``.
        self._previous: dict[
            int, Callable[[int, FrameType | None], Any] | int | signal.Handlers | None
        ] = {}

    def _note(self, signum: int, frame: FrameType | None) -> None:
        self.signum = signum

    def __enter__(self) -> StopRequests:
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                self._previous[signum] = signal.signal(signum, self._note)
        return self

    def __exit__(self, *exc) -> None:
        for signum, previous in self._previous.items():
            # a handler installed outside Python (PETSc's) cannot be put back: the default
            signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
        self._previous.clear()

    def requested(self, comm: MPI.Comm) -> int | None:
        """Collective: the signal that stops the run on every rank, if some rank got one."""
        if not any_rank(comm, self.signum is not None):
            return None
        return self.signum or signal.SIGTERM  # a rank that got none stops with the others


def raise_stopped(comm: MPI.Comm, signum: int, step: int, t: float, output) -> None:
    """Say how the run stopped at ``step`` resumes (on rank 0), and raise RunStopped."""
    name = signal.Signals(signum).name
    if output is None:
        how = "nothing was saved: give run(output=...) to be able to resume"
    else:
        how = f"checkpoint in {str(output)!r}: run again with resume=True to continue"
    if comm.rank == 0:
        print(f"run stopped by {name} at step {step} (t = {t:.6g}); {how}", file=sys.stderr)
        sys.stderr.flush()
    raise RunStopped(128 + signum)
