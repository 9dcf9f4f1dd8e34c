"""Time-integration schemes: Newmark's trapezoidal rule and generalized-alpha.

Both solve one linear system a step whose matrix is ``c M + K``, so every algorithm
factorises it as in statics (only the coefficient ``c`` differs). Written in equilibrium
form, the forces at ``t_n`` come from the state at ``t_n`` (``dd_contact.impact``)::

    (c M + K) u_{n+1} = M h(u_n, u'_n, u''_n) + r_{n+1} + w (r_n - K x_n + f_C(x_n))

``w`` is the weight of the start-of-step forces relative to the end ones.

**Trapezoidal rule** (beta = 1/4, gamma = 1/2; eqs. A10-A11): ``c = 4 / dt^2``,
``h = c u + (4 / dt) u'``, ``w = 1`` (forces weighted 1/2 and 1/2), and
``u'_{n+1} = 2 (u_{n+1} - u_n) / dt - u'_n``. Unconditionally stable; for a linear system
it conserves energy exactly and needs no acceleration.

**Generalized-alpha** (Chung and Hulbert 1993): the balance holds at
``t_{n+1-alpha}``: ``M [(1 - a_m) u''_{n+1} + a_m u''_n] + K [(1 - a_f) u_{n+1} + a_f u_n]
= (1 - a_f) r_{n+1} + a_f r_n`` with Newmark's updates, ``a_m = (2 rho - 1) / (rho + 1)``,
``a_f = rho / (rho + 1)``, ``gamma = 1/2 - a_m + a_f``, ``beta = (1 - a_m + a_f)^2 / 4``
(``rho``: the spectral radius as ``dt / period -> infinity``, in [0, 1]). Divided by
``1 - a_f``: ``c = (1 - a_m) / (beta dt^2 (1 - a_f))``, ``w = a_f / (1 - a_f)`` and
``h = c (u + dt u' + dt^2 (1/2 - beta) u'') - a_m / (1 - a_f) u''``. Second order,
unconditionally stable, damping the modes whose period is short against dt (1 - rho at
the limit) and barely the resolved ones; ``rho = 1`` is the trapezoidal rule. The
acceleration is a state of the scheme (carried from step to step).

Quasi-static load stepping is the same loop without the mass terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dd_contact.errors import InputError

__all__ = ["DEFAULT_RHO_INFINITY", "SCHEMES", "GeneralizedAlpha", "Newmark", "time_scheme"]

#: The schemes of ``TransientProblem(scheme=...)``.
SCHEMES = ("trapezoidal", "generalized-alpha")

#: generalized-alpha's rho_infinity when none is given.
DEFAULT_RHO_INFINITY = 0.8


def _check_dt(dt: float) -> None:
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"time step dt must be a positive finite number, got {dt}")


@dataclass(frozen=True)
class Newmark:
    """Coefficients and updates of the trapezoidal rule for a time step ``dt``."""

    dt: float
    #: Weight of the start-of-step forces against the end ones.
    start_weight = 1.0
    #: Whether a linear system keeps its energy exactly (checked step by step).
    conserves_energy = True

    def __post_init__(self):
        _check_dt(self.dt)

    @property
    def mass_coefficient(self) -> float:
        """a0 = 4 / dt^2, the mass factor of the effective matrix (A10)."""
        return 4.0 / self.dt**2

    @property
    def end_slope(self) -> float:
        """The derivative of :meth:`end_acceleration` in ``u_new``: 4 / dt^2."""
        return self.mass_coefficient

    def end_acceleration(
        self, u_new: np.ndarray, u: np.ndarray, velocity: np.ndarray, end: np.ndarray
    ) -> np.ndarray:
        """The rule's acceleration at t + dt, ``4 (u_new - u) / dt^2 - 4 u' / dt - u''_n``.

        Not the reported one (:meth:`update`'s mean): the trapezoidal rule holds
        ``M u''_n+1 = r_n+1 - K u_n+1`` at each step's end when it held at the start, so a
        reduced wall's settle balances this inertia (``end``: its value at t_n, carried).
        """
        out = np.subtract(u_new, u)
        out *= self.mass_coefficient
        out -= (4.0 / self.dt) * velocity
        out -= end
        return out

    def history(self, u: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """The vector that multiplies M on the right-hand side: a0 u + a1 u'."""
        history = np.multiply(u, self.mass_coefficient)  # in place from here: no temporaries
        history += (4.0 / self.dt) * velocity
        return history

    def update(
        self, u_new: np.ndarray, u: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Velocity at t + dt, and the step's mean acceleration (reported, not reused)."""
        velocity_new = np.subtract(u_new, u)  # in place from here: no temporaries
        velocity_new *= 2.0 / self.dt
        velocity_new -= velocity
        acceleration = np.subtract(velocity_new, velocity)
        acceleration /= self.dt
        return velocity_new, acceleration


@dataclass(frozen=True)
class GeneralizedAlpha:
    """Coefficients and updates of Chung and Hulbert's generalized-alpha scheme."""

    dt: float
    rho_infinity: float
    conserves_energy = False

    def __post_init__(self):
        _check_dt(self.dt)
        rho = self.rho_infinity
        if isinstance(rho, bool) or not isinstance(rho, int | float) or not 0 <= rho <= 1:
            raise InputError(
                f"rho_infinity must be a number in [0, 1] (1: no numerical damping, the "
                f"trapezoidal rule; 0: the most), got {rho!r}"
            )

    @property
    def alpha_m(self) -> float:
        """a_m = (2 rho - 1) / (rho + 1): the weight of u''_n in the inertia."""
        return (2.0 * self.rho_infinity - 1.0) / (self.rho_infinity + 1.0)

    @property
    def alpha_f(self) -> float:
        """a_f = rho / (rho + 1): the weight of the forces at t_n."""
        return self.rho_infinity / (self.rho_infinity + 1.0)

    @property
    def gamma(self) -> float:
        """Newmark's gamma = 1/2 - a_m + a_f."""
        return 0.5 - self.alpha_m + self.alpha_f

    @property
    def beta(self) -> float:
        """Newmark's beta = (1 - a_m + a_f)^2 / 4."""
        return 0.25 * (1.0 - self.alpha_m + self.alpha_f) ** 2

    @property
    def start_weight(self) -> float:
        """alpha_f / (1 - alpha_f): the forces at t_n against those at t_n+1."""
        return self.alpha_f / (1.0 - self.alpha_f)

    @property
    def mass_coefficient(self) -> float:
        """(1 - alpha_m) / (beta dt^2 (1 - alpha_f)): effective matrix c M + K."""
        return (1.0 - self.alpha_m) / (self.beta * self.dt**2 * (1.0 - self.alpha_f))

    @property
    def end_slope(self) -> float:
        """The derivative of :meth:`end_acceleration` in ``u_new``: 1 / (beta dt^2)."""
        return 1.0 / (self.beta * self.dt**2)

    def end_acceleration(
        self, u_new: np.ndarray, u: np.ndarray, velocity: np.ndarray, end: np.ndarray
    ) -> np.ndarray:
        """Newmark's acceleration at t + dt (the scheme's own state: :meth:`update`'s)."""
        return self.update(u_new, u, velocity, end)[1]

    def history(self, u: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """The vector that multiplies M on the right-hand side.

        ``c (u + dt u' + dt^2 (1/2 - beta) u'') - a_m u'' / (1 - a_f)``, the acceleration's
        two terms summed in one coefficient (exactly 0 at rho = 1).
        """
        am, af, beta = self.alpha_m, self.alpha_f, self.beta
        c = self.mass_coefficient
        inertia = ((1.0 - am) * (0.5 - beta) / beta - am) / (1.0 - af)
        history = np.multiply(u, c)  # the sum in place, left to right
        history += (c * self.dt) * velocity
        history += inertia * acceleration
        return history

    def update(
        self, u_new: np.ndarray, u: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Velocity and acceleration at t + dt (Newmark's updates, solved for them)."""
        dt, beta, gamma = self.dt, self.beta, self.gamma
        du = u_new - u
        # the sums in place, left to right
        velocity_new = np.multiply(du, gamma / (beta * dt))
        velocity_new += (1.0 - gamma / beta) * velocity
        velocity_new += (dt * (1.0 - gamma / (2.0 * beta))) * acceleration
        acceleration_new = np.divide(du, beta * dt * dt)
        acceleration_new -= velocity / (beta * dt)
        acceleration_new -= (0.5 / beta - 1.0) * acceleration
        return velocity_new, acceleration_new


def time_scheme(scheme: str, dt: float, rho_infinity: float | None) -> Newmark | GeneralizedAlpha:
    """The scheme named ``scheme`` for step ``dt`` (``rho_infinity``: generalized-alpha's)."""
    if scheme == "trapezoidal":
        if rho_infinity is not None and rho_infinity != 1:
            raise InputError(
                f"rho_infinity={rho_infinity!r} is a parameter of scheme='generalized-alpha'; "
                "the trapezoidal rule has no numerical damping (rho_infinity = 1)"
            )
        return Newmark(dt)
    if scheme == "generalized-alpha":
        return GeneralizedAlpha(dt, DEFAULT_RHO_INFINITY if rho_infinity is None else rho_infinity)
    raise InputError(
        f"unknown time-integration scheme {scheme!r}; valid: {', '.join(map(repr, SCHEMES))}"
    )
