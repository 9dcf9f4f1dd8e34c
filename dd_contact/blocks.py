"""The names the assembly, the schedule and the solvers share: blocks and contact regions.

A block of system (14) holds the displacement of one mesh: a subdomain (kind ``u``), the
interface (``v``) or a contact interface (``w``). A :class:`Block` is a ``str`` whose value
is ``"<kind>:<name>"``, so dictionaries keyed by blocks also answer to that string (the key
users and the work log see); it is built and read only here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

__all__ = ["BLOCK_KINDS", "Block", "ContactRegion"]

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

    Attributes:
        name: The contact region's name (the key of its contact matrix).
        block: The block holding the contact surface's displacement (``w``, or ``u`` for
            contact on a subdomain's own boundary).
        dofs: Dof in ``block`` of every surface dof (3 per surface node).
        pattern: Sparsity pattern of the contact matrix in surface dof numbering.
    """

    name: str
    block: Block
    dofs: np.ndarray
    pattern: sp.csr_array

    def shifted(self, offset: int) -> ContactRegion:
        """The same region with its dofs moved by ``offset`` (a block's place in a matrix)."""
        return replace(self, dofs=self.dofs + offset)
