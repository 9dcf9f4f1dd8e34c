"""MPI in one place: who owns what, and the collective idioms the package uses.

Ranks own whole subdomains (subdomain k on rank ``k % size``); a contact region lives with
its subdomain; small dense work (the condensed surface system) runs on :data:`ROOT`.

Large arrays that cross ranks go through the buffer-based helpers (``bcast_array``,
``allgather_blocks``: no pickling); the pickling ones carry small or rare objects. Every
helper counts what it sends in :data:`traffic`.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Mapping
from contextlib import contextmanager
from typing import Any

from mpi4py import MPI

import numpy as np

from dd_contact.errors import InputError

__all__ = [
    "ROOT",
    "Traffic",
    "allgather_blocks",
    "bcast_array",
    "bcast_from_root",
    "collective",
    "gather_to_root",
    "gathered",
    "owner_of",
    "traffic",
]

#: The rank that solves the dense surface system and reads or writes shared files.
ROOT = 0


class Traffic:
    """What this rank sent through the helpers below: calls and bytes, and time inside them.

    ``counts`` holds the calls per helper and ``"bytes"``, the array bytes this rank sent
    (pickled objects count as calls only); ``seconds`` the time spent in each helper,
    waiting for the other ranks included. Read by tests and benchmarks (``reset()``, run,
    ``snapshot()``); a single rank sends nothing and counts nothing.
    """

    def __init__(self):
        self.counts: Counter[str] = Counter()
        self.seconds: Counter[str] = Counter()

    @contextmanager
    def call(self, helper: str, nbytes: int = 0):
        """Count one call of ``helper`` sending ``nbytes``, and time it."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[helper] += time.perf_counter() - start
            self.counts[helper] += 1
            self.counts["bytes"] += nbytes

    def reset(self) -> None:
        """Forget what was counted."""
        self.counts.clear()
        self.seconds.clear()

    def snapshot(self) -> dict[str, int]:
        """The counts so far (calls per helper, ``"bytes"``)."""
        return dict(self.counts)


#: This process's :class:`Traffic`.
traffic = Traffic()


def owner_of(index: int, comm: MPI.Comm) -> int:
    """Rank that owns subdomain number ``index``: round robin over the ranks."""
    return index % comm.size


def gathered(comm: MPI.Comm, local: dict) -> dict:
    """Collective: the union of every rank's dict (each rank holds its own entries)."""
    if comm.size == 1:
        return dict(local)
    with traffic.call("gathered"):
        parts = comm.allgather(local)
    return {k: v for part in parts for k, v in part.items()}


def gather_to_root[T](comm: MPI.Comm, obj: T, nbytes: int = 0) -> list[T] | None:
    """Collective: every rank's ``obj`` in rank order on :data:`ROOT`, ``None`` elsewhere.

    ``nbytes``: the bytes of the arrays in ``obj``, for :data:`traffic` (it is pickled).
    """
    if comm.size == 1:
        return [obj]
    with traffic.call("gather_to_root", nbytes):
        return comm.gather(obj, root=ROOT)


def bcast_from_root[T](comm: MPI.Comm, obj: T) -> T:
    """Collective: :data:`ROOT`'s ``obj`` on every rank."""
    if comm.size == 1:
        return obj
    with traffic.call("bcast_from_root"):
        return comm.bcast(obj, root=ROOT)


def bcast_array(comm: MPI.Comm, array: np.ndarray) -> np.ndarray:
    """Collective: :data:`ROOT`'s float64 ``array`` on every rank, written into ``array``.

    The other ranks pass an array of the same shape to be filled.
    """
    if comm.size == 1:
        return array
    with traffic.call("bcast_array", array.nbytes if comm.rank == ROOT else 0):
        comm.Bcast(array, root=ROOT)
    return array


def allgather_blocks(
    comm: MPI.Comm,
    local: Mapping[str, np.ndarray],
    owners: Mapping[str, int],
    sizes: Mapping[str, int],
) -> dict[str, np.ndarray]:
    """Collective: every block of ``owners`` on every rank, each sent by its owner.

    Args:
        comm: Communicator.
        local: This rank's blocks (at least the ones ``owners`` gives this rank).
        owners: Block -> the rank that holds it (the same on every rank).
        sizes: Length of each block.
    """
    if comm.size == 1:
        return {b: local[b] for b in owners}
    by_rank = [sorted(b for b, r in owners.items() if r == rank) for rank in range(comm.size)]
    counts = [sum(sizes[b] for b in blocks) for blocks in by_rank]
    mine = [np.asarray(local[b], dtype=np.float64) for b in by_rank[comm.rank]]
    send = np.concatenate(mine) if mine else np.zeros(0)
    received = np.empty(sum(counts))
    with traffic.call("allgather_blocks", send.nbytes):
        comm.Allgatherv(send, [received, counts])
    out, start = {}, 0
    for blocks in by_rank:
        for b in blocks:
            out[b] = received[start : start + sizes[b]]
            start += sizes[b]
    return out


def collective(comm: MPI.Comm, action: Callable[[], Any]) -> Any:
    """Run ``action`` on every rank; if any rank raises InputError, raise it on all ranks."""
    result, message = None, None
    try:
        result = action()
    except InputError as error:
        message = str(error)
    if comm.size == 1:
        if message is not None:
            raise InputError(message)
        return result
    with traffic.call("collective"):
        messages = [m for m in comm.allgather(message) if m is not None]
    if messages:
        raise InputError(messages[0])
    return result
