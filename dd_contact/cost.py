"""Operation-count (FLOP) model of the paper's solution algorithms.

Implements section 6 of ``method.md`` (Kim, Ryu, Shin 2007, Table 1 and Table 2): the number of
LU decompositions and single right-hand-side substitutions each algorithm performs on each mesh,
priced with four kernels (one multiply-add counts as one operation):

* ``f1(D) = D**3 / 3``                      dense factorisation,
* ``f2(D) = 1.5 * D**2``                    dense forward + back substitution,
* ``f3(D, B) = D * B**2 - (2/3) * B**3``    banded factorisation, half-bandwidth ``B``,
* ``f4(D, B) = 3 * D * B``                  banded substitution.

Notation: ``D_U``/``B_U`` dofs and half-bandwidth of a subdomain, ``D_V`` interface dofs, ``D_W``
contact-interface dofs, ``N_TS`` time steps, ``alpha^(k)`` contact state changes on contact
interface ``k``, ``gamma`` contact state changes in the whole model. Matrix assembly and
matrix-matrix products (e.g. ``P^T (K^-1 P)``) are not counted, as in the paper.

Algorithms (the name lists the order in which the unknowns are obtained):

* ``"FULL"``: one banded matrix of the whole model, contact on its boundary.
* ``"v-w-u"``: condense u, then w, solve v; back-substitute w, then u (paper's Table 1).
* ``"w-v-u"``: condense u, then v, solve w; back-substitute v, then u.
* ``"w-u"``: no interface; the subdomains are merged into the whole model, contact interfaces
  only.
* ``"v-u"``: no contact interfaces; contact acts on the boundary of the subdomain that owns it.

The derivation of each order is in the docstring of its private ``_counts_*`` function. All counts
are pure arithmetic; nothing here imports dolfinx.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = [
    "ALGORITHMS",
    "ContactCounts",
    "CostReport",
    "MeshCost",
    "MeshCounts",
    "SceneSizes",
    "SubdomainCounts",
    "applicable_algorithms",
    "compare",
    "f1",
    "f2",
    "f3",
    "f4",
    "format_table",
    "half_bandwidth_structured_hex",
    "operation_counts",
    "parallelepiped_sizes",
    "to_json_dict",
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


def _check_positive(name: str, value: int) -> None:
    if int(value) != value or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")


def _check_non_negative(name: str, value: int) -> None:
    if int(value) != value or value < 0:
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
        tied: Whether the subdomain is tied to the interface ``Gamma_I``.
    """

    name: str
    dofs: int
    half_bandwidth: int
    tied: bool = True

    def __post_init__(self) -> None:
        MeshCounts(self.name, self.dofs, self.half_bandwidth)  # same validation


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
    return "+".join(c.name for c in s.contacts), sum(c.dofs for c in s.contacts)


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
      columns, only if it owns a contact interface), ``K_D^-1 P_DI2`` (``D_V`` columns, only if
      tied), ``u_hat`` (``N_TS``) and ``u`` (``N_TS``): ``D_W + D_V + 2 N_TS`` substitutions.
    * ``Gamma_C^(k)``: ``f1(D_W)`` ``1 + alpha`` times; ``f2(D_W)`` for ``K_CI^-1 P_CD``
      (``(1 + alpha) D_V``), ``K_CI^-1 p_C2`` (``N_TS + alpha``) and ``w`` (``N_TS + gamma``).
    * ``Gamma_I``: ``f1(D_V)`` ``1 + gamma`` times; ``f2(D_V)`` for ``v``, ``N_TS + gamma`` times.
    """
    d_v = _require_interface(s, "v-w-u")
    n, g = s.n_steps, s.gamma
    out = []
    for k, sd in enumerate(s.subdomains):
        c = s.contact_of(k)
        cols = (c.dofs if c else 0) + (d_v if sd.tied else 0)
        out.append(_banded(sd.name, sd.dofs, sd.half_bandwidth, 1, cols + 2 * n))
    for c in s.contacts:
        n_sub = (1 + c.alpha) * d_v + (n + c.alpha) + (n + g)
        out.append(_dense(c.name, c.dofs, 1 + c.alpha, n_sub))
    out.append(_dense(s.interface_name, d_v, 1 + g, n + g))
    return out


def _counts_wvu(s: SceneSizes) -> list[MeshCost]:
    """w-v-u: condense u, then v, solve w; back-substitute v, then u.

    Derivation (same bookkeeping as Table 1):

    * ``Omega^(k)``: identical to v-w-u (``K_D`` is contact independent): ``f3`` once,
      ``f4`` ``D_W + D_V + 2 N_TS`` times.
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
        cols = (c.dofs if c else 0) + (d_v if sd.tied else 0)
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
    ``f1(D_W) + f2(D_W)``, does not depend on any volume bandwidth.
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
      times; ``f4`` for ``K_D^-1 P_DI2`` after every factorisation (``(1 + alpha) D_V``),
      ``u_hat`` at each step and after each own change (``N_TS + alpha``), and ``u`` at each step
      and each change anywhere (``N_TS + gamma``; the contact check needs ``u`` on the boundary,
      and ``u`` depends on ``v``).
    * Other subdomains: as in v-w-u without contact columns: ``f3`` once, ``f4`` ``D_V + 2 N_TS``.
    * ``Gamma_I``: ``K_DI_hat`` contains every ``K_D^-1``, so ``f1(D_V)`` ``1 + gamma`` times;
      ``f2(D_V)`` for ``v`` ``N_TS + gamma`` times.

    This is the only order whose cost per contact change grows with the contact subdomain's
    half-bandwidth (through ``f3(D_U, B_U) + f4(D_U, B_U) (D_V + 2)``).
    """
    d_v = _require_interface(s, "v-u")
    n, g = s.n_steps, s.gamma
    out = []
    for k, sd in enumerate(s.subdomains):
        c = s.contact_of(k)
        dv_cols = d_v if sd.tied else 0
        if c is None:
            out.append(_banded(sd.name, sd.dofs, sd.half_bandwidth, 1, dv_cols + 2 * n))
        else:
            n_sub = (1 + c.alpha) * dv_cols + (n + c.alpha) + (n + g)
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


# --------------------------------------------------------------------------- paper's bar


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
    of ``nx * split[0] / sum(split)`` and the remaining element layers; each is numbered x
    slowest, so each has ``(layers + 1)(ny + 1)(nz + 1) * 3`` dofs and the half-bandwidth of
    :func:`half_bandwidth_structured_hex`. Note that with this numbering the half-bandwidth
    depends only on the cross-section, so the split ratio changes ``D_U`` but not ``B_U``.
    Interface and contact interface are structured quad meshes, ``(m0 + 1)(m1 + 1) * 3`` dofs;
    the contact interface sits on an end face of subdomain 1 (index 0). ``alpha = gamma =
    changes``. ``"FULL"`` and ``"w-u"`` use the whole bar, ``(nx+1)(ny+1)(nz+1) * 3`` dofs.

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
    total = sum(split)
    if (nx * split[0]) % total != 0:
        raise ValueError(f"split {split} does not divide {nx} element layers evenly")
    layers1 = nx * split[0] // total
    layers = (layers1, nx - layers1)
    if min(layers) < 1:
        raise ValueError(f"split {split} leaves an empty subdomain")
    per_layer = (ny + 1) * (nz + 1) * 3
    subdomains = tuple(
        SubdomainCounts(
            f"Omega{i + 1}", (n + 1) * per_layer, half_bandwidth_structured_hex(n, ny, nz)
        )
        for i, n in enumerate(layers)
    )
    quad_dofs = [(m0 + 1) * (m1 + 1) * 3 for m0, m1 in (interface, contact)]
    return SceneSizes(
        subdomains=subdomains,
        contacts=(ContactCounts("Gamma_C1", quad_dofs[1], 0, changes),),
        interface_dofs=quad_dofs[0],
        n_steps=steps,
        gamma=changes,
        whole=MeshCounts("Omega", (nx + 1) * per_layer, half_bandwidth_structured_hex(nx, ny, nz)),
    )


# --------------------------------------------------------------------------- output


def format_table(reports: Mapping[str, CostReport] | Sequence[CostReport]) -> str:
    """Text table in the style of the paper's Table 2, one block per algorithm.

    Args:
        reports: Reports keyed by algorithm (as from :func:`compare`) or a sequence of them.

    Returns:
        The table; dense matrices show ``dense`` in the bandwidth column.
    """
    items = list(reports.values()) if isinstance(reports, Mapping) else list(reports)
    head = (
        f"{'mesh':<24}{'dofs':>12}{'B':>8}{'decomp.':>10}{'subst.':>14}"
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
                f"{m.name:<24}{m.dofs:>12,}{b:>8}{m.decompositions:>10,}{m.substitutions:>14,}"
                f"{m.gflops_decomposition:>14.6g}{m.gflops_substitution:>14.6g}{m.gflops:>14.6g}"
            )
        lines += [
            rule,
            f"{'total':<68}{r.gflops_decomposition:>14.6g}{r.gflops_substitution:>14.6g}"
            f"{r.gflops_total:>14.6g}",
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
