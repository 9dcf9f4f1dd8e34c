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

The derivation of each order is in the docstring of its private ``_counts_*`` function and, with
tables, in ``docs/cost.md``. Besides the model, this module holds the two examples of the paper as
size generators (:func:`parallelepiped_sizes`, :func:`pin_joint_sizes`), a JSON scene format
(:func:`load_scene`), the paper's parameter studies (:func:`parallelepiped_studies`,
:func:`pin_joint_studies`) and their charts (:func:`write_studies`). Nothing here imports
dolfinx; matplotlib is imported only when a chart is drawn.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = [
    "ALGORITHMS",
    "CHANGES_SWEEP",
    "CONTACT_SCALES",
    "STEPS_SWEEP",
    "ContactCounts",
    "CostReport",
    "MeshCost",
    "MeshCounts",
    "PinJointLayout",
    "SceneSizes",
    "Study",
    "SubdomainCounts",
    "applicable_algorithms",
    "compare",
    "f1",
    "f2",
    "f3",
    "f4",
    "format_table",
    "half_bandwidth_box",
    "half_bandwidth_structured_hex",
    "load_scene",
    "matrix_half_bandwidth",
    "operation_counts",
    "parallelepiped_sizes",
    "parallelepiped_studies",
    "pin_joint_mesh_counts",
    "pin_joint_sizes",
    "pin_joint_studies",
    "plot_study",
    "rcm_half_bandwidth",
    "scene_from_dict",
    "scene_studies",
    "scene_to_dict",
    "to_json_dict",
    "write_studies",
]

#: Algorithm keys in the order the paper lists them, baseline first.
ALGORITHMS: tuple[str, ...] = ("FULL", "v-w-u", "w-v-u", "w-u", "v-u")

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


def _is_int(value: Any) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def _check_positive(name: str, value: int) -> None:
    if not _is_int(value) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")


def _check_non_negative(name: str, value: int) -> None:
    if not _is_int(value) or value < 0:
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
        _check_positive(f"{self.name}.dofs", self.dofs)
        _check_positive(f"{self.name}.half_bandwidth", self.half_bandwidth)
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
            _check_non_negative(f"{self.name}.interface_dofs", self.interface_dofs)


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
        _check_positive(f"{self.name}.dofs", self.dofs)
        _check_non_negative(f"{self.name}.subdomain", self.subdomain)
        _check_non_negative(f"{self.name}.alpha", self.alpha)


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
    """

    subdomains: tuple[SubdomainCounts, ...]
    contacts: tuple[ContactCounts, ...]
    interface_dofs: int | None
    n_steps: int
    gamma: int
    whole: MeshCounts
    interface_name: str = "Gamma_I"

    def __post_init__(self) -> None:
        # tuples keep the frozen dataclass hashable even if lists were passed
        object.__setattr__(self, "subdomains", tuple(self.subdomains))
        object.__setattr__(self, "contacts", tuple(self.contacts))
        if not self.subdomains:
            raise ValueError("at least one subdomain is required")
        if not self.contacts:
            raise ValueError("at least one contact interface is required")
        if self.interface_dofs is not None:
            _check_positive("interface_dofs", self.interface_dofs)
        for sd in self.subdomains:
            if sd.interface_dofs:
                if self.interface_dofs is None:
                    raise ValueError(f"{sd.name} is tied to an interface, but there is none")
                if sd.interface_dofs > self.interface_dofs:
                    raise ValueError(
                        f"{sd.name}: interface_dofs {sd.interface_dofs} > interface dofs "
                        f"{self.interface_dofs}"
                    )
        _check_non_negative("n_steps", self.n_steps)
        _check_non_negative("gamma", self.gamma)
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


def _banded(name: str, d: int, b: int, n_dec: int, n_sub: int) -> MeshCost:
    dec, sub = n_dec * f3(d, b) / _GIGA, n_sub * f4(d, b) / _GIGA
    return MeshCost(name, int(d), int(b), int(n_dec), int(n_sub), float(dec), float(sub))


def _dense(name: str, d: int, n_dec: int, n_sub: int) -> MeshCost:
    dec, sub = n_dec * f1(d) / _GIGA, n_sub * f2(d) / _GIGA
    return MeshCost(name, int(d), None, int(n_dec), int(n_sub), float(dec), float(sub))


# --------------------------------------------------------------------------- algorithms


def _require_interface(s: SceneSizes, algorithm: str) -> int:
    if s.interface_dofs is None:
        raise ValueError(f"{algorithm!r} needs an interface (interface_dofs is None)")
    return s.interface_dofs


def _coupled_contacts(s: SceneSizes) -> tuple[str, int]:
    """Name and size of the single dense block holding all w^(k) (w-v-u and w-u)."""
    names = [c.name for c in s.contacts]
    name = "+".join(names) if len(names) <= 3 else f"{len(names)} coupled contact interfaces"
    return name, sum(c.dofs for c in s.contacts)


def _counts_full(s: SceneSizes) -> list[MeshCost]:
    """FULL: classical solve of the undecomposed model.

    One banded matrix ``[D, B] = [whole.dofs, whole.half_bandwidth]``, factorised at the first
    step and after every contact change anywhere (``1 + gamma``), and substituted once per time
    step and once per contact iteration caused by a change (``N_TS + gamma``).
    """
    w = s.whole
    return [_banded(w.name, w.dofs, w.half_bandwidth, 1 + s.gamma, s.n_steps + s.gamma)]


def _counts_vwu(s: SceneSizes) -> list[MeshCost]:
    """v-w-u: condense u, then w, solve v; back-substitute w, then u (Table 1, summed per mesh).

    * ``Omega^(k)``: ``f3(D_U, B_U)`` once; ``f4(D_U, B_U)`` for ``K_D^-1 P_CI2`` (``D_W``
      columns, only if it owns a contact interface), ``K_D^-1 P_DI2`` (``D_V^(k)`` non-zero
      columns; ``D_V`` in the paper's bar), ``u_hat`` (``N_TS``) and ``u`` (``N_TS``):
      ``D_W + D_V^(k) + 2 N_TS`` substitutions.
    * ``Gamma_C^(k)``: ``f1(D_W)`` ``1 + alpha`` times; ``f2(D_W)`` for ``K_CI^-1 P_CD``
      (``(1 + alpha) D_V^(k)``: ``P_CD^(k)`` has the non-zero columns of ``P_DI2^(k)``),
      ``K_CI^-1 p_C2`` (``N_TS + alpha``) and ``w`` (``N_TS + gamma``).
    * ``Gamma_I``: ``f1(D_V)`` ``1 + gamma`` times; ``f2(D_V)`` for ``v``, ``N_TS + gamma`` times.
    """
    d_v = _require_interface(s, "v-w-u")
    n, g = s.n_steps, s.gamma
    out = []
    for k, sd in enumerate(s.subdomains):
        c = s.contact_of(k)
        cols = (c.dofs if c else 0) + s.tied_dofs(k)
        out.append(_banded(sd.name, sd.dofs, sd.half_bandwidth, 1, cols + 2 * n))
    for c in s.contacts:
        n_sub = (1 + c.alpha) * s.tied_dofs(c.subdomain) + (n + c.alpha) + (n + g)
        out.append(_dense(c.name, c.dofs, 1 + c.alpha, n_sub))
    out.append(_dense(s.interface_name, d_v, 1 + g, n + g))
    return out


def _counts_wvu(s: SceneSizes) -> list[MeshCost]:
    """w-v-u: condense u, then v, solve w; back-substitute v, then u.

    Derivation (same bookkeeping as Table 1):

    * ``Omega^(k)``: identical to v-w-u (``K_D`` is contact independent): ``f3`` once,
      ``f4`` ``D_W + D_V^(k) + 2 N_TS`` times.
    * ``Gamma_I``: ``K_DI_hat = K_DI - sum P^T K_D^-1 P`` does not depend on contact, so
      ``f1(D_V)`` once. ``f2(D_V)`` for ``K_DI_hat^-1 P_CD^T`` (once, one column per contact dof,
      ``sum D_W``), for ``K_DI_hat^-1 sum P_DI2^T u_hat`` (the w right-hand side, once per step,
      ``N_TS``) and for the back-substitution of ``v`` (once per converged step, ``N_TS``; the
      contact check needs only ``w``): ``sum D_W + 2 N_TS``.
    * Contact: condensing ``v`` couples every ``w^(k)`` with every other, so all contact
      interfaces form one dense block of ``sum D_W`` dofs. It changes whenever any contact
      interface changes: ``f1`` ``1 + gamma`` times, ``f2`` (solve for ``w``) ``N_TS + gamma``
      times. With one contact interface this is ``Gamma_C^(1)`` and ``gamma == alpha``.
    """
    d_v = _require_interface(s, "w-v-u")
    n, g = s.n_steps, s.gamma
    name_c, d_c = _coupled_contacts(s)
    out = []
    for k, sd in enumerate(s.subdomains):
        c = s.contact_of(k)
        cols = (c.dofs if c else 0) + s.tied_dofs(k)
        out.append(_banded(sd.name, sd.dofs, sd.half_bandwidth, 1, cols + 2 * n))
    out.append(_dense(s.interface_name, d_v, 1, d_c + 2 * n))
    out.append(_dense(name_c, d_c, 1 + g, n + g))
    return out


def _counts_wu(s: SceneSizes) -> list[MeshCost]:
    """w-u: no interface; contact interfaces on the merged (undecomposed) model.

    Without ``v`` the subdomains are one body, so the volume matrix is ``whole`` (its dofs and
    half-bandwidth), factorised once: ``f3`` once; ``f4`` for ``K^-1 P_CI2`` (``sum D_W``
    columns), ``u_hat`` (``N_TS``) and ``u`` (``N_TS``). Condensing the merged ``u`` couples all
    contact interfaces into one dense block of ``sum D_W`` dofs, re-factorised ``1 + gamma``
    times and solved for ``w`` ``N_TS + gamma`` times. The cost of a contact change,
    ``f1(sum D_W) + f2(sum D_W)``, does not depend on any volume bandwidth.
    """
    n, g = s.n_steps, s.gamma
    name_c, d_c = _coupled_contacts(s)
    w = s.whole
    return [
        _banded(w.name, w.dofs, w.half_bandwidth, 1, d_c + 2 * n),
        _dense(name_c, d_c, 1 + g, n + g),
    ]


def _counts_vu(s: SceneSizes) -> list[MeshCost]:
    """v-u: interface only; contact acts on the boundary of its owning subdomain.

    * Contact subdomain ``k`` (owns ``Gamma_C^(k)`` in the scene; the contact mesh itself is not
      used): its banded matrix ``[D_U, B_U]`` holds the contact penalty, so ``f3`` ``1 + alpha``
      times; ``f4`` for ``K_D^-1 P_DI2`` with the new factor after every factorisation
      (``(1 + alpha) D_V^(k)``; ``K_DI_hat`` (A17) needs it), ``u_hat`` at each step and after
      each own change (``N_TS + alpha``), and ``u`` at each step and each change anywhere
      (``N_TS + gamma``; the contact check needs ``u`` on the boundary, and ``u`` depends on
      ``v``).
    * Other subdomains: their condensation is contact independent and reused: ``f3`` once,
      ``f4`` ``D_V^(k) + 2 N_TS`` times.
    * ``Gamma_I``: ``K_DI_hat`` contains every ``K_D^-1``, so ``f1(D_V)`` ``1 + gamma`` times;
      ``f2(D_V)`` for ``v`` ``N_TS + gamma`` times.

    This is the only order whose cost per contact change grows with the contact subdomain's
    half-bandwidth (through ``f3(D_U, B_U) + f4(D_U, B_U) (D_V^(k) + 2)``).
    """
    d_v = _require_interface(s, "v-u")
    n, g = s.n_steps, s.gamma
    out = []
    for k, sd in enumerate(s.subdomains):
        c = s.contact_of(k)
        dv_k = s.tied_dofs(k)
        if c is None:
            out.append(_banded(sd.name, sd.dofs, sd.half_bandwidth, 1, dv_k + 2 * n))
        else:
            n_sub = (1 + c.alpha) * dv_k + (n + c.alpha) + (n + g)
            out.append(_banded(sd.name, sd.dofs, sd.half_bandwidth, 1 + c.alpha, n_sub))
    out.append(_dense(s.interface_name, d_v, 1 + g, n + g))
    return out


_COUNTERS = {
    "FULL": _counts_full,
    "v-w-u": _counts_vwu,
    "w-v-u": _counts_wvu,
    "w-u": _counts_wu,
    "v-u": _counts_vu,
}


def applicable_algorithms(sizes: SceneSizes) -> tuple[str, ...]:
    """Algorithms that make sense for ``sizes``: those using ``v`` need an interface.

    Args:
        sizes: Scene description.

    Returns:
        Subset of :data:`ALGORITHMS`, in that order.
    """
    if sizes.interface_dofs is None:
        return ("FULL", "w-u")
    return ALGORITHMS


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
    if algorithm not in _COUNTERS:
        raise ValueError(f"unknown algorithm {algorithm!r}; choose from {ALGORITHMS}")
    meshes = tuple(_COUNTERS[algorithm](sizes))
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


# --------------------------------------------------------------------------- bandwidths


def half_bandwidth_structured_hex(nx: int, ny: int, nz: int, dofs_per_node: int = 3) -> int:
    """Half-bandwidth (diagonal included) of a structured box mesh of 8-node hexahedra.

    Nodes ``(i, j, k)``, ``0 <= i <= nx`` etc., are numbered ``n = (i (ny + 1) + j)(nz + 1) + k``
    (x slowest, z fastest) and dofs interleaved, ``dof = dofs_per_node * n + c``. Two nodes share
    an element iff their indices differ by at most 1 in each direction, so the largest node
    offset is ``(ny + 1)(nz + 1) + (nz + 1) + 1``. The largest dof offset adds
    ``dofs_per_node - 1`` (component 0 of the lower to the last component of the upper node),
    and the diagonal adds 1::

        B = dofs_per_node * ((ny + 1)(nz + 1) + (nz + 1) + 1) + dofs_per_node
          = dofs_per_node * ((ny + 2)(nz + 1) + 2)

    e.g. 400 x 100 x 10: ``3 * (102 * 11 + 2) = 3372``. ``nx`` does not enter (for ``nx >= 1``).

    Args:
        nx: Elements along x (numbered slowest; put the long direction here).
        ny: Elements along y.
        nz: Elements along z (numbered fastest).
        dofs_per_node: Unknowns per node.

    Returns:
        The half-bandwidth ``B``.
    """
    for name, v in (("nx", nx), ("ny", ny), ("nz", nz), ("dofs_per_node", dofs_per_node)):
        _check_positive(name, v)
    max_node_offset = (ny + 1) * (nz + 1) + (nz + 1) + 1
    return dofs_per_node * max_node_offset + dofs_per_node


def half_bandwidth_box(nx: int, ny: int, nz: int, dofs_per_node: int = 3) -> int:
    """Smallest structured half-bandwidth of an ``nx x ny x nz`` box of hexahedra.

    Of the six axis orders of :func:`half_bandwidth_structured_hex` the best numbers the longest
    direction slowest and the shortest fastest: ``B = dofs_per_node ((n_mid + 2)(n_short + 1) +
    2)``. (With ``(m + 2)(s + 1) - (s + 2)(m + 1) = s - m``, the larger of the two remaining
    directions belongs in the middle.)

    Args:
        nx: Elements along x.
        ny: Elements along y.
        nz: Elements along z.
        dofs_per_node: Unknowns per node.

    Returns:
        The half-bandwidth ``B``.
    """
    n_long, n_mid, n_short = sorted((nx, ny, nz), reverse=True)
    return half_bandwidth_structured_hex(n_long, n_mid, n_short, dofs_per_node)


def _pattern(matrix: Any) -> tuple[np.ndarray, np.ndarray, int]:
    from scipy.sparse import coo_array

    coo = coo_array(matrix)
    if coo.shape[0] != coo.shape[1]:
        raise ValueError(f"matrix must be square, got shape {coo.shape}")
    return np.asarray(coo.row), np.asarray(coo.col), int(coo.shape[0])


def matrix_half_bandwidth(matrix: Any) -> int:
    """Half-bandwidth (diagonal included) of a sparse matrix in its present numbering.

    Args:
        matrix: A square scipy sparse matrix or array (e.g. the ``to_scipy()`` of an assembled
            dolfinx matrix) or a dense array; only the pattern of stored entries is used.

    Returns:
        ``max |i - j| + 1`` over the stored entries (1 for an empty matrix).
    """
    row, col, _ = _pattern(matrix)
    return int(np.abs(row - col).max()) + 1 if row.size else 1


def rcm_half_bandwidth(matrix: Any) -> int:
    """Half-bandwidth after a reverse Cuthill-McKee reordering (scipy's, symmetric pattern).

    Args:
        matrix: As for :func:`matrix_half_bandwidth`.

    Returns:
        The half-bandwidth in the reverse Cuthill-McKee numbering.
    """
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    row, col, n = _pattern(matrix)
    if not row.size:
        return 1
    sym = coo_array(
        (np.ones(2 * row.size, dtype=np.int8), (np.r_[row, col], np.r_[col, row])), shape=(n, n)
    ).tocsr()
    perm = reverse_cuthill_mckee(sym, symmetric_mode=True)
    rank = np.empty(n, dtype=np.int64)
    rank[perm] = np.arange(n)
    return int(np.abs(rank[row] - rank[col]).max()) + 1


# --------------------------------------------------------------------------- paper's bar


def _split_layers(nx: int, split: tuple[int, int]) -> tuple[int, int]:
    a, b = split
    _check_positive("split[0]", a)
    _check_positive("split[1]", b)
    if (nx * a) % (a + b) != 0:
        raise ValueError(f"split {a}:{b} does not divide {nx} element layers evenly")
    layers1 = nx * a // (a + b)
    return layers1, nx - layers1


def parallelepiped_sizes(
    elements: tuple[int, int, int] = (400, 100, 10),
    split: tuple[int, int] = (5, 5),
    interface: tuple[int, int] = (100, 10),
    contact: tuple[int, int] = (100, 10),
    steps: int = 10000,
    changes: int = 20000,
) -> SceneSizes:
    """Scene of the paper's rectangular parallelepiped (method.md 7.1).

    The bar of ``nx x ny x nz`` hexahedra (3 dofs per node) is cut across x into two subdomains
    of ``nx * split[0] / sum(split)`` and the remaining element layers, so subdomain ``k`` has
    ``(layers + 1)(ny + 1)(nz + 1) * 3`` dofs. Each subdomain (and the whole bar) is numbered
    structurally with its longest direction slowest and its shortest fastest
    (:func:`half_bandwidth_box`): for the paper's 400 x 100 x 10 bar this is x slowest and
    ``B = 3372`` for the bar and both halves; a subdomain shorter than ``ny`` layers is numbered
    y slowest and gets a smaller bandwidth (40 x 100 x 10 at 1:9: ``B = 3 (42 * 11 + 2) =
    1392``). Interface and contact interface are structured quad meshes, ``(m0 + 1)(m1 + 1) * 3``
    dofs; the interface ties the whole cut of both subdomains; the contact interface sits on the
    far end face of subdomain 1 (index 0). ``alpha = gamma = changes``. ``"FULL"`` and ``"w-u"``
    use the whole bar, ``(nx+1)(ny+1)(nz+1) * 3`` dofs.

    Args:
        elements: Hexahedra along x (long, cut direction), y, z.
        split: Ratio of element layers in subdomain 1 : subdomain 2.
        interface: Quads of the interface mesh on the cut.
        contact: Quads of the contact interface mesh.
        steps: ``N_TS``.
        changes: ``alpha = gamma``.

    Returns:
        The scene.

    Raises:
        ValueError: If the split does not give whole, non-empty element layers.
    """
    nx, ny, nz = elements
    for name, v in (("nx", nx), ("ny", ny), ("nz", nz)):
        _check_positive(name, v)
    layers = _split_layers(nx, split)
    if min(layers) < 1:
        raise ValueError(f"split {split} leaves an empty subdomain")
    per_layer = (ny + 1) * (nz + 1) * 3
    subdomains = tuple(
        SubdomainCounts(f"Omega{i + 1}", (n + 1) * per_layer, half_bandwidth_box(n, ny, nz))
        for i, n in enumerate(layers)
    )
    for name, mesh in (("interface", interface), ("contact", contact)):
        for v in mesh:
            _check_positive(name, v)
    quad_dofs = [(m0 + 1) * (m1 + 1) * 3 for m0, m1 in (interface, contact)]
    return SceneSizes(
        subdomains=subdomains,
        contacts=(ContactCounts("Gamma_C1", quad_dofs[1], 0, changes),),
        interface_dofs=quad_dofs[0],
        n_steps=steps,
        gamma=changes,
        whole=MeshCounts("Omega", (nx + 1) * per_layer, half_bandwidth_box(nx, ny, nz)),
    )


# --------------------------------------------------------------------------- multi-pin joint


@dataclass(frozen=True)
class PinJointLayout:
    """A steel lap joint: two plates with a row of holes, pinned (method.md 7.2).

    Each plate (thickness ``thickness``) is ``n_holes * pitch`` wide (x) and ``pitch +
    free_length`` long (y): a hole strip of ``n_holes`` square hole blocks ``pitch x pitch`` with
    a centred hole of ``hole_diameter``, then the free (grip) part ``free_length`` long. The
    upper and lower plates overlap over their hole strips, their grips point in opposite
    directions, and a rigid pin of the hole diameter passes through each pair of holes.

    Mesh (8-node hexahedra, 3 dofs per node, conforming inside a plate): each hole block is an
    O-grid, ``4 n_circumferential`` elements around the hole (``n_circumferential`` along each
    side of the block), ``n_radial`` from the hole to the block's boundary, ``n_layers`` through
    the thickness; the grip is a structured ``n_holes n_circumferential x n_length x n_layers``
    box. The decomposition has ``2 (n_holes + 1)`` subdomains (each hole block and each grip),
    one interface (the cuts between hole blocks and between the hole strip and the grip, in both
    plates, meshed like the subdomain faces) and ``2 n_holes`` contact interfaces (each hole's
    cylindrical surface, meshed like the hole).

    The defaults (20 mm pins at a 60 mm pitch, edge distance 30 mm, 10 mm plates 300 mm wide
    and 330 mm long, 3.75 mm elements on the block sides and in the grip, 0.98 mm around the
    hole) give 174,080 hexahedra and 201,672 nodes, close to the paper's 173,250 and 197,472.

    Attributes:
        hole_diameter: Hole (pin) diameter, mm.
        pitch: Hole spacing = hole block side, mm.
        thickness: Plate thickness, mm.
        free_length: Length of each plate beyond the hole strip, mm.
        n_holes: Holes (pins) in the row.
        n_circumferential: Elements along each side of a hole block (a quarter of the hole).
        n_radial: Elements from the hole to the hole block's boundary.
        n_layers: Elements through the thickness.
        n_length: Elements along the grip's length.
    """

    hole_diameter: float = 20.0
    pitch: float = 60.0
    thickness: float = 10.0
    free_length: float = 270.0
    n_holes: int = 5
    n_circumferential: int = 16
    n_radial: int = 16
    n_layers: int = 8
    n_length: int = 72

    def __post_init__(self) -> None:
        for name in ("n_holes", "n_circumferential", "n_radial", "n_layers", "n_length"):
            _check_positive(name, getattr(self, name))
        if not 0.0 < self.hole_diameter < self.pitch:
            raise ValueError("need 0 < hole_diameter < pitch")
        if self.thickness <= 0.0 or self.free_length <= 0.0:
            raise ValueError("thickness and free_length must be positive")


def pin_joint_mesh_counts(layout: PinJointLayout | None = None) -> dict[str, int]:
    """Node, element, dof and bandwidth counts of the multi-pin joint's meshes.

    Closed forms (``c, r, t, y, h`` = ``n_circumferential, n_radial, n_layers, n_length,
    n_holes``, ``g = h c`` grip elements across the width):

    * hole block: ``4 c (r + 1)(t + 1)`` nodes, ``4 c r t`` hexahedra; half-bandwidth of the
      better of two zig-zag O-grid numberings (ring position slowest, visited 0, 1, -1, 2, -2,
      ... so that ring neighbours are at most 2 apart: ``3 ((2 r + 3)(t + 1) + 2)``; or radial
      layer slowest with the same zig-zag inside each ring: ``3 ((4 c + 2)(t + 1) + 2)``);
    * grip: ``(g + 1)(y + 1)(t + 1)`` nodes, ``g y t`` hexahedra, :func:`half_bandwidth_box`;
    * plate: ``[4 h c (r + 1) - (h - 1)(c + 1) + (g + 1) y](t + 1)`` nodes (neighbouring hole
      blocks share a side, the grip shares the strip's edge), ``4 h c r t + g y t`` hexahedra;
      its half-bandwidth is computed (see :func:`_plate_half_bandwidth`); the whole model is
      both plates numbered one after the other, so it has the plate's half-bandwidth;
    * contact interface (a hole's surface): ``4 c (t + 1)`` nodes, ``4 c t`` quadrilaterals;
    * interface: in each plate the ``h - 1`` cuts between hole blocks (``c x t`` quads each) and
      the cut between strip and grip (``g x t``), one surface mesh (the short cuts end on the
      long one): ``((2 h - 1) c + 1)(t + 1)`` nodes per plate;
    * tied interface dofs ``D_V^(k)``: an end hole block touches its top and one side,
      ``3 (2 c + 1)(t + 1)``; an inner hole block its top and two sides, ``3 (3 c + 1)(t + 1)``;
      the grip the long cut, ``3 (g + 1)(t + 1)``; a single hole block its top only.

    Args:
        layout: The joint; the default :class:`PinJointLayout` if ``None``.

    Returns:
        A dict with keys ``hexahedra``, ``nodes``, ``dofs`` (whole model), ``half_bandwidth``
        (whole model), ``plate_*``, ``hole_block_*``, ``grip_*`` (``nodes``, ``hexahedra``,
        ``dofs``, ``half_bandwidth``), ``contact_nodes``, ``contact_quads``, ``contact_dofs``,
        ``interface_nodes``, ``interface_quads``, ``interface_dofs``, and
        ``tied_dofs_end_block``, ``tied_dofs_inner_block``, ``tied_dofs_grip``.
    """
    lay = layout or PinJointLayout()
    c, r, t = lay.n_circumferential, lay.n_radial, lay.n_layers
    y, h = lay.n_length, lay.n_holes
    g = h * c
    hole_nodes = 4 * c * (r + 1) * (t + 1)
    grip_nodes = (g + 1) * (y + 1) * (t + 1)
    plate_nodes = (4 * h * c * (r + 1) - (h - 1) * (c + 1) + (g + 1) * y) * (t + 1)
    plate_hex = h * 4 * c * r * t + g * y * t
    plate_b = _plate_half_bandwidth(lay)
    iface_nodes = 2 * ((2 * h - 1) * c + 1) * (t + 1)
    end_sides = 1 if h > 1 else 0  # an end block touches one side, a single block none
    return {
        "hexahedra": 2 * plate_hex,
        "nodes": 2 * plate_nodes,
        "dofs": 6 * plate_nodes,
        "half_bandwidth": plate_b,
        "plate_nodes": plate_nodes,
        "plate_hexahedra": plate_hex,
        "plate_dofs": 3 * plate_nodes,
        "plate_half_bandwidth": plate_b,
        "hole_block_nodes": hole_nodes,
        "hole_block_hexahedra": 4 * c * r * t,
        "hole_block_dofs": 3 * hole_nodes,
        "hole_block_half_bandwidth": 3 * (min(2 * r + 3, 4 * c + 2) * (t + 1) + 2),
        "grip_nodes": grip_nodes,
        "grip_hexahedra": g * y * t,
        "grip_dofs": 3 * grip_nodes,
        "grip_half_bandwidth": half_bandwidth_box(g, y, t),
        "contact_nodes": 4 * c * (t + 1),
        "contact_quads": 4 * c * t,
        "contact_dofs": 12 * c * (t + 1),
        "interface_nodes": iface_nodes,
        "interface_quads": 2 * (h - 1) * c * t + 2 * g * t,
        "interface_dofs": 3 * iface_nodes,
        "tied_dofs_end_block": 3 * ((1 + end_sides) * c + 1) * (t + 1),
        "tied_dofs_inner_block": 3 * (3 * c + 1) * (t + 1),
        "tied_dofs_grip": 3 * (g + 1) * (t + 1),
    }


def _hole_block_mesh(lay: PinJointLayout, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates (mm) and hexahedra of the O-grid hole block ``i`` (local numbering).

    Ring index ``a`` (counter-clockwise from the lower-left corner, ``c`` per block side),
    radial index ``b`` (0 on the hole), layer ``l``: node ``(a (r + 1) + b)(t + 1) + l``.
    Points on the block's boundary are integer multiples of the side element size, so that
    nodes shared with neighbours have bit-identical coordinates.
    """
    c, r, t = lay.n_circumferential, lay.n_radial, lay.n_layers
    n_ring, h_side = 4 * c, lay.pitch / c
    a = np.arange(n_ring)
    side, k = np.divmod(a, c)
    sq = np.select(  # boundary point in side-element units, relative to the block corner
        [(side == q)[:, None] for q in range(4)],
        [np.c_[k, 0 * k], np.c_[c + 0 * k, k], np.c_[c - k, c + 0 * k], np.c_[0 * k, c - k]],
    ) + np.array([i * c, 0])
    theta = np.deg2rad(225.0) + 0.5 * np.pi * a / c
    centre = np.array([(i + 0.5) * lay.pitch, 0.5 * lay.pitch])
    hole = centre + 0.5 * lay.hole_diameter * np.c_[np.cos(theta), np.sin(theta)]
    s = np.arange(r + 1) / r
    xy = hole[:, None, :] * (1.0 - s)[None, :, None] + (sq * h_side)[:, None, :] * s[None, :, None]
    z = np.arange(t + 1) * (lay.thickness / t)
    xyz = np.concatenate(
        [
            np.repeat(xy[:, :, None, :], t + 1, axis=2),
            np.broadcast_to(z[None, None, :, None], (n_ring, r + 1, t + 1, 1)),
        ],
        axis=3,
    ).reshape(-1, 3)
    idx = np.arange(xyz.shape[0]).reshape(n_ring, r + 1, t + 1)
    ia, ib, il = np.meshgrid(np.arange(n_ring), np.arange(r), np.arange(t), indexing="ij")
    ia1 = (ia + 1) % n_ring
    hexes = np.stack(
        [idx[aa, ib + db, il + dl] for aa in (ia, ia1) for db in (0, 1) for dl in (0, 1)], axis=-1
    ).reshape(-1, 8)
    return xyz, hexes


def _box_mesh(
    n: tuple[int, int, int], origin: Sequence[float], h: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and hexahedra of a structured box (x slowest, z fastest)."""
    axes = [origin[d] + np.arange(n[d] + 1) * h[d] for d in range(3)]
    xyz = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    idx = np.arange(xyz.shape[0]).reshape(n[0] + 1, n[1] + 1, n[2] + 1)
    i, j, k = np.meshgrid(*(np.arange(m) for m in n), indexing="ij")
    hexes = np.stack(
        [idx[i + di, j + dj, k + dk] for di in (0, 1) for dj in (0, 1) for dk in (0, 1)], axis=-1
    ).reshape(-1, 8)
    return xyz, hexes


def _plate_mesh(lay: PinJointLayout) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates and hexahedra of one plate (hole blocks and grip, shared nodes merged)."""
    c, t = lay.n_circumferential, lay.n_layers
    g = lay.n_holes * c
    h_side = lay.pitch / c
    parts = [_hole_block_mesh(lay, i) for i in range(lay.n_holes)]
    parts.append(
        _box_mesh(
            (g, lay.n_length, t),
            (0.0, c * h_side, 0.0),
            (h_side, lay.free_length / lay.n_length, lay.thickness / t),
        )
    )
    offsets = np.cumsum([0] + [p[0].shape[0] for p in parts])
    xyz = np.concatenate([p[0] for p in parts])
    hexes = np.concatenate([p[1] + o for p, o in zip(parts, offsets[:-1], strict=True)])
    unique, inverse = np.unique(xyz, axis=0, return_inverse=True)
    return unique, inverse.ravel()[hexes]


def _span_half_bandwidth(rank: np.ndarray, hexes: np.ndarray, dofs_per_node: int) -> int:
    r = rank[hexes]
    return dofs_per_node * int((r.max(axis=1) - r.min(axis=1)).max()) + dofs_per_node


def _rank_of(order: np.ndarray) -> np.ndarray:
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank


def _best_half_bandwidth(xyz: np.ndarray, hexes: np.ndarray, dofs_per_node: int = 3) -> int:
    """Smallest half-bandwidth of four frontal numberings of a plate-like hexahedral mesh.

    For each in-plane axis ``a`` in (x, y): (1) lexicographic by coordinates, ``a`` slowest,
    then the other in-plane axis, z fastest; (2) Cuthill-McKee level structure from the face
    ``a = min`` (graph distance in element hops), inside a level by the other in-plane axis,
    then z. On a structured box numbering (1) with the longer axis is the natural numbering of
    :func:`half_bandwidth_structured_hex`.
    """
    n = xyz.shape[0]
    ranks = []
    for a in (0, 1):
        other = 1 - a
        ranks.append(_rank_of(np.lexsort((xyz[:, 2], xyz[:, other], xyz[:, a]))))
        level = np.full(n, -1, dtype=np.int64)
        front = xyz[:, a] == xyz[:, a].min()
        level[front] = 0
        depth = 0
        while front.any():  # next level: unvisited nodes of the cells touching the front
            depth += 1
            reached = np.zeros(n, dtype=bool)
            reached[hexes[front[hexes].any(axis=1)]] = True
            front = reached & (level < 0)
            level[front] = depth
        ranks.append(_rank_of(np.lexsort((xyz[:, 2], xyz[:, other], level))))
    return min(_span_half_bandwidth(rank, hexes, dofs_per_node) for rank in ranks)


@functools.lru_cache(maxsize=8)
def _plate_half_bandwidth(lay: PinJointLayout) -> int:
    """Half-bandwidth of one plate of the pin joint: :func:`_best_half_bandwidth` of its mesh.

    The mesh is generated here only as integer connectivity and node coordinates (numpy, no
    mesher): no closed form gives a good numbering of a row of O-grids next to a box. Cached.
    """
    xyz, hexes = _plate_mesh(lay)
    return _best_half_bandwidth(xyz, hexes)


def pin_joint_sizes(
    active_holes: int = 10,
    steps: int = 10000,
    changes: int = 20000,
    layout: PinJointLayout | None = None,
) -> SceneSizes:
    """Scene of the multi-pin joint (method.md 7.2) with ``active_holes`` holes in contact.

    Subdomains, in order: upper plate ``U-hole1 ... U-hole<h>``, ``U-grip``, then the lower
    plate ``L-...`` (:func:`pin_joint_mesh_counts` gives their sizes). Contact interfaces exist
    only on the holes in contact: pin 1 in the upper plate, pin 1 in the lower plate, pin 2 in
    the upper plate, ... (``active_holes`` of the ``2 n_holes`` holes). All of them change state
    together: ``alpha^(k) = gamma = changes``.

    The two plates touch only the (rigid) pins, so the whole model is two disjoint bodies and
    the interface two disjoint pieces; like the paper's model we still price the interface
    matrix and the coupled contact block of w-v-u and w-u as single dense matrices (an
    implementation that factorised each body's block separately would be cheaper there).

    Args:
        active_holes: Holes in contact, ``1 <= active_holes <= 2 n_holes``.
        steps: ``N_TS``.
        changes: ``gamma`` (and each ``alpha``).
        layout: The joint; the default :class:`PinJointLayout` if ``None``.

    Returns:
        The scene.
    """
    lay = layout or PinJointLayout()
    h = lay.n_holes
    if not _is_int(active_holes) or not 1 <= active_holes <= 2 * h:
        raise ValueError(f"active_holes must be in 1..{2 * h}, got {active_holes!r}")
    m = pin_joint_mesh_counts(lay)
    subdomains = []
    for plate in "UL":
        for i in range(h):
            end = i in (0, h - 1)
            tied = m["tied_dofs_end_block"] if end else m["tied_dofs_inner_block"]
            subdomains.append(
                SubdomainCounts(
                    f"{plate}-hole{i + 1}",
                    m["hole_block_dofs"],
                    m["hole_block_half_bandwidth"],
                    tied,
                )
            )
        subdomains.append(
            SubdomainCounts(
                f"{plate}-grip", m["grip_dofs"], m["grip_half_bandwidth"], m["tied_dofs_grip"]
            )
        )
    contacts = []
    for j in range(active_holes):
        pin, plate = divmod(j, 2)
        k = plate * (h + 1) + pin
        contacts.append(
            ContactCounts(f"Gamma_C {subdomains[k].name}", m["contact_dofs"], k, changes)
        )
    return SceneSizes(
        subdomains=tuple(subdomains),
        contacts=tuple(contacts),
        interface_dofs=m["interface_dofs"],
        n_steps=steps,
        gamma=changes,
        whole=MeshCounts("Omega (both plates)", m["dofs"], m["half_bandwidth"]),
    )


# --------------------------------------------------------------------------- scene files

_SCENE_KEYS = {"name", "n_steps", "gamma", "interface", "subdomains", "contacts", "whole"}
_SUBDOMAIN_KEYS = {"name", "dofs", "half_bandwidth", "interface_dofs"}
_CONTACT_KEYS = {"name", "dofs", "subdomain", "alpha"}
_INTERFACE_KEYS = {"name", "dofs"}
_WHOLE_KEYS = {"name", "dofs", "half_bandwidth"}


def scene_to_dict(sizes: SceneSizes, name: str | None = None) -> dict[str, Any]:
    """JSON-serialisable scene description, the inverse of :func:`scene_from_dict`.

    Args:
        sizes: The scene.
        name: Optional title stored under ``"name"``.

    Returns:
        A dict following the schema of :func:`scene_from_dict` (contacts refer to subdomains by
        name).
    """
    out: dict[str, Any] = {} if name is None else {"name": name}
    out["n_steps"] = sizes.n_steps
    out["gamma"] = sizes.gamma
    out["interface"] = (
        None
        if sizes.interface_dofs is None
        else {"name": sizes.interface_name, "dofs": sizes.interface_dofs}
    )
    subs = []
    for sd in sizes.subdomains:
        d: dict[str, Any] = {"name": sd.name, "dofs": sd.dofs, "half_bandwidth": sd.half_bandwidth}
        if sd.interface_dofs is not None:
            d["interface_dofs"] = sd.interface_dofs
        subs.append(d)
    out["subdomains"] = subs
    out["contacts"] = [
        {
            "name": c.name,
            "dofs": c.dofs,
            "subdomain": sizes.subdomains[c.subdomain].name,
            "alpha": c.alpha,
        }
        for c in sizes.contacts
    ]
    out["whole"] = dataclasses.asdict(sizes.whole)
    return out


def _fields(obj: Any, where: str, allowed: set[str], required: Sequence[str]) -> dict[str, Any]:
    if not isinstance(obj, dict):
        raise ValueError(f"{where}: expected a JSON object, got {type(obj).__name__}")
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise ValueError(
            f"{where}: unknown key {unknown[0]!r} (allowed: {', '.join(sorted(allowed))})"
        )
    for key in required:
        if key not in obj:
            raise ValueError(f"{where}: missing key {key!r}")
    return obj


def _int_field(obj: Mapping[str, Any], key: str, where: str, minimum: int) -> int:
    value = obj[key]
    if not _is_int(value) or value < minimum:
        kind = "a positive" if minimum == 1 else "a non-negative"
        raise ValueError(f"{where}.{key} must be {kind} integer, got {value!r}")
    return int(value)


def _name_field(obj: Mapping[str, Any], where: str, default: str) -> str:
    name = obj.get("name", default)
    if not isinstance(name, str) or not name:
        raise ValueError(f"{where}.name must be a non-empty string, got {name!r}")
    return name


def scene_from_dict(data: Any, source: str = "scene") -> SceneSizes:
    """Validate a scene description (parsed JSON) and build its :class:`SceneSizes`.

    Schema (``docs/cost.md`` has an annotated example)::

        {
          "name": "optional title",
          "n_steps": N_TS,                       # >= 0
          "gamma": changes in the whole model,   # max(alpha) <= gamma <= sum(alpha)
          "interface": {"name": "Gamma_I", "dofs": D_V} or null / absent (no interface),
          "subdomains": [                        # at least one
            {"name": "Omega1", "dofs": D_U, "half_bandwidth": B_U,
             "interface_dofs": D_V^(k)},         # optional: default all D_V, 0 = not tied
            ...
          ],
          "contacts": [                          # at least one, at most one per subdomain
            {"name": "Gamma_C1", "dofs": D_W,
             "subdomain": "Omega1" or 0,         # owner, by name or 0-based index
             "alpha": changes on this contact interface},
            ...
          ],
          "whole": {"name": "Omega", "dofs": D, "half_bandwidth": B}
                     # optional: the undecomposed model for FULL and w-u; default: the sum of
                     # the subdomain dofs and the largest subdomain half-bandwidth
        }

    Args:
        data: The parsed JSON.
        source: Prefix of error messages (e.g. the file name).

    Returns:
        The scene.

    Raises:
        ValueError: On a missing or unknown key, a number that is not a (positive or
            non-negative) integer, a contact interface pointing at an unknown subdomain, or an
            inconsistent scene (e.g. ``gamma`` outside ``[max(alpha), sum(alpha)]``); the message
            names the offending entry.
    """
    top = _fields(data, source, _SCENE_KEYS, ("n_steps", "gamma", "subdomains", "contacts"))
    n_steps = _int_field(top, "n_steps", source, 0)
    gamma = _int_field(top, "gamma", source, 0)

    interface_dofs, interface_name = None, "Gamma_I"
    if top.get("interface") is not None:
        where = f"{source}: interface"
        iface = _fields(top["interface"], where, _INTERFACE_KEYS, ("dofs",))
        interface_dofs = _int_field(iface, "dofs", where, 1)
        interface_name = _name_field(iface, where, interface_name)

    raw_subs = top["subdomains"]
    if not isinstance(raw_subs, list) or not raw_subs:
        raise ValueError(f"{source}: subdomains must be a non-empty list")
    subdomains = []
    for k, raw in enumerate(raw_subs):
        where = f"{source}: subdomains[{k}]"
        sd = _fields(raw, where, _SUBDOMAIN_KEYS, ("dofs", "half_bandwidth"))
        name = _name_field(sd, where, f"Omega{k + 1}")
        dofs = _int_field(sd, "dofs", where, 1)
        band = _int_field(sd, "half_bandwidth", where, 1)
        if band > dofs:
            raise ValueError(f"{where}: half_bandwidth {band} > dofs {dofs}")
        tied = None
        if sd.get("interface_dofs") is not None:
            tied = _int_field(sd, "interface_dofs", where, 0)
            if tied and interface_dofs is None:
                raise ValueError(f"{where}: interface_dofs given but the scene has no interface")
            if interface_dofs is not None and tied > interface_dofs:
                raise ValueError(
                    f"{where}: interface_dofs {tied} > interface dofs {interface_dofs}"
                )
        subdomains.append(SubdomainCounts(name, dofs, band, tied))
    names = [sd.name for sd in subdomains]
    if len(set(names)) != len(names):
        raise ValueError(f"{source}: subdomain names are not unique: {names}")

    raw_contacts = top["contacts"]
    if not isinstance(raw_contacts, list) or not raw_contacts:
        raise ValueError(f"{source}: contacts must be a non-empty list")
    contacts = []
    for k, raw in enumerate(raw_contacts):
        where = f"{source}: contacts[{k}]"
        c = _fields(raw, where, _CONTACT_KEYS, ("dofs", "subdomain", "alpha"))
        owner = c["subdomain"]
        if isinstance(owner, str):
            if owner not in names:
                raise ValueError(
                    f"{where}.subdomain {owner!r} is not a subdomain (known: {', '.join(names)})"
                )
            index = names.index(owner)
        elif _is_int(owner):
            if not 0 <= owner < len(names):
                raise ValueError(
                    f"{where}.subdomain index {owner} is not a subdomain "
                    f"(0..{len(names) - 1}: {', '.join(names)})"
                )
            index = int(owner)
        else:
            raise ValueError(f"{where}.subdomain must be a name or an index, got {owner!r}")
        contacts.append(
            ContactCounts(
                _name_field(c, where, f"Gamma_C{k + 1}"),
                _int_field(c, "dofs", where, 1),
                index,
                _int_field(c, "alpha", where, 0),
            )
        )

    if top.get("whole") is not None:
        where = f"{source}: whole"
        w = _fields(top["whole"], where, _WHOLE_KEYS, ("dofs", "half_bandwidth"))
        dofs, band = _int_field(w, "dofs", where, 1), _int_field(w, "half_bandwidth", where, 1)
        if band > dofs:
            raise ValueError(f"{where}: half_bandwidth {band} > dofs {dofs}")
        whole = MeshCounts(_name_field(w, where, "Omega"), dofs, band)
    else:
        whole = MeshCounts(
            "Omega (merged)",
            sum(sd.dofs for sd in subdomains),
            max(sd.half_bandwidth for sd in subdomains),
        )
    try:
        return SceneSizes(
            subdomains=tuple(subdomains),
            contacts=tuple(contacts),
            interface_dofs=interface_dofs,
            n_steps=n_steps,
            gamma=gamma,
            whole=whole,
            interface_name=interface_name,
        )
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from None


def load_scene(path: str | os.PathLike[str]) -> SceneSizes:
    """Read a scene JSON file (schema: :func:`scene_from_dict`).

    Args:
        path: The file.

    Returns:
        The scene.

    Raises:
        ValueError: If the file is not valid JSON or not a valid scene (message names the file,
            and the line and column of a JSON syntax error).
        OSError: If the file cannot be read.
    """
    text = Path(path).read_text()
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not valid JSON: {err}") from None
    return scene_from_dict(data, str(path))


# --------------------------------------------------------------------------- studies


@dataclass(frozen=True)
class Study:
    """One parameter study of the paper: every algorithm's cost relative to FULL vs a parameter.

    Attributes:
        name: Identifier, used in file names (``flops_<name>.png``).
        title: Chart title.
        xlabel: Label of the varied parameter.
        x: Values of the parameter.
        percent_of_full: ``{algorithm: [100 * cost / FULL cost at each x]}``.
        gflops_total: ``{algorithm: [cost at each x, 1e9 operations]}``.
        xscale: ``"log"`` or ``"linear"``.
        yscale: ``"log"`` or ``"linear"``.
        xticklabels: Optional labels of the ``x`` values (e.g. ``"1:9"``).
        extra: Further series along ``x`` (e.g. the contact subdomain's dofs and bandwidth).
        parameters: The fixed parameters of the study.
    """

    name: str
    title: str
    xlabel: str
    x: tuple[float, ...]
    percent_of_full: Mapping[str, tuple[float, ...]]
    gflops_total: Mapping[str, tuple[float, ...]]
    xscale: str = "log"
    yscale: str = "log"
    xticklabels: tuple[str, ...] | None = None
    extra: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    parameters: Mapping[str, Any] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        """JSON-serialisable form (all fields, tuples as lists)."""
        return json.loads(json.dumps(dataclasses.asdict(self)))


def _study(
    name: str,
    title: str,
    xlabel: str,
    x: Sequence[float],
    scenes: Sequence[SceneSizes],
    **kwargs: Any,
) -> Study:
    reports = [compare(s) for s in scenes]
    algorithms = [a for a in ALGORITHMS if all(a in r for r in reports)]
    return Study(
        name=name,
        title=title,
        xlabel=xlabel,
        x=tuple(x),
        percent_of_full={
            a: tuple(float(r[a].percent_of_full) for r in reports) for a in algorithms
        },
        gflops_total={a: tuple(r[a].gflops_total for r in reports) for a in algorithms},
        **kwargs,
    )


#: N_TS values of the step studies (the paper's 1 ... 10,000).
STEPS_SWEEP: tuple[int, ...] = (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000)
#: gamma values of the contact-change studies.
CHANGES_SWEEP: tuple[int, ...] = (
    1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000, 100000,
)  # fmt: skip
#: Scale factors of the contact interface mesh in the contact-element study.
CONTACT_SCALES: tuple[float, ...] = (0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.4, 2.0)


def parallelepiped_studies(
    elements: tuple[int, int, int] = (400, 100, 10),
    split: tuple[int, int] = (5, 5),
    interface: tuple[int, int] = (100, 10),
    contact: tuple[int, int] = (100, 10),
    steps: int = 10000,
    changes: int = 20000,
) -> list[Study]:
    """The paper's four studies of the bar (method.md 7.1), around the given configuration.

    * ``bar_steps``: ``N_TS`` = 1 ... 10,000 with ``gamma = 2 N_TS``;
    * ``bar_split``: ``Omega1:Omega2`` = 1:9 ... 9:1 (splits that do not divide ``nx`` evenly
      are skipped); the contact subdomain's dofs and half-bandwidth are in ``extra``;
    * ``bar_changes``: ``gamma`` = 1 ... 100,000 at ``N_TS = steps``;
    * ``bar_contact_elements``: the contact interface mesh scaled by :data:`CONTACT_SCALES`
      (``contact`` = 100 x 10 gives 10 x 1 ... 200 x 20 quads); x is the number of contact
      elements, ``D_W`` is in ``extra``.

    Args:
        elements: As for :func:`parallelepiped_sizes`.
        split: As for :func:`parallelepiped_sizes`.
        interface: As for :func:`parallelepiped_sizes`.
        contact: As for :func:`parallelepiped_sizes`.
        steps: As for :func:`parallelepiped_sizes`.
        changes: As for :func:`parallelepiped_sizes`.

    Returns:
        The four studies.
    """
    base = {
        "elements": tuple(elements),
        "split": tuple(split),
        "interface": tuple(interface),
        "contact": tuple(contact),
        "steps": steps,
        "changes": changes,
    }
    params = {k: list(v) if isinstance(v, tuple) else v for k, v in base.items()}

    def sizes(**over: Any) -> SceneSizes:
        return parallelepiped_sizes(**{**base, **over})

    label = f"{elements[0]} x {elements[1]} x {elements[2]} bar"
    studies = [
        _study(
            "bar_steps",
            f"{label}: FLOPs vs number of time steps (gamma = 2 N_TS)",
            "time steps N_TS",
            STEPS_SWEEP,
            [sizes(steps=n, changes=2 * n) for n in STEPS_SWEEP],
            parameters=params,
        )
    ]
    splits = []
    for a in range(1, 10):
        try:
            _split_layers(elements[0], (a, 10 - a))
        except ValueError:
            continue
        splits.append((a, 10 - a))
    split_scenes = [sizes(split=sp) for sp in splits]
    studies.append(
        _study(
            "bar_split",
            f"{label}: FLOPs vs split Omega1:Omega2 (contact on Omega1)",
            "split Omega1:Omega2 (Omega1 holds the contact)",
            [a / 10 for a, _ in splits],
            split_scenes,
            xscale="linear",
            xticklabels=tuple(f"{a}:{b}" for a, b in splits),
            extra={
                "contact_subdomain_dofs": tuple(s.subdomains[0].dofs for s in split_scenes),
                "contact_subdomain_half_bandwidth": tuple(
                    s.subdomains[0].half_bandwidth for s in split_scenes
                ),
            },
            parameters=params,
        )
    )
    studies.append(
        _study(
            "bar_changes",
            f"{label}: FLOPs vs contact state changes (N_TS = {steps:,})",
            "contact state changes gamma",
            CHANGES_SWEEP,
            [sizes(changes=g) for g in CHANGES_SWEEP],
            parameters=params,
        )
    )
    meshes = []
    for s in CONTACT_SCALES:
        m = (max(1, round(contact[0] * s)), max(1, round(contact[1] * s)))
        if m not in meshes:
            meshes.append(m)
    contact_scenes = [sizes(contact=m) for m in meshes]
    studies.append(
        _study(
            "bar_contact_elements",
            f"{label}: FLOPs vs contact interface elements",
            "contact interface elements (quadrilaterals, mesh in brackets)",
            [m0 * m1 for m0, m1 in meshes],
            contact_scenes,
            xticklabels=tuple(f"{m0 * m1}\n({m0}x{m1})" for m0, m1 in meshes),
            extra={"contact_dofs": tuple(s.contacts[0].dofs for s in contact_scenes)},
            parameters=params,
        )
    )
    return studies


def pin_joint_studies(
    steps: int = 10000, changes: int = 20000, layout: PinJointLayout | None = None
) -> list[Study]:
    """The paper's two studies of the multi-pin joint (method.md 7.2).

    * ``pin_steps``: ``N_TS`` = 1 ... 10,000 with ``gamma = 2 N_TS``, every hole in contact;
    * ``pin_holes``: holes in contact 2 ... ``2 n_holes`` at ``N_TS = steps``, ``gamma =
      changes``.

    Args:
        steps: ``N_TS`` of the hole study.
        changes: ``gamma`` of the hole study.
        layout: The joint; the default :class:`PinJointLayout` if ``None``.

    Returns:
        The two studies.
    """
    lay = layout or PinJointLayout()
    n_all = 2 * lay.n_holes
    params = {"layout": dataclasses.asdict(lay), "steps": steps, "changes": changes}
    holes = list(range(min(2, n_all), n_all + 1))
    return [
        _study(
            "pin_steps",
            f"pin joint, {n_all} holes in contact: FLOPs vs time steps (gamma = 2 N_TS)",
            "time steps N_TS",
            STEPS_SWEEP,
            [pin_joint_sizes(n_all, n, 2 * n, lay) for n in STEPS_SWEEP],
            parameters=params,
        ),
        _study(
            "pin_holes",
            f"pin joint: FLOPs vs holes in contact (N_TS = {steps:,}, gamma = {changes:,})",
            "holes in contact",
            holes,
            [pin_joint_sizes(n, steps, changes, lay) for n in holes],
            xscale="linear",
            parameters=params,
        ),
    ]


def _rescaled(sizes: SceneSizes, n_steps: int, gamma: int) -> SceneSizes:
    """``sizes`` with new ``N_TS`` and ``gamma``; each ``alpha`` scaled like ``gamma`` (ceil)."""
    g0 = sizes.gamma
    contacts = tuple(
        dataclasses.replace(c, alpha=gamma if g0 == 0 else math.ceil(c.alpha * gamma / g0))
        for c in sizes.contacts
    )
    return dataclasses.replace(sizes, contacts=contacts, n_steps=n_steps, gamma=gamma)


def scene_studies(sizes: SceneSizes, name: str = "scene") -> list[Study]:
    """Step and contact-change studies of a user's scene.

    * ``<name>_steps``: ``N_TS`` = 1 ... 10,000 with ``gamma`` in the scene's ratio
      ``gamma / N_TS`` (2 if the scene has no steps), at least 1;
    * ``<name>_changes``: ``gamma`` = 1 ... 100,000 at the scene's ``N_TS``.

    Each ``alpha^(k)`` is scaled like ``gamma`` and rounded up, which keeps
    ``max(alpha) <= gamma <= sum(alpha)``.

    Args:
        sizes: The scene.
        name: Prefix of the study names.

    Returns:
        The two studies.
    """
    ratio = sizes.gamma / sizes.n_steps if sizes.n_steps else 2.0
    return [
        _study(
            f"{name}_steps",
            f"{name}: FLOPs vs time steps (gamma = {ratio:.3g} N_TS)",
            "time steps N_TS",
            STEPS_SWEEP,
            [_rescaled(sizes, n, max(1, round(ratio * n))) for n in STEPS_SWEEP],
        ),
        _study(
            f"{name}_changes",
            f"{name}: FLOPs vs contact state changes (N_TS = {sizes.n_steps:,})",
            "contact state changes gamma",
            CHANGES_SWEEP,
            [_rescaled(sizes, sizes.n_steps, g) for g in CHANGES_SWEEP],
        ),
    ]


# --------------------------------------------------------------------------- charts

#: Line colours and markers of the algorithms in every chart.
_STYLE = {
    "FULL": ("black", "o"),
    "v-w-u": ("tab:blue", "s"),
    "w-v-u": ("tab:orange", "^"),
    "w-u": ("tab:green", "D"),
    "v-u": ("tab:red", "v"),
}

MeasuredPoints = Mapping[str, Sequence[Sequence[float]]]


def _read_measured(measured: Any) -> Any:
    if measured is None or isinstance(measured, Mapping):
        return measured
    return json.loads(Path(measured).read_text())


def plot_study(
    study: Study,
    path: str | os.PathLike[str],
    measured: MeasuredPoints | str | os.PathLike[str] | None = None,
) -> Path:
    """Draw ``study`` as a PNG chart (matplotlib, Agg canvas; pyplot is not used).

    Model values are lines with small markers, one per algorithm; FULL is the 100 % line.

    Args:
        study: The study.
        path: Output PNG.
        measured: Hook for measured runs: ``{algorithm: [[x, percent_of_full], ...]}``, or the
            path of a JSON file holding that; drawn as large open markers in the algorithm's
            colour, labelled "measured".

    Returns:
        The path written.
    """
    from matplotlib.figure import Figure

    points = _read_measured(measured) or {}
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.add_subplot()
    for alg, values in study.percent_of_full.items():
        colour, marker = _STYLE.get(alg, ("gray", "x"))
        ax.plot(study.x, values, color=colour, marker=marker, markersize=4, label=f"{alg} (model)")
    for alg, pts in points.items():
        if not pts:
            continue
        colour, marker = _STYLE.get(alg, ("gray", "x"))
        xs, ys = zip(*((float(p[0]), float(p[1])) for p in pts), strict=True)
        ax.plot(
            xs,
            ys,
            linestyle="none",
            marker=marker,
            markersize=9,
            markerfacecolor="none",
            markeredgecolor=colour,
            markeredgewidth=1.6,
            label=f"{alg} (measured)",
        )
    ax.set_xscale(study.xscale)
    ax.set_yscale(study.yscale)
    if study.xticklabels is not None:
        ax.set_xticks(list(study.x), list(study.xticklabels), fontsize=8)
        ax.minorticks_off()
    ax.set_xlabel(study.xlabel)
    ax.set_ylabel("FLOPs relative to FULL [%]")
    ax.set_title(study.title, fontsize=9)
    ax.grid(True, which="major", alpha=0.4)
    ax.legend(fontsize=8)
    out = Path(path)
    fig.savefig(out, dpi=120)
    return out


def write_studies(
    studies: Sequence[Study],
    directory: str | os.PathLike[str],
    measured: Mapping[str, MeasuredPoints] | str | os.PathLike[str] | None = None,
) -> list[Path]:
    """Write ``flops_<name>.png`` and ``flops_<name>.json`` of every study into ``directory``.

    Args:
        studies: The studies.
        directory: Output directory (created if missing).
        measured: Measured points per study, ``{study name: {algorithm: [[x, percent], ...]}}``
            or the path of a JSON file holding that; each study's entry goes to
            :func:`plot_study` and into its JSON under ``"measured"``.

    Returns:
        The files written, PNG then JSON for each study.
    """
    out_dir = Path(directory)
    out_dir.mkdir(parents=True, exist_ok=True)
    all_points = _read_measured(measured) or {}
    written = []
    for study in studies:
        points = all_points.get(study.name)
        png = plot_study(study, out_dir / f"flops_{study.name}.png", points)
        data = study.to_json_dict()
        if points:
            data["measured"] = points
        js = out_dir / f"flops_{study.name}.json"
        js.write_text(json.dumps(data, indent=1) + "\n")
        written += [png, js]
    return written


# --------------------------------------------------------------------------- output


def format_table(reports: Mapping[str, CostReport] | Sequence[CostReport]) -> str:
    """Text table in the style of the paper's Table 2, one block per algorithm.

    Args:
        reports: Reports keyed by algorithm (as from :func:`compare`) or a sequence of them.

    Returns:
        The table; dense matrices show ``dense`` in the bandwidth column.
    """
    items = list(reports.values()) if isinstance(reports, Mapping) else list(reports)
    width = max([24, *(len(m.name) + 2 for r in items for m in r.meshes)])
    head = (
        f"{'mesh':<{width}}{'dofs':>12}{'B':>8}{'decomp.':>10}{'subst.':>14}"
        f"{'GFLOP dec.':>14}{'GFLOP subst.':>14}{'GFLOP':>14}"
    )
    rule = "-" * len(head)
    lines = []
    for r in items:
        pct = "" if r.percent_of_full is None else f"  ({r.percent_of_full:.4g} % of FULL)"
        lines += [f"{r.algorithm}: {r.gflops_total:.6g} GFLOP{pct}", head, rule]
        for m in r.meshes:
            b = "dense" if m.half_bandwidth is None else f"{m.half_bandwidth:,}"
            lines.append(
                f"{m.name:<{width}}{m.dofs:>12,}{b:>8}{m.decompositions:>10,}"
                f"{m.substitutions:>14,}{m.gflops_decomposition:>14.6g}"
                f"{m.gflops_substitution:>14.6g}{m.gflops:>14.6g}"
            )
        lines += [
            rule,
            f"{'total':<{width + 44}}{r.gflops_decomposition:>14.6g}"
            f"{r.gflops_substitution:>14.6g}{r.gflops_total:>14.6g}",
            "",
        ]
    return "\n".join(lines)


def to_json_dict(reports: Mapping[str, CostReport]) -> dict[str, dict[str, Any]]:
    """JSON-serialisable form of reports keyed by algorithm.

    Args:
        reports: Reports keyed by algorithm, e.g. from :func:`compare`.

    Returns:
        ``{algorithm: {"gflops_total", "percent_of_full", "meshes": [{name, dofs,
        half_bandwidth, decompositions, substitutions, gflops_decomposition,
        gflops_substitution}, ...]}}``; ``half_bandwidth`` is ``None`` for dense matrices.
    """
    return {
        key: {
            "gflops_total": r.gflops_total,
            "percent_of_full": r.percent_of_full,
            "meshes": [dataclasses.asdict(m) for m in r.meshes],
        }
        for key, r in reports.items()
    }
