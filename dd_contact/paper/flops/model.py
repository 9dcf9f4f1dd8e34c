"""Operation-count (FLOP) model of the paper's solution algorithms.

Implements section 6 of ``method.md`` (Kim, Ryu, Shin 2007, Table 1 and Table 2): the number of
LU decompositions and single right-hand-side substitutions each algorithm performs on each mesh,
priced with four kernels (one multiply-add counts as one operation):

* ``f1(D) = D**3 / 3``                      dense factorisation,
* ``f2(D) = 1.5 * D**2``                    dense forward + back substitution,
* ``f3(D, B) = D * B**2 - (2/3) * B**3``    banded factorisation, half-bandwidth ``B``,
* ``f4(D, B) = 3 * D * B``                  banded substitution.

Notation: ``D_U``/``B_U`` dofs and half-bandwidth of a subdomain, ``D_V`` interface dofs,
``D_V^(k)`` the interface dofs tied to subdomain ``k`` (the non-zero columns of ``P_DI2^(k)``),
``D_W`` contact-interface dofs, ``N_TS`` time steps, ``alpha^(k)`` contact state changes on contact
interface ``k``, ``gamma`` contact state changes in the whole model. Matrix assembly and
matrix-matrix products (e.g. ``P^T (K^-1 P)``) are not counted, as in the paper.

Algorithms (the name lists the order in which the unknowns are obtained):

* ``"FULL"``: one banded matrix of the whole model, contact on its boundary.
* ``"v-w-u"``: condense u, then w, solve v; back-substitute w, then u (paper's Table 1).
* ``"w-v-u"``: condense u, then v, solve w; back-substitute v, then u.
* ``"w-u"``: no interface; the subdomains are merged into the whole model, contact interfaces
  only.
* ``"v-u"``: no contact interfaces; contact acts on the boundary of the subdomain that owns it.

The names and the rule of which algorithms fit a scene are those of
:mod:`dd_contact.solvers.schedule` (:data:`ALGORITHMS`, ``fitting_algorithms``), read as the
paper does: each algorithm runs on its own variant of the model. The counts are not written
out here: each variant is handed to the engine's own schedule (:func:`schedule_counts`), so
the model counts exactly what the solvers do. ``docs/cost.md`` derives them per order, with
tables, and the tests check them against the paper's Table 1.
"""

from __future__ import annotations

import dataclasses
import operator
from collections import Counter
from dataclasses import dataclass
from functools import reduce
from typing import Any

import numpy as np
import numpy.typing as npt

from dd_contact.blocks import Block
from dd_contact.solvers.schedule import (
    ALGORITHMS,
    SWEEPS,
    FullSchedule,
    Operation,
    Schedule,
    fitting_algorithms,
)

__all__ = [
    "ALGORITHMS",
    "ArrayLike",
    "ContactCounts",
    "CostReport",
    "MeshCost",
    "MeshCounts",
    "SceneSizes",
    "SubdomainCounts",
    "applicable_algorithms",
    "check_non_negative",
    "check_positive",
    "compare",
    "f1",
    "f2",
    "f3",
    "f4",
    "is_int",
    "operation_counts",
]

_GIGA = 1.0e9

ArrayLike = float | int | npt.NDArray[np.floating[Any]] | npt.NDArray[np.integer[Any]]


# --------------------------------------------------------------------------- kernels


def f1(d: ArrayLike) -> ArrayLike:
    """Dense LU factorisation of a ``d x d`` matrix: ``d**3 / 3`` operations.

    Args:
        d: Matrix dimension (scalar or array).

    Returns:
        Operation count.
    """
    return d**3 / 3.0


def f2(d: ArrayLike) -> ArrayLike:
    """Dense forward + back substitution for one right-hand side: ``1.5 * d**2`` operations.

    Args:
        d: Matrix dimension (scalar or array).

    Returns:
        Operation count.
    """
    return 1.5 * d**2


def f3(d: ArrayLike, b: ArrayLike) -> ArrayLike:
    """Banded LU factorisation: ``d * b**2 - (2/3) * b**3`` operations.

    With ``b == d`` this equals :func:`f1`, so a banded matrix of full bandwidth costs the same
    as a dense one.

    Args:
        d: Matrix dimension (scalar or array).
        b: Half-bandwidth, diagonal included (scalar or array).

    Returns:
        Operation count.
    """
    return d * b**2 - (2.0 / 3.0) * b**3


def f4(d: ArrayLike, b: ArrayLike) -> ArrayLike:
    """Banded forward + back substitution for one right-hand side: ``3 * d * b`` operations.

    Args:
        d: Matrix dimension (scalar or array).
        b: Half-bandwidth, diagonal included (scalar or array).

    Returns:
        Operation count.
    """
    return 3.0 * d * b


# --------------------------------------------------------------------------- inputs


def is_int(value: Any) -> bool:
    """Whether ``value`` is a Python or numpy integer (``bool`` is not)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def check_positive(name: str, value: int) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is an integer ``>= 1``."""
    if not is_int(value) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")


def check_non_negative(name: str, value: int) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is an integer ``>= 0``."""
    if not is_int(value) or value < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {value!r}")


@dataclass(frozen=True)
class MeshCounts:
    """Size of a banded (volume) matrix, e.g. the undecomposed whole model.

    Attributes:
        name: Label used in reports.
        dofs: Number of unknowns ``D``.
        half_bandwidth: Half-bandwidth ``B`` counting the diagonal, ``1 <= B <= D``.
    """

    name: str
    dofs: int
    half_bandwidth: int

    def __post_init__(self) -> None:
        check_positive(f"{self.name}.dofs", self.dofs)
        check_positive(f"{self.name}.half_bandwidth", self.half_bandwidth)
        if self.half_bandwidth > self.dofs:
            raise ValueError(
                f"{self.name}: half_bandwidth {self.half_bandwidth} > dofs {self.dofs}"
            )


@dataclass(frozen=True)
class SubdomainCounts:
    """Size of one subdomain matrix ``K_D^(k)``.

    Attributes:
        name: Label used in reports.
        dofs: ``D_U``.
        half_bandwidth: ``B_U`` counting the diagonal, ``1 <= B_U <= D_U``.
        interface_dofs: ``D_V^(k)``, the interface dofs tied to this subdomain, i.e. the
            non-zero columns of ``P_DI2^(k)``: the interface nodes on (or, for non-matching
            meshes, whose cells overlap) the subdomain's tied surface, times the dofs per node.
            ``None`` means the whole interface (as in the paper's bar, where each subdomain
            touches all of ``Gamma_I``); ``0`` means not tied.
    """

    name: str
    dofs: int
    half_bandwidth: int
    interface_dofs: int | None = None

    def __post_init__(self) -> None:
        MeshCounts(self.name, self.dofs, self.half_bandwidth)  # same validation
        if self.interface_dofs is not None:
            check_non_negative(f"{self.name}.interface_dofs", self.interface_dofs)


@dataclass(frozen=True)
class ContactCounts:
    """Size of one contact interface ``Gamma_C^(k)``.

    Attributes:
        name: Label used in reports.
        dofs: ``D_W``.
        subdomain: Index (into ``SceneSizes.subdomains``) of the owning subdomain.
        alpha: ``alpha^(k)``, the number of contact state changes on this contact interface.
    """

    name: str
    dofs: int
    subdomain: int
    alpha: int

    def __post_init__(self) -> None:
        check_positive(f"{self.name}.dofs", self.dofs)
        check_non_negative(f"{self.name}.subdomain", self.subdomain)
        check_non_negative(f"{self.name}.alpha", self.alpha)


@dataclass(frozen=True)
class SceneSizes:
    """Everything the operation-count model needs to know about a decomposed model.

    Attributes:
        subdomains: The subdomains ``Omega^(k)``.
        contacts: The contact interfaces; at least one, at most one per subdomain.
        interface_dofs: ``D_V`` of the interface ``Gamma_I``, or ``None`` without interface.
        n_steps: ``N_TS``, number of time steps.
        gamma: Contact state changes in the whole model. Simultaneous changes on several contact
            interfaces count once, so ``max(alpha) <= gamma <= sum(alpha)``.
        whole: The undecomposed model as one banded matrix, used by ``"FULL"`` and ``"w-u"``.
        interface_name: Label of the interface in reports.
        substitutions_per_step: Subdomain substitutions per time step: 1 (default), a
            forward sweep for the condensed right-hand side and a backward sweep for u, as
            the paper's Tables 2 and 3 count and the engine does; 2, u_hat and u each a
            full substitution, as its Table 1 lists.
    """

    subdomains: tuple[SubdomainCounts, ...]
    contacts: tuple[ContactCounts, ...]
    interface_dofs: int | None
    n_steps: int
    gamma: int
    whole: MeshCounts
    interface_name: str = "Gamma_I"
    substitutions_per_step: int = 1

    def __post_init__(self) -> None:
        # tuples keep the frozen dataclass hashable even if lists were passed
        object.__setattr__(self, "subdomains", tuple(self.subdomains))
        object.__setattr__(self, "contacts", tuple(self.contacts))
        if not self.subdomains:
            raise ValueError("at least one subdomain is required")
        if not self.contacts:
            raise ValueError("at least one contact interface is required")
        if self.interface_dofs is not None:
            check_positive("interface_dofs", self.interface_dofs)
        for sd in self.subdomains:
            if sd.interface_dofs:
                if self.interface_dofs is None:
                    raise ValueError(f"{sd.name} is tied to an interface, but there is none")
                if sd.interface_dofs > self.interface_dofs:
                    raise ValueError(
                        f"{sd.name}: interface_dofs {sd.interface_dofs} > interface dofs "
                        f"{self.interface_dofs}"
                    )
        if self.substitutions_per_step not in (1, 2):
            raise ValueError(
                f"substitutions_per_step must be 1 (Tables 2 and 3) or 2 (Table 1), got "
                f"{self.substitutions_per_step!r}"
            )
        check_non_negative("n_steps", self.n_steps)
        check_non_negative("gamma", self.gamma)
        owners = [c.subdomain for c in self.contacts]
        if max(owners) >= len(self.subdomains):
            raise ValueError(f"contact owner index out of range: {owners}")
        if len(set(owners)) != len(owners):
            # Table 1 assumes one contact interface per subdomain (w^(k) blocks decoupled)
            raise ValueError(f"each subdomain may own at most one contact interface: {owners}")
        alphas = [c.alpha for c in self.contacts]
        if not max(alphas) <= self.gamma <= sum(alphas):
            raise ValueError(
                f"need max(alpha) <= gamma <= sum(alpha); got alpha={alphas}, gamma={self.gamma}"
            )

    def contact_of(self, subdomain: int) -> ContactCounts | None:
        """Return the contact interface owned by subdomain ``subdomain``, if any."""
        for c in self.contacts:
            if c.subdomain == subdomain:
                return c
        return None

    def tied_dofs(self, subdomain: int) -> int:
        """``D_V^(k)``: interface dofs tied to subdomain ``subdomain`` (0 without interface)."""
        if self.interface_dofs is None:
            return 0
        n = self.subdomains[subdomain].interface_dofs
        return self.interface_dofs if n is None else n


# --------------------------------------------------------------------------- outputs


@dataclass(frozen=True)
class MeshCost:
    """Counts and cost on one mesh (one row of the paper's Table 2).

    Attributes:
        name: Mesh label.
        dofs: Matrix dimension.
        half_bandwidth: Half-bandwidth for banded matrices, ``None`` for dense ones.
        decompositions: Number of LU factorisations of this mesh's matrix.
        substitutions: Number of single right-hand-side substitutions with it.
        gflops_decomposition: Cost of all factorisations, in 1e9 operations.
        gflops_substitution: Cost of all substitutions, in 1e9 operations.
    """

    name: str
    dofs: int
    half_bandwidth: int | None
    decompositions: int
    substitutions: int
    gflops_decomposition: float
    gflops_substitution: float

    @property
    def gflops(self) -> float:
        """Total cost on this mesh in 1e9 operations."""
        return self.gflops_decomposition + self.gflops_substitution


@dataclass(frozen=True)
class CostReport:
    """Operation counts of one algorithm.

    Attributes:
        algorithm: One of :data:`ALGORITHMS`.
        meshes: Per-mesh counts and costs.
        percent_of_full: ``100 * gflops_total / FULL.gflops_total``; set by :func:`compare`.
    """

    algorithm: str
    meshes: tuple[MeshCost, ...]
    percent_of_full: float | None = None

    @property
    def gflops_decomposition(self) -> float:
        """Factorisation cost summed over meshes, in 1e9 operations."""
        return float(sum(m.gflops_decomposition for m in self.meshes))

    @property
    def gflops_substitution(self) -> float:
        """Substitution cost summed over meshes, in 1e9 operations."""
        return float(sum(m.gflops_substitution for m in self.meshes))

    @property
    def gflops_total(self) -> float:
        """Total cost in 1e9 operations."""
        return self.gflops_decomposition + self.gflops_substitution


def _banded(name: str, d: int, b: int, n_dec: int, n_sub: float) -> MeshCost:
    dec, sub = n_dec * f3(d, b) / _GIGA, n_sub * f4(d, b) / _GIGA
    return MeshCost(name, int(d), int(b), int(n_dec), int(n_sub), float(dec), float(sub))


def _dense(name: str, d: int, n_dec: int, n_sub: float) -> MeshCost:
    dec, sub = n_dec * f1(d) / _GIGA, n_sub * f2(d) / _GIGA
    return MeshCost(name, int(d), None, int(n_dec), int(n_sub), float(dec), float(sub))


# --------------------------------------------------------------------------- algorithms


def _require_interface(s: SceneSizes, algorithm: str) -> int:
    if s.interface_dofs is None:
        raise ValueError(f"{algorithm!r} needs an interface (interface_dofs is None)")
    return s.interface_dofs


def _coupled_name(contacts: list[ContactCounts]) -> str:
    """Name of a dense block holding several w^(k) (w-v-u and w-u)."""
    names = [c.name for c in contacts]
    return "+".join(names) if len(names) <= 3 else f"{len(names)} coupled contact interfaces"


# The paper's model runs each algorithm on its own variant of the scene (method.md section
# 6): FULL on the whole model, v-w-u and w-v-u on the scene as described, w-u with the
# subdomains merged into the whole model (no interface), v-u with contact on the owning
# subdomain's boundary (no contact meshes). Each variant is written as the block system the
# engine would see, and its counts are those of the engine's own schedule
# (dd_contact.solvers.schedule), with the paper's condensation: one substitution per
# coupling column; a step substitutes each subdomain once (a forward and a backward sweep)
# or twice (SceneSizes.substitutions_per_step).
def _u(k: int) -> Block:
    return Block("u", str(k))


def _w(k: int) -> Block:
    return Block("w", str(k))


_V = Block("v", "interface")
_WHOLE = Block("u", "whole")


def _variant(s: SceneSizes, algorithm: str) -> tuple[Schedule | FullSchedule, list]:
    """The schedule of ``algorithm`` on its variant of ``s``, and the meshes to report.

    Returns the schedule and, in report order, ``(schedule target, name, dofs,
    half-bandwidth or None for a dense matrix, contacts)`` of every mesh.
    """
    regions: dict[str, str] = {c.name: _w(i) for i, c in enumerate(s.contacts)}
    if algorithm == "FULL":
        w = s.whole
        regions = {c.name: "FULL" for c in s.contacts}
        return FullSchedule(w.dofs, regions), [("FULL", w.name, w.dofs, w.half_bandwidth)]
    contact_of = {c.subdomain: (i, c) for i, c in enumerate(s.contacts)}
    sizes = {_w(i): c.dofs for i, c in enumerate(s.contacts)}
    pairs = {(b, b) for b in sizes}
    layouts: dict[str, list] = {}
    volumes = []
    if algorithm == "w-u":  # the subdomains merged: one volume tied to every contact mesh
        w = s.whole
        sizes[_WHOLE] = w.dofs
        layouts[_WHOLE] = [(_w(i), np.arange(c.dofs)) for i, c in enumerate(s.contacts)]
        volumes.append((_WHOLE, w.name, w.dofs, w.half_bandwidth))
    else:
        sizes[_V] = _require_interface(s, algorithm)
        pairs.add((_V, _V))
        for k, sd in enumerate(s.subdomains):
            sizes[_u(k)] = sd.dofs
            tied = s.tied_dofs(k)
            layouts[_u(k)] = [(_V, np.arange(tied))] if tied else []
            if k in contact_of and algorithm != "v-u":
                i, c = contact_of[k]
                layouts[_u(k)].append((_w(i), np.arange(c.dofs)))
            volumes.append((_u(k), sd.name, sd.dofs, sd.half_bandwidth))
    if algorithm == "v-u":  # contact on the subdomain's own boundary: no contact meshes
        sizes = {b: n for b, n in sizes.items() if b.kind != "w"}
        pairs = {p for p in pairs if p[0] in sizes}
        regions = {c.name: _u(c.subdomain) for c in s.contacts}
    split = s.substitutions_per_step == 1
    schedule = Schedule(algorithm, sizes, layouts, pairs, regions, "multi-rhs", split)
    surfaces = []
    for g in schedule.flat:
        if g.blocks == (_V,):
            surfaces.append((g.name, s.interface_name, sizes[_V], None))
            continue
        contacts = [c for i, c in enumerate(s.contacts) if _w(i) in g.blocks]
        name = contacts[0].name if len(contacts) == 1 else _coupled_name(contacts)
        surfaces.append((g.name, name, sum(c.dofs for c in contacts), None))
    if algorithm == "v-w-u":  # the paper's Table 2 lists the contact meshes first
        surfaces.sort(key=lambda m: m[0] == _V)
    return schedule, volumes + surfaces


def _tally(ops: list[Operation]) -> Counter:
    """Decompositions and single right-hand-side substitutions per schedule target.

    A forward or backward sweep (:data:`SWEEPS`) is half a substitution: counted in
    ``"sweeps"`` and turned into substitutions by :func:`_counts`.
    """
    counts: Counter = Counter()
    for op in ops:
        if op.kind.endswith("_factor"):
            counts[(op.target, "decompositions")] += 1
        elif op.kind.endswith("_solve"):
            counts[(op.target, "substitutions")] += op.nrhs
        elif op.kind in SWEEPS:
            counts[(op.target, "sweeps")] += op.nrhs
    return counts


def schedule_counts(
    schedule: Schedule | FullSchedule, n_steps: int, gamma: int, alpha: dict[str, int]
) -> Counter:
    """Counts of a run of the schedule: ``(target, "decompositions"|"substitutions") -> n``.

    Set-up once, a step ``n_steps`` times, and the contact changes: what every region's
    change does (the surface levels all changes go through) once per change anywhere
    (``gamma``), the rest of a region's change once per change there (``alpha``).
    """
    changes = {key: _tally(schedule.change(key)) for key, _ in alpha.items()}
    common = reduce(operator.and_, changes.values()) if changes else Counter()
    total = _tally(schedule.setup())
    for key, n in _tally(schedule.step()).items():
        total[key] += n_steps * n
    for key, n in common.items():
        total[key] += gamma * n
    for region, count in alpha.items():
        for key, n in (changes[region] - common).items():
            total[key] += count * n
    return total


def _counts(s: SceneSizes, algorithm: str) -> list[MeshCost]:
    """Per mesh, the counts of the algorithm's schedule priced with the paper's kernels."""
    schedule, meshes = _variant(s, algorithm)
    counts = schedule_counts(schedule, s.n_steps, s.gamma, {c.name: c.alpha for c in s.contacts})
    out = []
    for target, name, dofs, bandwidth in meshes:
        n_dec = counts[(target, "decompositions")]
        n_sub: float = counts[(target, "substitutions")]
        sweeps = counts[(target, "sweeps")]
        n_sub += sweeps // 2 if sweeps % 2 == 0 else sweeps / 2
        if bandwidth is None:
            out.append(_dense(name, dofs, n_dec, n_sub))
        else:
            out.append(_banded(name, dofs, bandwidth, n_dec, n_sub))
    return out


def applicable_algorithms(sizes: SceneSizes) -> tuple[str, ...]:
    """Algorithms that make sense for ``sizes``: those using ``v`` need an interface.

    The schedule's fit rule in the paper's reading (``fitting_algorithms(..., variants=True)``):
    every scene here has contact interfaces, and w-u and v-u run on their own variants of the
    model, so without an interface FULL and w-u fit, with one all of :data:`ALGORITHMS`.

    Args:
        sizes: Scene description.

    Returns:
        Subset of :data:`ALGORITHMS`, in that order.
    """
    return fitting_algorithms(sizes.interface_dofs is not None, True, variants=True)


def operation_counts(sizes: SceneSizes, algorithm: str) -> CostReport:
    """Decompositions, substitutions and GFLOPs of ``algorithm`` on each mesh of ``sizes``.

    Args:
        sizes: Scene description.
        algorithm: One of :data:`ALGORITHMS`.

    Returns:
        The report; ``percent_of_full`` is ``100.0`` for ``"FULL"`` and ``None`` otherwise
        (use :func:`compare` to fill it).

    Raises:
        ValueError: Unknown algorithm, or one that needs an interface the scene lacks.
    """
    if algorithm not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algorithm!r}; choose from {ALGORITHMS}")
    meshes = tuple(_counts(sizes, algorithm))
    return CostReport(algorithm, meshes, 100.0 if algorithm == "FULL" else None)


def compare(sizes: SceneSizes) -> dict[str, CostReport]:
    """Reports of every applicable algorithm with ``percent_of_full`` filled in.

    Args:
        sizes: Scene description.

    Returns:
        ``{algorithm: report}`` in :data:`ALGORITHMS` order.
    """
    reports = {a: operation_counts(sizes, a) for a in applicable_algorithms(sizes)}
    full = reports["FULL"].gflops_total
    return {
        a: dataclasses.replace(r, percent_of_full=100.0 * r.gflops_total / full)
        for a, r in reports.items()
    }
