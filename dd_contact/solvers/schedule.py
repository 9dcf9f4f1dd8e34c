"""The elimination schedule: what each algorithm factorises and substitutes, and when.

This module is the one description of the algorithms (method.md section 5). The engine
(:mod:`dd_contact.solvers.engine`) executes it, :mod:`dd_contact.timing` prices it with
measured rates, and :mod:`dd_contact.paper.flops` counts it with the paper's kernels. It knows
sizes, blocks (:class:`~dd_contact.blocks.Block`) and couplings only: no PETSc, no dolfinx.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from dd_contact.blocks import Block, BlockKeyed

__all__ = [
    "ALGORITHMS",
    "CONDENSATIONS",
    "CONDENSATION_CHUNK",
    "ORDERS",
    "SWEEPS",
    "FullSchedule",
    "Group",
    "Operation",
    "Schedule",
    "condensation_chunks",
    "fitting_algorithms",
    "region_blocks",
    "run_operations",
]

#: Surface levels eliminated after the subdomains, first to last, for every order. The name
#: lists the unknowns in the order they are obtained, i.e. the levels read backwards.
ORDERS: dict[str, tuple[str, ...]] = {
    "v-w-u": ("w", "v"),
    "w-v-u": ("v", "w"),
    "w-u": ("w",),
    "v-u": ("v",),
}

#: Every algorithm, baseline first: FULL factorises the whole system as one matrix.
ALGORITHMS: tuple[str, ...] = ("FULL", *ORDERS)

#: Ways to form a subdomain's condensed operator ``C^T K^-1 C``: MUMPS's Schur complement
#: within the factorisation, or one substitution per coupling column.
CONDENSATIONS = ("schur", "multi-rhs")

#: Right-hand sides per MUMPS multi-RHS solve when condensing with ``"multi-rhs"``.
CONDENSATION_CHUNK = 256

#: Work kinds of the two halves of a subdomain substitution split by MUMPS's Schur phases:
#: the reduction (a forward sweep, giving the surface right-hand side) and the expansion (a
#: backward sweep, giving u). Each is half a substitution.
SWEEPS = ("sparse_forward", "sparse_backward")


def fitting_algorithms(
    has_interface: bool, has_contact_interfaces: bool, variants: bool = False
) -> tuple[str, ...]:
    """The algorithms that fit a scene: ``v`` needs an interface, ``w`` contact interfaces.

    Args:
        has_interface: The scene has an interface mesh (unknowns ``v``).
        has_contact_interfaces: The scene has contact-interface meshes (unknowns ``w``).
        variants: ``False``: what runs on the scene as built, i.e. FULL and the orders whose
            levels are exactly the scene's surface unknowns. ``True``: the paper's
            operation-count reading, where each algorithm runs on its own variant of the
            model (w-u merges the subdomains, dropping the interface; v-u puts contact on
            the subdomain's boundary, dropping the contact interfaces), i.e. FULL and the
            orders whose levels the scene has.

    Returns:
        The fitting algorithms in :data:`ALGORITHMS` order.
    """
    kinds = {kind for kind, has in (("v", has_interface), ("w", has_contact_interfaces)) if has}
    fit = [
        name
        for name, levels in ORDERS.items()
        if (set(levels) <= kinds if variants else set(levels) == kinds)
    ]
    return ("FULL", *fit)


def region_blocks(blocks: str | tuple[str, ...]) -> tuple[Block, ...]:
    """The blocks a contact region's matrix couples, from one block or several.

    One for contact against an obstacle (a contact interface ``w`` or, on a subdomain's own
    boundary, ``u``); two for a contact pair between the surfaces of two bodies.
    """
    names = (blocks,) if isinstance(blocks, str) else tuple(blocks)
    if not names:
        raise ValueError("a contact region couples at least one block")
    return tuple(Block.parse(b) for b in names)


def condensation_chunks(m: int) -> list[tuple[int, int]]:
    """Column ranges of the multi-RHS solves that condense ``m`` coupling columns."""
    return [(j0, min(m, j0 + CONDENSATION_CHUNK)) for j0 in range(0, m, CONDENSATION_CHUNK)]


@dataclass(frozen=True)
class Group:
    """Surface blocks eliminated together by one dense factorisation.

    Attributes:
        blocks: The blocks: those not coupled to a later level first (the rows its
            condensation skips), each part sorted.
        last: In the order's last level: solved for, not eliminated.
        neighbours: Blocks of later levels coupled to the group (after the fill-in of
            the earlier eliminations): what eliminating it changes.
    """

    blocks: tuple[Block, ...]
    last: bool
    neighbours: tuple[Block, ...]

    @property
    def name(self) -> str:
        """The blocks, sorted, joined by ``+`` (the name in the work log)."""
        return "+".join(sorted(self.blocks))


@dataclass(frozen=True)
class Operation:
    """One factorisation or substitution the schedule calls for.

    Attributes:
        target: A subdomain block (sparse) or a group name (dense).
        kind: ``"sparse_factor"``, ``"schur"`` (MUMPS's Schur complement of a subdomain
            factorisation), ``"sparse_solve"``, ``"sparse_forward"`` or
            ``"sparse_backward"`` (the halves of a substitution, :data:`SWEEPS`),
            ``"dense_factor"`` or ``"dense_solve"``.
        size: Rows of the matrix, or of the solved vectors for sparse solves.
        nrhs: Right-hand sides (0 for factorisations).
        what: What a solve is for: ``"condense"``, ``"u_hat"``, ``"u"``, ``"y"`` (a group's
            forward elimination), ``"x"`` (a group's solution).
        analysis: A sparse factorisation that includes the symbolic analysis (the first).
    """

    target: str
    kind: str
    size: int
    nrhs: int = 0
    what: str = ""
    analysis: bool = False


def _plan_groups(
    surface: dict[Block, int], pairs: set, levels: tuple[str, ...]
) -> list[list[Group]]:
    """The groups of each level: connected blocks of the level's kind, given the fill-in."""
    coupled = {frozenset(p) for p in pairs if p[0] != p[1]}
    remaining = set(surface)
    all_groups = []
    for li, kind in enumerate(levels):
        level = sorted(b for b in remaining if b.kind == kind)
        members: list[list[Block]] = []
        for b in level:
            joined = [m for m in members if any(frozenset((b, a)) in coupled for a in m)]
            members = [m for m in members if m not in joined] + [
                [b] + [a for m in joined for a in m]
            ]
        remaining -= set(level)
        groups = []
        for m in members:
            neighbours = sorted(
                r for r in remaining if any(frozenset((a, r)) in coupled for a in m)
            )
            for r1 in neighbours:  # fill-in of the elimination
                for r2 in neighbours:
                    if r1 != r2:
                        coupled.add(frozenset((r1, r2)))
            # coupled blocks last: B's leading rows are zero, which the condensation skips
            ordered = sorted(
                m, key=lambda a: (any(frozenset((a, r)) in coupled for r in neighbours), a)
            )
            groups.append(Group(tuple(ordered), li == len(levels) - 1, tuple(neighbours)))
        all_groups.append(groups)
    return all_groups


class Schedule:
    """What one order factorises and substitutes, and when: the rules the engine follows.

    The engine condenses every subdomain first (its sparse factorisation made once, again
    only when contact on its own boundary changes its matrix), which leaves a dense system
    on the surface blocks; the order's levels then eliminate the surface blocks group by
    group (:attr:`groups`). A group is re-factorised when something it depends on changed
    (:meth:`stale_groups`), and solved when it is stale, its right-hand side is new, or it
    is in the last level (:meth:`solves`).

    Args:
        order: One of :data:`ORDERS`.
        sizes: Size of every block (subdomains ``u:``, interface ``v:``, contact ``w:``).
        layouts: Per subdomain block, ``(surface block, tied dofs)`` of each coupling: the
            non-zero columns of its coupling matrices.
        base_pairs: Surface block pairs with a matrix of their own (either orientation).
        regions: Contact region -> the block it acts on (``w:`` or, for contact on a
            subdomain's own boundary, ``u:``), or the blocks its matrix couples: a contact
            pair between two bodies couples two (:func:`region_blocks`); they are always
            eliminated in one group, so a change on the pair re-factorises that group.
        condensation: One of :data:`CONDENSATIONS`.
        split_substitution: Substitute a subdomain once per right-hand side, split in a
            forward sweep (the surface right-hand side) and a backward sweep (u), as
            MUMPS's Schur phases do (the paper's Tables 2 and 3); ``False``: two full
            substitutions, u_hat and u (its Table 1). Default: with ``"schur"``.
    """

    def __init__(
        self,
        order: str,
        sizes: BlockKeyed[int],
        layouts: BlockKeyed[list],
        base_pairs: set,
        regions: Mapping[str, str | tuple[str, ...]],
        condensation: str = "schur",
        split_substitution: bool | None = None,
    ):
        if order not in ORDERS:
            raise ValueError(f"unknown order {order!r}; valid: {', '.join(ORDERS)}")
        if condensation not in CONDENSATIONS:
            raise ValueError(
                f"unknown condensation {condensation!r}; valid: {', '.join(CONDENSATIONS)}"
            )
        self.order, self.levels, self.condensation = order, ORDERS[order], condensation
        if split_substitution is None:
            split_substitution = condensation == "schur"
        self.split_substitution = split_substitution
        blocks = {Block.parse(b): n for b, n in sizes.items()}
        self.surface = {b: n for b, n in blocks.items() if b.kind != "u"}
        self.subdomains = {b: n for b, n in blocks.items() if b.kind == "u"}
        self.layouts = {Block.parse(b): layout for b, layout in layouts.items()}
        #: Contact region -> the blocks its contact matrix couples.
        self.regions = {key: region_blocks(b) for key, b in regions.items()}
        #: Per subdomain: surface block -> (offset in the condensed operator Z, tied dofs).
        self.tied_at: dict[Block, dict[Block, tuple[int, np.ndarray]]] = {}
        pairs = {(a, b) for a, b in base_pairs} | {(b, a) for a, b in base_pairs}
        self.base_pairs = frozenset(pairs)
        for block, layout in self.layouts.items():
            offsets = np.cumsum([0] + [len(J) for _, J in layout])
            self.tied_at[block] = {s: (int(offsets[i]), J) for i, (s, J) in enumerate(layout)}
            pairs |= {(a, b) for a, _ in layout for b, _ in layout}
        for coupled in self.regions.values():  # a contact pair's blocks are one group
            pairs |= {(a, b) for a in coupled for b in coupled if a != b}
        #: Surface block pairs that are not zero after the subdomain condensation.
        self.pairs = frozenset(pairs)
        #: The groups of each level, first level first.
        self.groups = _plan_groups(self.surface, pairs, self.levels)
        self.flat = [g for level in self.groups for g in level]
        needed = {b for blocks in self.regions.values() for b in blocks}
        #: Blocks the contact check reads that are not in the last level: every solve of the
        #: contact iteration must back-substitute the earlier levels too.
        self.needs_all_surface = any(b.kind != self.levels[-1] for b in needed)
        #: Subdomains with contact on their own boundary: back-substituted in every solve.
        self.needed_u = sorted(b for b in needed if b.kind == "u")

    # -- the rules -------------------------------------------------------------------------
    def coupling_size(self, block: Block) -> int:
        """Columns of a subdomain's couplings: the size of its condensed operator."""
        return sum(len(J) for _, J in self.layouts.get(block, []))

    def touched(self, *blocks: str) -> set[str]:
        """Surface blocks whose matrices change when ``blocks`` change.

        A surface block itself; for a subdomain (re-condensed after its own contact changed),
        the surface blocks it is tied to.
        """
        out: set[str] = set()
        for block in map(Block.parse, blocks):
            out |= set(self.tied_at.get(block, {})) if block.kind == "u" else {block}
        return out

    def stale_groups(self, changed: set[str]) -> set[str]:
        """Names of the groups to re-factorise after the surface blocks ``changed`` changed.

        A group is stale if one of its blocks changed, or if an earlier stale group is
        eliminated into it (its neighbours are among the group's blocks).
        """
        stale: set[str] = set()
        for g in self.flat:  # earlier levels first: one pass propagates
            if set(g.blocks) & changed or any(
                set(h.neighbours) & set(g.blocks) for h in self.flat if h.name in stale
            ):
                stale.add(g.name)
        return stale

    @staticmethod
    def solves(group: Group, stale: set[str], new_rhs: bool) -> bool:
        """Whether a solve substitutes with ``group``: last level, re-factorised, or new rhs."""
        return group.last or group.name in stale or new_rhs

    def coupling_columns(self, g: Group) -> int:
        """Coupling columns of a group to its later neighbours (what its condensation solves).

        A neighbour with a matrix of its own couples all its dofs; one coupled only through
        subdomain condensations couples the dofs those subdomains tie.
        """
        total = 0
        for r in g.neighbours:
            if any((a, r) in self.base_pairs for a in g.blocks):
                total += self.surface[r]
                continue
            tied = [
                w[r][1] for w in self.tied_at.values() if r in w and any(a in w for a in g.blocks)
            ]
            total += len(np.unique(np.concatenate(tied))) if tied else 0
        return total

    # -- the plans -------------------------------------------------------------------------
    def factorise_subdomain(self, block: Block, analysis: bool) -> list[Operation]:
        """Factorise a subdomain and condense its couplings."""
        n, m = self.subdomains[block], self.coupling_size(block)
        if self.condensation == "schur" and m:
            return [
                Operation(block, "sparse_factor", n, analysis=analysis),
                Operation(block, "schur", m),
            ]
        ops = [Operation(block, "sparse_factor", n, analysis=analysis)]
        ops += [
            Operation(block, "sparse_solve", n, j1 - j0, "condense")
            for j0, j1 in condensation_chunks(m)
        ]
        return ops

    def substitute_subdomain(self, block: Block, what: str) -> Operation:
        """A substitution with a subdomain's factor for ``"u_hat"`` or ``"u"``.

        Split: the forward sweep for u_hat (the surface right-hand side), the backward sweep
        for u. Otherwise, or for a subdomain coupled to nothing (no Schur block), a full
        substitution for each.
        """
        n = self.subdomains[block]
        if not self.split_substitution or not self.coupling_size(block):
            if self.condensation == "schur":  # the vectors carry the (zero) Schur block
                n += self.coupling_size(block)
            return Operation(block, "sparse_solve", n, 1, what)
        return Operation(block, SWEEPS[what == "u"], n, 1, what)

    def factorise_group(self, g: Group) -> list[Operation]:
        """Factorise a group and, if it is eliminated, condense its coupling columns.

        The condensation is a triangular solve of the columns, then their product W^T W,
        both over the rows from the first block coupled to a later level (t of them).
        """
        n = sum(self.surface[b] for b in g.blocks)
        ops = [Operation(g.name, "dense_factor", n)]
        if not g.last and g.neighbours and (m := self.coupling_columns(g)):
            coupled = [any((a, r) in self.pairs for r in g.neighbours) for a in g.blocks]
            t = sum(self.surface[b] for b in g.blocks[coupled.index(True) if any(coupled) else 0 :])
            ops.append(Operation(g.name, "dense_solve", t, m, "condense"))
            ops.append(Operation(g.name, "dense_product", t, m, "condense"))
        return ops

    def solve_group(self, g: Group, what: str | None = None) -> Operation:
        """A forward elimination (``"y"``) or solution (``"x"``) with a group's factor."""
        n = sum(self.surface[b] for b in g.blocks)
        return Operation(g.name, "dense_solve", n, 1, what or ("x" if g.last else "y"))

    def coupling_product(self, g: Group, what: str) -> list[Operation]:
        """An eliminated group's coupling matrix B times a vector: none for the last level.

        ``"y"``: B^T y, its forward elimination into the later levels (in every surface
        solve, whether y was solved again or not); ``"x"``: B x, the later levels' solution
        in its back-substitution.
        """
        if g.last or not g.neighbours or not (m := self.coupling_columns(g)):
            return []
        return [Operation(g.name, "dense_product", sum(self.surface[b] for b in g.blocks), m, what)]

    def forward(self, stale: set[str], new_rhs: bool) -> list[Operation]:
        """The surface solve's forward elimination and last level, group by group."""
        ops: list[Operation] = []
        for g in self.flat:
            if self.solves(g, stale, new_rhs):
                ops.append(self.solve_group(g))
            ops += self.coupling_product(g, "y")
        return ops

    def back_substitution(self) -> list[Operation]:
        """Solutions of the earlier levels given the last (in the engine's order)."""
        return [
            op
            for level in reversed(self.groups[:-1])
            for g in level
            for op in [*self.coupling_product(g, "x"), self.solve_group(g, "x")]
        ]

    def setup(self) -> list[Operation]:
        """Before the first solution: every factorisation and condensation."""
        ops = [op for b in self.layouts for op in self.factorise_subdomain(b, True)]
        return ops + [op for g in self.flat for op in self.factorise_group(g)]

    def step(self) -> list[Operation]:
        """One time step (new right-hand sides) without a contact state change."""
        ops = [self.substitute_subdomain(b, "u_hat") for b in self.layouts]
        ops += self.forward(set(), True) + self.back_substitution()
        return ops + [self.substitute_subdomain(b, "u") for b in self.layouts]

    def change(self, region: str) -> list[Operation]:
        """One more solve of the contact iteration after a change on ``region``."""
        blocks = self.regions[region]
        ops: list[Operation] = []
        for block in blocks:
            if block.kind == "u":  # contact on the subdomain's own boundary: K changes
                ops += self.factorise_subdomain(block, False)
                ops.append(self.substitute_subdomain(block, "u_hat"))
        stale = self.stale_groups(self.touched(*blocks))
        ops += [op for g in self.flat if g.name in stale for op in self.factorise_group(g)]
        return ops + self.forward(stale, False) + self._read_back(blocks)

    def release(self, region: str) -> list[Operation]:
        """One more solve of the same contact state, with a new right-hand side on ``region``.

        An energy-safe release (:mod:`dd_contact.impact`) changes only the right-hand side of
        the region's block: nothing is re-factorised. A contact interface's change is on its
        w rows (the groups it reaches are solved again, and the last level); contact on a
        subdomain's own boundary changes that subdomain's right-hand side (a forward sweep).
        Split ties (``kappa`` above 1e6) carry a w release on the subdomain: not planned.
        """
        blocks = self.regions[region]
        ops: list[Operation] = []
        for block in blocks:
            if block.kind == "u":
                ops.append(self.substitute_subdomain(block, "u_hat"))
        new_rhs = self.stale_groups(self.touched(*blocks))  # a new rhs propagates as staleness
        for g in self.flat:
            if self.solves(g, set(), g.name in new_rhs):
                ops.append(self.solve_group(g))
            ops += self.coupling_product(g, "y")
        return ops + self._read_back(blocks)

    def _read_back(self, blocks: tuple[Block, ...]) -> list[Operation]:
        """After a surface solve for ``blocks``: what the contact check reads is substituted."""
        ops = self.back_substitution() if self.needs_all_surface else []
        for b in self.needed_u:
            if self.split_substitution and self.coupling_size(b) and b not in blocks:
                # the forward sweep was used by the last expansion: sweep forward again
                ops.append(Operation(b, SWEEPS[0], self.subdomains[b], 1, "u"))
            ops.append(self.substitute_subdomain(b, "u"))
        return ops


class FullSchedule:
    """FULL: the whole system as one sparse matrix, re-factorised on every contact change.

    Args:
        size: Rows of the whole (constrained) system.
        regions: Contact region -> the block it acts on.
    """

    order = "FULL"

    def __init__(self, size: int, regions: Mapping[str, str | tuple[str, ...]]):
        self.size, self.regions = size, dict(regions)

    def setup(self) -> list[Operation]:
        """The first factorisation, with the symbolic analysis."""
        return [Operation("FULL", "sparse_factor", self.size, analysis=True)]

    def step(self) -> list[Operation]:
        """One substitution per time step."""
        return [Operation("FULL", "sparse_solve", self.size, 1)]

    def change(self, region: str) -> list[Operation]:
        """A numeric re-factorisation and one more substitution."""
        return [Operation("FULL", "sparse_factor", self.size), *self.step()]

    def release(self, region: str) -> list[Operation]:
        """One more substitution (the same matrix, a new right-hand side)."""
        return self.step()


def run_operations(
    schedule: Schedule | FullSchedule,
    n_steps: int,
    changes: dict[str, int],
    releases: dict[str, int] | None = None,
) -> list[Operation]:
    """Every operation of a run: set-up, steps, and each region's changes and releases.

    ``changes`` and ``releases`` per contact region: its contact state changes (the
    iteration's ``alpha``) and release solves (``ContactIteration.releases``).

    Exact when the regions change and release in different solves (a solve that changes
    two regions at once counts in each region, as ``alpha`` does).
    """
    ops = schedule.setup() + n_steps * schedule.step()
    for region, count in changes.items():
        ops += count * schedule.change(region)
    for region, count in (releases or {}).items():
        ops += count * schedule.release(region)
    return ops
