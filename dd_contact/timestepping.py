"""Newmark's trapezoidal rule (beta = 1/4, gamma = 1/2), eqs. (A10)-(A11).

With ``a0 = 4 / dt^2`` and ``a1 = 4 / dt`` the step from t to t + dt solves::

    (a0 M + K) u_new = M (a0 u + a1 u' + u'') + r(t + dt)                      (A10, A11)

with ``M u'' = r(t) - K u`` (+ contact): written with the start-of-step forces computed
from the state at t rather than carried in u'' (``dd_contact.impact``, which also keeps the
contact from creating energy), it is::

    (a0 M + K) u_new = M (a0 u + a1 u') + r(t) + r(t + dt) - K x(t) + f_C(t)

and ``u'_new = 2 (u_new - u) / dt - u'``. The rule is unconditionally stable and, for a linear
system, conserves energy exactly. Quasi-static load stepping is the same loop without the
mass terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dd_contact.errors import InputError

__all__ = ["Newmark"]


@dataclass(frozen=True)
class Newmark:
    """Coefficients and updates of the trapezoidal rule for a time step ``dt``."""

    dt: float

    def __post_init__(self):
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"time step dt must be a positive finite number, got {self.dt}")

    @property
    def mass_coefficient(self) -> float:
        """a0 = 4 / dt^2, the mass factor of the effective matrix (A10)."""
        return 4.0 / self.dt**2

    def history(self, u: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """The vector that multiplies M on the right-hand side: a0 u + a1 u'."""
        return self.mass_coefficient * u + (4.0 / self.dt) * velocity

    def update(
        self, u_new: np.ndarray, u: np.ndarray, velocity: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Velocity at t + dt, and the step's mean acceleration (reported, not reused)."""
        velocity_new = (2.0 / self.dt) * (u_new - u) - velocity
        return velocity_new, (velocity_new - velocity) / self.dt
