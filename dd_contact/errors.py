"""The package's exceptions and warnings (a leaf: imports nothing of the package).

Every error says what is wrong and what to change. :class:`InputError` is raised on every
rank when any rank finds bad input (:func:`dd_contact.parallel.collective`).
"""

from __future__ import annotations

import warnings
from pathlib import Path

__all__ = [
    "CoarseContactWarning",
    "CoarseTimeStepWarning",
    "ContactCycleWarning",
    "ContactIterationError",
    "EnergyGrowthWarning",
    "InaccurateSolutionError",
    "InputError",
    "OutputError",
    "PenaltyRangeWarning",
    "RunStopped",
    "SingularMatrixError",
    "SurfaceResolutionWarning",
    "warn",
]


class InputError(ValueError):
    """A scene that cannot be solved as given; the message says what to change."""


class SingularMatrixError(RuntimeError):
    """A factorisation met a singular matrix: part of the model is not held."""


class InaccurateSolutionError(SingularMatrixError):
    """A solve returned a solution that does not satisfy its system (residual check).

    A subclass of :class:`SingularMatrixError`: its usual causes are a singular matrix the
    factorisation did not flag, or one too ill-conditioned for double precision.
    """


class ContactIterationError(RuntimeError):
    """The contact iteration did not settle: it cycles or hit its iteration limit."""


class PenaltyRangeWarning(UserWarning):
    """A tie penalty lies outside the range over which the results are verified."""


class ContactCycleWarning(UserWarning):
    """The contact iteration cycled and the cycle was resolved (``on_cycle="union"``)."""


class SurfaceResolutionWarning(UserWarning):
    """A contact surface is finer than the wall it is tied to: its nodal pressure may oscillate."""


class EnergyGrowthWarning(UserWarning):
    """A time step's energy grew by more than the loads' work: the contact created energy."""


class CoarseTimeStepWarning(UserWarning):
    """A contact episode lasted too few time steps for an accurate rebound (energy is kept)."""


class CoarseContactWarning(UserWarning):
    """A contact's force was carried by too few contact points for an accurate contact."""


class OutputError(OSError):
    """A run's output could not be written (a full disk, a quota, a vanished directory).

    The message names the directory, what was being written and how to go on; ``errno`` is
    the system's (28, ``ENOSPC``, for a full disk). What was written before stays readable,
    no temporary file is left, and the last checkpoint is intact.
    """


class RunStopped(SystemExit):
    """A run ended at a step boundary by SIGTERM or SIGUSR1, its state saved.

    A :class:`SystemExit` with the exit status ``128 + signal`` (143 for SIGTERM), as a
    process killed by the signal would have: a batch script sees the run did not finish.
    """


#: The package's folder: a warning of ours is attributed to the first caller outside it.
_PACKAGE = str(Path(__file__).resolve().parent)


def warn(message: str, category: type[Warning]) -> None:
    """Warn at the user's line that led here (the first frame outside the package)."""
    warnings.warn(message, category, skip_file_prefixes=(_PACKAGE,))
