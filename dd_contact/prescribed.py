"""Prescribed displacements of a subdomain (its Dirichlet conditions), fixed or changing in time.

The prescribed dofs never change: they are eliminated from the matrices once, when a problem
is built. Their values may change: a value given as a callable ``(x, t)`` is evaluated at
every solve time, and a dolfinx ``DirichletBC`` is read again at every solve, so a
``Constant`` or ``Function`` the user updates between solves takes effect. A new value is a
new right-hand side (:class:`dd_contact.assembly.Lifting`), never a new factorisation.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import dolfinx.fem as fem
import numpy as np

from dd_contact import arguments
from dd_contact.errors import InputError

__all__ = ["Prescribed", "Value"]

#: A prescribed value: a 3-vector, a callable ``x -> (3, n)`` (fixed), or a callable
#: ``(x, t) -> (3, n)`` or ``(x, t) -> 3-vector`` evaluated at every solve time.
Value = (
    Sequence[float]
    | Callable[[np.ndarray], np.ndarray]
    | Callable[[np.ndarray, float], np.ndarray | Sequence[float]]
)


@dataclass(frozen=True)
class _Condition:
    """Dofs (unrolled, 3 per node) and their values at a time; ``changing`` if they may vary."""

    dofs: np.ndarray
    values: Callable[[float], np.ndarray]
    changing: bool


def _positional_arguments(function: Callable) -> int:
    """How many positional arguments a callable requires (1 when it cannot be inspected)."""
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):  # some builtins and extension functions
        return 1
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return sum(p.kind in kinds and p.default is inspect.Parameter.empty for p in parameters)


class Prescribed:
    """The Dirichlet conditions of one subdomain, in the order given (a later one wins).

    Args:
        V: The subdomain's vector function space.
        what: How messages name the subdomain, e.g. ``"subdomain 'left'"``.
    """

    def __init__(self, V: fem.FunctionSpace, what: str):
        self._V, self._what = V, what
        self._conditions: list[_Condition] = []
        self._union: tuple[np.ndarray, np.ndarray] | None = None

    def add_nodes(self, nodes: np.ndarray, components: Sequence[int], value, t: float) -> None:
        """Prescribe ``components`` of the (owned) nodes ``nodes`` to ``value``.

        ``value`` is ``None`` (zero), a 3-vector, a callable ``x -> (3, n)`` evaluated now,
        or a callable ``(x, t)`` evaluated at every solve time (checked now at ``t``).
        """
        what = f"{self._what} fix(value=...): prescribed displacement"
        x = self._V.tabulate_dof_coordinates()[nodes].T
        n = len(nodes)
        if value is None or not callable(value):
            fixed = np.zeros(3) if value is None else arguments.vector(value, what)
            at = _constant(np.tile(fixed.reshape(3, 1), (1, n)))
            changing = False
        elif _positional_arguments(value) == 1:
            at = _constant(_checked(value(x), n, what, "x"))
            changing = False
        elif _positional_arguments(value) == 2:
            last: dict[float, np.ndarray] = {}  # one call per time for all components

            def at(t: float, value=value, last=last) -> np.ndarray:
                if t not in last:
                    last.clear()
                    last[t] = _checked(value(x, t), n, f"{what} at t = {t}", "x, t")
                return last[t]

            changing = True
        else:
            raise InputError(
                f"{what}: a callable value takes x (an array of shape (3, n)) or x and the "
                f"time t, got one with {_positional_arguments(value)} required arguments; "
                "for a value of time alone write lambda x, t: (0.0, 0.0, -d(t))"
            )
        at(t)  # a malformed value is refused now, not at the first solve
        for c in components:
            dofs = (3 * nodes + c).astype(np.int32)
            # mypy infers no lambda with default arguments for a Callable[[float], ...]
            self._add(
                _Condition(dofs, lambda t, at=at, c=c: at(t)[c], changing)  # type: ignore[misc]
            )

    def add_dirichletbcs(self, bcs: Sequence[fem.DirichletBC]) -> None:
        """The dofs of dolfinx DirichletBCs on V (or ``V.sub(i)``); values read at every solve."""
        num_owned = self._V.dofmap.index_map.size_local * 3
        for i, bc in enumerate(bcs):
            what = f"{self._what}: fix DirichletBC {i}"
            arguments.instance(bc, fem.DirichletBC, what)
            if not self._V._cpp_object.contains(bc.function_space):
                raise InputError(
                    f"{what} is built on another function space; build it on this subdomain's "
                    "V (or V.sub(i)), e.g. dirichletbc(value, locate_dofs_topological(sub.V, "
                    "2, facets), sub.V)"
                )
            dofs = bc.dof_indices()[0]
            dofs = dofs[dofs < num_owned].astype(np.int32)

            def read(t: float, bc=bc, dofs=dofs, what=what) -> np.ndarray:
                values = np.zeros(num_owned)
                bc.set(values)
                arguments.finite(values[dofs], f"{what} values")
                return values[dofs]

            read(0.0)
            self._add(_Condition(dofs, read, True))

    def _add(self, condition: _Condition) -> None:
        self._conditions.append(condition)
        self._union = None

    @property
    def changing(self) -> bool:
        """Whether some value may differ from one solve to the next."""
        return any(c.changing for c in self._conditions)

    @property
    def dofs(self) -> np.ndarray:
        """The prescribed dofs (unrolled, 3 per node), sorted."""
        return self._merged()[0]

    def values(self, t: float) -> np.ndarray:
        """The values of :attr:`dofs` at time ``t`` (where conditions overlap, the latest)."""
        if not self._conditions:
            return np.zeros(0)
        _, first = self._merged()
        values = np.concatenate([c.values(t) for c in self._conditions])
        return values[::-1][first]

    def _merged(self) -> tuple[np.ndarray, np.ndarray]:
        """Sorted unique dofs, and where each one's latest value sits in the reversed values."""
        if self._union is None:
            if not self._conditions:
                self._union = (np.zeros(0, np.int32), np.zeros(0, np.int64))
            else:
                dofs = np.concatenate([c.dofs for c in self._conditions])
                # np.unique keeps the first occurrence: reversed, the latest condition wins.
                unique, first = np.unique(dofs[::-1], return_index=True)
                self._union = (unique.astype(np.int32), first)
        return self._union


def _constant(values: np.ndarray) -> Callable[[float], np.ndarray]:
    return lambda t: values


def _checked(values, n: int, what: str, takes: str) -> np.ndarray:
    """A callable's values as a (3, n) array: (3, n) as returned, or a 3-vector for all."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is not None and array.shape == (3,):
        array = np.tile(array.reshape(3, 1), (1, n))
    if array is None or array.shape != (3, n):
        shape = "no array" if array is None else f"shape {array.shape}"
        raise InputError(
            f"{what}: the callable of ({takes}) must return a (3, n) array for the n = {n} "
            f"points x of shape (3, n) (or a 3-vector for all of them), got {shape}"
        )
    arguments.finite(array, what)
    return array
