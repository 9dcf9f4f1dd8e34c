"""MPI in one place: who owns what, and the collective idioms the package uses.

Ranks own whole subdomains (subdomain k on rank ``k % size``); a contact region lives with
its subdomain; small dense work (the condensed surface system) runs on :data:`ROOT`.

Every collective call of the package goes through the helpers here (a test checks that no
other module calls one). Large arrays that cross ranks go through the buffer-based helpers
(``bcast_array``, ``allgather_blocks``, ``elementwise_max``: no pickling); the pickling ones
carry small or rare objects. Every helper counts what it sends in :data:`traffic`, the
process's count, and in the count of the problem whose work is running (:func:`counted`).
"""

from __future__ import annotations

import contextvars
import os
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import Any

from mpi4py import MPI

import numpy as np
import threadpoolctl

from dd_contact.blocks import Block, BlockKeyed
from dd_contact.errors import InputError, SingularMatrixError

__all__ = [
    "REFUSALS",
    "ROOT",
    "Traffic",
    "allgather_blocks",
    "allgathered",
    "any_rank",
    "barrier",
    "bcast_array",
    "bcast_from_root",
    "collective",
    "counted",
    "elementwise_max",
    "every_rank",
    "exchanged",
    "gather_to_root",
    "gathered",
    "max_over_ranks",
    "owner_of",
    "share_cores",
    "sum_over_ranks",
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
        self.seconds: defaultdict[str, float] = defaultdict(float)

    @contextmanager
    def call(self, helper: str, nbytes: int = 0):
        """Count one call of ``helper`` sending ``nbytes``, and time it.

        Counted here and in the count of the problem whose work is running, if any.
        """
        start = time.perf_counter()
        try:
            yield
        finally:
            seconds = time.perf_counter() - start
            scoped = _SCOPE.get()
            for count in (self,) if scoped is None or scoped is self else (self, scoped):
                count.seconds[helper] += seconds
                count.counts[helper] += 1
                count.counts["bytes"] += nbytes

    def reset(self) -> None:
        """Forget what was counted."""
        self.counts.clear()
        self.seconds.clear()

    def snapshot(self) -> dict[str, int]:
        """The counts so far (calls per helper, ``"bytes"``)."""
        return dict(self.counts)


#: This process's :class:`Traffic`: every call of every problem.
traffic = Traffic()

# The count of the problem whose work is running (counted), besides the process's.
_SCOPE: contextvars.ContextVar[Traffic | None] = contextvars.ContextVar(
    "dd_contact_traffic", default=None
)


@contextmanager
def counted(scope: Traffic) -> Iterator[Traffic]:
    """Count the calls made inside in ``scope`` too (a problem's own :class:`Traffic`)."""
    token = _SCOPE.set(scope)
    try:
        yield scope
    finally:
        _SCOPE.reset(token)


#: Environment variables through which a user sets a process's BLAS threads: if one is
#: set, :func:`share_cores` leaves the threads as the user has them.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

_cores_shared = False  # share_cores ran in this process (once is enough)


def share_cores(comm: MPI.Comm) -> int | None:
    """Collective: each rank's BLAS threads limited to its share of its node's cores.

    Ranks on one node that each run a multi-threaded BLAS (numpy's and scipy's OpenBLAS
    start one thread per core) oversubscribe the cores: OpenBLAS threads spin while they
    wait, and two ranks ran several times slower than one. Done once per process, on more
    than one rank, unless the user set one of :data:`THREAD_VARIABLES`. Returns the threads
    per rank set, or ``None``.
    """
    global _cores_shared
    if comm.size == 1 or _cores_shared or any(v in os.environ for v in THREAD_VARIABLES):
        return None
    _cores_shared = True
    with traffic.call("share_cores"):
        node = comm.Split_type(MPI.COMM_TYPE_SHARED)
        ranks_here = node.size
        node.Free()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    threads = max(1, (cores or 1) // ranks_here)
    threadpoolctl.threadpool_limits(limits=threads, user_api="blas")
    return threads


def owner_of(index: int, comm: MPI.Comm) -> int:
    """Rank that owns subdomain number ``index``: round robin over the ranks."""
    return index % comm.size


def gathered[K, V](comm: MPI.Comm, local: Mapping[K, V]) -> dict[K, V]:
    """Collective: the union of every rank's dict (each rank holds its own entries)."""
    if comm.size == 1:
        return dict(local)
    with traffic.call("gathered"):
        parts = comm.allgather(local)
    return {k: v for part in parts for k, v in part.items()}


def gather_to_root[T](comm: MPI.Comm, obj: T, nbytes: int = 0, root: int = ROOT) -> list[T] | None:
    """Collective: every rank's ``obj`` in rank order on ``root``, ``None`` elsewhere.

    ``nbytes``: the bytes of the arrays in ``obj``, for :data:`traffic` (it is pickled).
    """
    if comm.size == 1:
        return [obj]
    with traffic.call("gather_to_root", nbytes):
        return comm.gather(obj, root=root)


def allgathered[T](comm: MPI.Comm, obj: T) -> list[T]:
    """Collective: every rank's ``obj``, in rank order, on every rank (pickled)."""
    if comm.size == 1:
        return [obj]
    with traffic.call("allgathered"):
        return comm.allgather(obj)


def exchanged[T](comm: MPI.Comm, outgoing: list[T], nbytes: int = 0) -> list[T]:
    """Collective: ``outgoing[r]`` sent to rank r; returns what each rank sent to this one.

    ``nbytes``: the bytes of the arrays sent, for :data:`traffic` (they are pickled).
    """
    if comm.size == 1:
        return list(outgoing)
    with traffic.call("exchanged", nbytes):
        return comm.alltoall(outgoing)


def sum_over_ranks[T](comm: MPI.Comm, value: T) -> T:
    """Collective: the sum of every rank's ``value`` (a number or a float array)."""
    if comm.size == 1:
        return value
    with traffic.call("sum_over_ranks"):
        return comm.allreduce(value)


def max_over_ranks[T](comm: MPI.Comm, value: T) -> T:
    """Collective: the largest of every rank's number ``value``."""
    if comm.size == 1:
        return value
    with traffic.call("max_over_ranks"):
        return comm.allreduce(value, op=MPI.MAX)


def any_rank(comm: MPI.Comm, flag: bool) -> bool:
    """Collective: whether ``flag`` is true on some rank."""
    if comm.size == 1:
        return bool(flag)
    with traffic.call("any_rank"):
        return bool(comm.allreduce(bool(flag), op=MPI.LOR))


def every_rank(comm: MPI.Comm, flag: bool) -> bool:
    """Collective: whether ``flag`` is true on every rank."""
    if comm.size == 1:
        return bool(flag)
    with traffic.call("every_rank"):
        return bool(comm.allreduce(bool(flag), op=MPI.LAND))


def elementwise_max(comm: MPI.Comm, array: np.ndarray) -> np.ndarray:
    """Collective: the largest of every rank's float64 ``array``, entry by entry (a new array)."""
    if comm.size == 1:
        return array.copy()
    out = np.empty_like(array)
    with traffic.call("elementwise_max", array.nbytes):
        comm.Allreduce(array, out, op=MPI.MAX)
    return out


def barrier(comm: MPI.Comm) -> None:
    """Collective: wait until every rank is here."""
    if comm.size == 1:
        return
    with traffic.call("barrier"):
        comm.Barrier()


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
    local: BlockKeyed[np.ndarray],
    owners: Mapping[Block, int],
    sizes: Mapping[Block, int],
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
    out: dict[str, np.ndarray] = {}
    start = 0
    for blocks in by_rank:
        for b in blocks:
            out[b] = received[start : start + sizes[b]]
            start += sizes[b]
    return out


#: What :func:`collective` raises on every rank when one rank raises it: refusals of the
#: input (InputError), of what is not built (NotImplementedError), of a singular matrix.
REFUSALS: tuple[type[Exception], ...] = (InputError, NotImplementedError, SingularMatrixError)


def collective(comm: MPI.Comm, action: Callable[[], Any]) -> Any:
    """Run ``action`` on every rank; a refusal on one rank is raised on all ranks.

    A refusal is one of :data:`REFUSALS`: the lowest refusing rank's class and message are
    raised everywhere (that rank keeps its traceback), so no rank is left waiting in the
    next collective.
    """
    result, refusal = None, None
    try:
        result = action()
    except REFUSALS as error:
        refusal = error
    if comm.size == 1:
        if refusal is not None:
            raise refusal
        return result
    mine = None if refusal is None else (REFUSALS.index(_kind(refusal)), str(refusal))
    with traffic.call("collective"):
        refusals = [m for m in comm.allgather(mine) if m is not None]
    if refusals and refusals[0] == mine:
        assert refusal is not None  # mine is not None
        raise refusal
    if refusals:
        kind, message = refusals[0]
        raise REFUSALS[kind](message)
    return result


def _kind(error: Exception) -> type[Exception]:
    """The entry of :data:`REFUSALS` that ``error`` is an instance of."""
    return next(k for k in REFUSALS if isinstance(error, k))
