"""Rigid obstacles: the gap s and contact normal n of eqs. (4)-(5) at any point and time.

Every obstacle answers one question: for points ``x`` of the undeformed body at time ``t``,
how far is the obstacle (the gap ``s``, positive when apart) and along which direction
``n`` would the body have to move to reach it (the body's outward contact normal). The
contact condition is then ``w . n - s <= 0`` (small displacements: s and n are evaluated at
the undeformed points, as in the paper).

An obstacle may move: ``motion(t)`` is a prescribed rigid translation of the obstacle.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from dd_contact.errors import InputError

__all__ = ["Cylinder", "Obstacle", "Plane", "Sphere", "UserObstacle"]

Motion = Callable[[float], Sequence[float]]


def _unit(vector: Sequence[float], what: str) -> np.ndarray:
    v = np.asarray(vector, dtype=float).reshape(3)
    norm = np.linalg.norm(v)
    if not (np.all(np.isfinite(v)) and norm > 0):
        raise InputError(f"{what} must be a non-zero finite 3-vector, got {vector}")
    return v / norm


def _positive(value: float, what: str) -> float:
    if not (np.isfinite(value) and value > 0):
        raise InputError(f"{what} must be positive, got {value}")
    return float(value)


class Obstacle:
    """A rigid obstacle. Subclasses implement :meth:`_gap_normal` at rest.

    Args:
        motion: Optional prescribed translation of the obstacle, ``t -> (3,)``.
    """

    def __init__(self, motion: Motion | None = None):
        self.motion = motion

    @property
    def at_rest(self) -> bool:
        """Whether gap and normals at given points are the same at every time.

        A built-in obstacle without a motion (its :meth:`_gap_normal` is the obstacle at
        rest); a motion given later, or a ``gap_normal`` of its own (``UserObstacle``), is not.
        """
        return self.motion is None and type(self).gap_normal is Obstacle.gap_normal

    @property
    def fixed_normals(self) -> bool:
        """Whether the normals at given points never change with time.

        Then a contact state change is known point by point (the contact operator's point
        rows stay the same). At rest at least.
        """
        return self.at_rest

    def _offset(self, t: float) -> np.ndarray:
        if self.motion is None:
            return np.zeros(3)
        d = np.asarray(self.motion(t), dtype=float).reshape(3)
        if not np.all(np.isfinite(d)):
            raise InputError(f"obstacle motion at t = {t} is not finite: {d}")
        return d

    def gap_normal(
        self, x: npt.NDArray[np.float64], t: float = 0.0
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Gap ``s`` (shape ``(n,)``) and body contact normal ``n`` (``(n, 3)``) at points."""
        # A translated obstacle seen from x is the obstacle at rest seen from x - offset.
        s, n = self._gap_normal(np.asarray(x, dtype=float) - self._offset(t))
        return np.asarray(s, dtype=float), np.asarray(n, dtype=float)

    def _gap_normal(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError


class Plane(Obstacle):
    """A rigid wall: the half-space behind a plane.

    Args:
        point: A point on the wall's surface.
        normal: The wall's surface normal, pointing out of the wall towards the body.
        motion: Optional translation ``t -> (3,)``.
    """

    def __init__(self, point: Sequence[float], normal: Sequence[float], motion=None):
        super().__init__(motion)
        self.point = np.asarray(point, dtype=float).reshape(3)
        self.normal = _unit(normal, "Plane normal")

    @property
    def fixed_normals(self) -> bool:  # noqa: D102 (a translated wall keeps its normal)
        return True

    def _gap_normal(self, x):
        s = (x - self.point) @ self.normal
        return s, np.broadcast_to(-self.normal, x.shape)


class Sphere(Obstacle):
    """A rigid ball; the body lies outside it.

    Args:
        centre: Centre of the ball.
        radius: Its radius.
        motion: Optional translation ``t -> (3,)``.
    """

    def __init__(self, centre: Sequence[float], radius: float, motion=None):
        super().__init__(motion)
        self.centre = np.asarray(centre, dtype=float).reshape(3)
        self.radius = _positive(radius, "Sphere radius")

    def _gap_normal(self, x):
        d = x - self.centre
        r = np.linalg.norm(d, axis=1)
        return r - self.radius, -d / np.maximum(r, 1e-300)[:, None]


class Cylinder(Obstacle):
    """A rigid pin (infinite circular cylinder); the body lies around it, as a plate's hole.

    Args:
        point: A point on the pin's axis.
        axis: Direction of the axis.
        radius: Pin radius.
        motion: Optional translation ``t -> (3,)``.
    """

    def __init__(self, point: Sequence[float], axis: Sequence[float], radius: float, motion=None):
        super().__init__(motion)
        self.point = np.asarray(point, dtype=float).reshape(3)
        self.axis = _unit(axis, "Cylinder axis")
        self.radius = _positive(radius, "Cylinder radius")

    def _gap_normal(self, x):
        d = x - self.point
        radial = d - np.outer(d @ self.axis, self.axis)
        r = np.linalg.norm(radial, axis=1)
        return r - self.radius, -radial / np.maximum(r, 1e-300)[:, None]


class UserObstacle(Obstacle):
    """An obstacle given by two callables.

    Args:
        gap: ``(x, t) -> s`` with ``x`` of shape ``(n, 3)``; positive when apart.
        normal: ``(x, t) -> n`` of shape ``(n, 3)``: the unit direction along which the body
            approaches the obstacle (the body's outward contact normal).
    """

    def __init__(self, gap: Callable, normal: Callable):
        super().__init__(None)
        self.gap, self.normal = gap, normal

    def gap_normal(self, x, t=0.0):  # noqa: D102
        x = np.asarray(x, dtype=float)
        s = np.asarray(self.gap(x, t), dtype=float).reshape(len(x))
        n = np.asarray(self.normal(x, t), dtype=float).reshape(len(x), 3)
        length = np.linalg.norm(n, axis=1)
        if not np.all(np.isfinite(s)) or not np.all(np.isfinite(n)):
            raise InputError(f"UserObstacle: gap or normal is NaN/inf at t = {t}")
        if np.any(np.abs(length - 1.0) > 1e-6):
            raise InputError(
                "UserObstacle: the normal callable must return unit vectors (worst length "
                f"{length[np.argmax(np.abs(length - 1))]:.6g}); normalise it"
            )
        return s, n
