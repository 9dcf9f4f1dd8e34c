"""The arguments of the public scene API, read and checked in one place.

Each reader returns the value in the form the package uses, or raises an
:class:`~dd_contact.errors.InputError` that names the argument, says what is wrong and what
to give instead: a malformed argument never surfaces as a TypeError, IndexError or UFL
shape error from deep inside dolfinx.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Sequence
from typing import Any

import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from dd_contact.errors import InputError

__all__ = [
    "Region",
    "boundary_facets",
    "components",
    "finite",
    "instance",
    "is_real",
    "name",
    "one_rank_mesh",
    "positive_int",
    "real",
    "tolerance",
    "ufl_vector",
    "vector",
]

#: A region of a mesh's boundary: a locator ``x -> bool`` (all vertices of a facet must
#: satisfy it), facet indices, a facet MeshTags (all its facets), or ``(meshtags, value)``.
Region = (
    Callable[[np.ndarray], np.ndarray]
    | npt.NDArray[np.int32]
    | dolfinx.mesh.MeshTags
    | tuple[dolfinx.mesh.MeshTags, int]
)


def _describe(value: Any) -> str:
    text = repr(value)
    return f"{text[:60]}... ({type(value).__name__})" if len(text) > 60 else f"{text}"


def is_real(value: Any) -> bool:
    """Whether ``value`` is a real number (a Python or numpy int or float, not a bool)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def real(value: Any, argument: str) -> float:
    """A finite real number (not a string, not a bool)."""
    if not is_real(value):
        raise InputError(
            f"{argument} must be a real number, got {_describe(value)} of type "
            f"{type(value).__name__}; pass e.g. 210e9, not '210e9'"
        )
    if not np.isfinite(value):
        raise InputError(f"{argument} must be finite, got {value}")
    return float(value)


def friction(value: Any, what: str, pair_side: bool) -> float:
    """A Coulomb coefficient: a finite number >= 0 (0: frictionless)."""
    if not (is_real(value) and np.isfinite(value) and value >= 0):
        raise InputError(
            f"{what}: friction must be a finite number >= 0 (the Coulomb coefficient mu; "
            f"0 for frictionless contact), got {_describe(value)}"
        )
    if value > 0 and pair_side:
        raise InputError(
            f"{what}: a side of a ContactPair has no friction of its own: friction between "
            "two bodies is the pair's, give it there (ContactPair(a, b, friction=mu))"
        )
    return float(value)


def pair_friction(value: Any, what: str, points: str, unbiased: bool) -> float:
    """A pair's Coulomb coefficient, on the scheme friction is built for (nodes, one way)."""
    mu = friction(value, what, False)
    if mu > 0 and (points != "nodes" or unbiased):
        scheme = "unbiased=True" if unbiased else f"points={points!r}"
        raise InputError(
            f"{what}: friction with {scheme} is not supported: those points carry more "
            "conditions than the surfaces have dofs, their pressures and tangential tractions "
            "scatter point to point and the stick/slip iteration does not settle; use the "
            "default points='nodes', unbiased=False with friction (docs/contact.md, 'Friction')"
        )
    return mu


def choice(value: Any, allowed: Sequence[str], argument: str) -> None:
    """One of ``allowed``."""
    if value not in allowed:
        raise InputError(f"{argument} must be one of {tuple(allowed)}, got {value!r}")


def positive_int(value: Any, argument: str) -> int:
    """An integer >= 1 (a count)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise InputError(f"{argument} must be a positive integer, got {_describe(value)}")
    return int(value)


def vector(value: Any, argument: str, length: int = 3) -> np.ndarray:
    """``length`` finite real numbers, as a float array."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != (length,):
        shape = "?" if array is None else array.shape
        raise InputError(
            f"{argument} must be {length} real numbers (x, y, z), got {_describe(value)} "
            f"(shape {shape})"
        )
    if not np.all(np.isfinite(array)):
        raise InputError(f"{argument} contains NaN or inf ({array}); give finite values")
    return array


def ufl_vector(expr: ufl.core.expr.Expr, argument: str) -> ufl.core.expr.Expr:
    """A UFL expression with 3 components."""
    if expr.ufl_shape != (3,):
        raise InputError(
            f"{argument} must be a UFL vector with 3 components, got shape {expr.ufl_shape}; "
            "build it with ufl.as_vector([fx, fy, fz])"
        )
    return expr


def components(value: Sequence[int] | None, argument: str) -> list[int]:
    """Displacement components: distinct integers among 0, 1, 2 (``None``: all three)."""
    if value is None:
        return [0, 1, 2]
    picked = list(value) if isinstance(value, Sequence | np.ndarray) else [value]
    if not picked or any(
        isinstance(c, bool) or not isinstance(c, numbers.Integral) or c not in (0, 1, 2)
        for c in picked
    ):
        raise InputError(
            f"{argument} must list components among 0 (x), 1 (y), 2 (z), got {value!r}"
        )
    if len(set(picked)) != len(picked):
        raise InputError(f"{argument} lists a component twice: {value!r}")
    return [int(c) for c in picked]


def finite(values: np.ndarray, argument: str) -> None:
    """No NaN or inf in ``values``."""
    if not np.all(np.isfinite(values)):
        raise InputError(f"{argument} contains NaN or inf; check the data that defines it")


def instance(value: Any, cls: type | tuple[type, ...], argument: str) -> None:
    """``value`` is a ``cls`` (or one of a tuple of classes)."""
    if not isinstance(value, cls):
        names = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        raise InputError(f"{argument}: expected {names}, got {type(value).__name__}")


def name(value: Any, what: str) -> None:
    """A name for messages and output: a non-empty string."""
    if not isinstance(value, str) or not value:
        raise InputError(f"{what} name must be a non-empty string, got {value!r}")


def tolerance(value: Any, what: str) -> None:
    """A positive distance, or ``None``."""
    if value is not None and not real(value, f"{what}: tolerance") > 0:
        raise InputError(f"{what}: tolerance must be positive, got {value}")


def one_rank_mesh(value: Any, tdim: int, what: str, hint: str) -> None:
    """A dolfinx mesh of topological dimension ``tdim`` in 3-D, on one rank, finite nodes."""
    kind = "3-D volume mesh" if tdim == 3 else "surface mesh (topological dimension 2) in 3-D"
    if not isinstance(value, dolfinx.mesh.Mesh):
        raise InputError(f"{what}: needs a dolfinx.mesh.Mesh, got {type(value).__name__}; {hint}")
    if value.topology.dim != tdim or value.geometry.dim != 3:
        raise InputError(
            f"{what}: needs a {kind}, got topological dimension {value.topology.dim} in "
            f"{value.geometry.dim}-D; {hint}"
        )
    if value.comm.size != 1:
        raise InputError(
            f"{what}: its mesh is distributed over {value.comm.size} ranks, but every mesh of a "
            f"scene belongs to one rank; create it on MPI.COMM_SELF ({hint})"
        )
    finite(value.geometry.x, f"{what} mesh coordinates")


def boundary_facets(mesh: dolfinx.mesh.Mesh, where: Region, argument: str) -> np.ndarray:
    """The sorted boundary facets of ``mesh`` that a :data:`Region` selects (at least one)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    if isinstance(where, tuple) and len(where) == 2:
        tags, value = where
        facets = _tags(mesh, tags, argument).find(int(real(value, f"{argument} tag value")))
    elif isinstance(where, dolfinx.mesh.MeshTags):
        facets = _tags(mesh, where, argument).indices
    elif callable(where):
        facets = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, where)
    else:
        facets = _indices(mesh, where, argument)
    if facets.size == 0:
        raise InputError(
            f"{argument} selects no facet of the boundary; check it against the mesh (its bounding "
            f"box is {mesh.geometry.x.min(axis=0)} .. {mesh.geometry.x.max(axis=0)})"
        )
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    inside = np.setdiff1d(facets, exterior)
    if inside.size:
        raise InputError(
            f"{argument}: {inside.size} of its {facets.size} facets are not on the mesh's "
            f"boundary (e.g. facet {inside[0]}); a boundary region needs exterior facets"
        )
    return np.unique(facets).astype(np.int32)


def _tags(mesh: dolfinx.mesh.Mesh, tags: Any, argument: str) -> dolfinx.mesh.MeshTags:
    tdim = mesh.topology.dim
    if not isinstance(tags, dolfinx.mesh.MeshTags):
        raise InputError(
            f"{argument}: a (meshtags, value) pair needs a dolfinx MeshTags first, got "
            f"{type(tags).__name__}"
        )
    if tags.dim != tdim - 1:
        raise InputError(
            f"{argument}: the MeshTags tag entities of dimension {tags.dim}, a boundary region "
            f"needs facets (dimension {tdim - 1})"
        )
    if tags.topology is not mesh.topology._cpp_object:
        raise InputError(
            f"{argument}: the MeshTags belong to another mesh; create them on this mesh"
        )
    return tags


def _indices(mesh: dolfinx.mesh.Mesh, where: Any, argument: str) -> np.ndarray:
    facets = np.asarray(where)
    num_facets = mesh.topology.index_map(mesh.topology.dim - 1).size_local
    if facets.ndim != 1 or not (facets.size == 0 or np.issubdtype(facets.dtype, np.integer)):
        raise InputError(
            f"{argument} must be a locator x -> bool, facet indices (1-D integers), a facet "
            f"MeshTags or (meshtags, value), got {_describe(where)}"
        )
    if facets.size and (facets.min() < 0 or facets.max() >= num_facets):
        raise InputError(
            f"{argument}: facet indices must lie in 0 .. {num_facets - 1}, got "
            f"{facets.min()} .. {facets.max()}"
        )
    return facets.astype(np.int32)
