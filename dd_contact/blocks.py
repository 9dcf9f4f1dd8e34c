"""The names the assembly, the schedule and the solvers share: blocks and contact regions.

A block of system (14) holds the displacement of one mesh: a subdomain (kind ``u``), the
interface (``v``) or a contact interface (``w``). A :class:`Block` is a ``str`` whose value
is ``"<kind>:<name>"``, so dictionaries keyed by blocks also answer to that string (the key
users and the work log see); it is built and read only here.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

__all__ = ["BLOCK_KINDS", "Block", "ContactRegion", "refuse_unsolvable"]

#: Kinds of unknowns: subdomain, interface, contact-interface displacement.
BLOCK_KINDS: tuple[str, ...] = ("u", "v", "w")


class Block(str):
    """A block of unknowns: its ``kind`` (``u``, ``v`` or ``w``) and the mesh's ``name``."""

    kind: str
    name: str

    def __new__(cls, kind: str, name: str) -> Block:
        """The block ``kind:name``; ``kind`` must be one of :data:`BLOCK_KINDS`."""
        if kind not in BLOCK_KINDS:
            raise ValueError(f"block kind {kind!r} is not one of {BLOCK_KINDS}")
        block = super().__new__(cls, f"{kind}:{name}")
        block.kind, block.name = kind, str(name)
        return block

    def __getnewargs__(self) -> tuple[str, str]:  # pickling (blocks travel between ranks)
        return self.kind, self.name

    def __repr__(self) -> str:
        return f"Block({self.kind!r}, {self.name!r})"

    @classmethod
    def parse(cls, key: str) -> Block:
        """The block named by ``key`` (a Block or its ``"kind:name"`` string)."""
        if isinstance(key, Block):
            return key
        kind, sep, name = str(key).partition(":")
        if not sep:
            raise ValueError(f"{key!r} is not a block name of the form 'kind:name'")
        return cls(kind, name)


@dataclass(frozen=True, eq=False)
class ContactRegion:
    """What a solver reserves for one contact region: where its matrix goes, and its shape.

    The last three attributes are the seams of contact between bodies and of friction
    (docs/architecture.md, "Seams"): the schedule already groups a region's blocks; the
    solvers refuse a region they cannot solve yet (:func:`not_yet_solvable`).

    Attributes:
        name: The contact region's name (the key of its contact matrix).
        block: The block holding the contact surface's displacement (``w``, or ``u`` for
            contact on a subdomain's own boundary).
        dofs: Dof in ``block`` of every surface dof (3 per surface node).
        pattern: Sparsity pattern of the contact matrix in surface dof numbering.
        partner: The other block a contact pair's matrix couples (``None``: an obstacle).
        symmetric: Whether the contact matrix is symmetric (friction's slip is not).
        history: Whether the region carries state from step to step (friction's traction).
    """

    name: str
    block: Block
    dofs: np.ndarray
    pattern: sp.csr_array
    partner: Block | None = None
    symmetric: bool = True
    history: bool = False

    @property
    def blocks(self) -> tuple[Block, ...]:
        """The blocks the contact matrix couples: one for an obstacle, two for a pair."""
        return (self.block,) if self.partner is None else (self.block, self.partner)

    def shifted(self, offset: int) -> ContactRegion:
        """The same region with its dofs moved by ``offset`` (a block's place in a matrix)."""
        return replace(self, dofs=self.dofs + offset)


def refuse_unsolvable(regions: Iterable[ContactRegion]) -> None:
    """Raise NotImplementedError for a region the solvers cannot solve yet.

    A contact pair couples two blocks (its seam: the schedule's region groups and the
    surface's contact matrices by block pair), an unsymmetric contact block needs an LU
    factorisation (its seam: the surface's dense factor), a region with history needs it
    checkpointed (its seam: the run state).
    """
    for region in regions:
        if region.partner is not None:
            what = "couples two blocks (a contact pair)"
        elif not region.symmetric:
            what = "has an unsymmetric matrix (friction)"
        elif region.history:
            what = "carries history from step to step (friction)"
        else:
            continue
        raise NotImplementedError(
            f"contact region {region.name!r} {what}: the solvers do not solve such a region "
            "yet (docs/architecture.md, 'Seams')"
        )
