"""MPI in one place: who owns what, and the collective idioms the package uses.

Ranks own whole subdomains (subdomain k on rank ``k % size``); a contact region lives with
its subdomain; small dense work (the condensed surface system) runs on :data:`ROOT`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mpi4py import MPI

from dd_contact.errors import InputError

__all__ = ["ROOT", "bcast_from_root", "collective", "gather_to_root", "gathered", "owner_of"]

#: The rank that solves the dense surface system and reads or writes shared files.
ROOT = 0


def owner_of(index: int, comm: MPI.Comm) -> int:
    """Rank that owns subdomain number ``index``: round robin over the ranks."""
    return index % comm.size


def gathered(comm: MPI.Comm, local: dict) -> dict:
    """Collective: the union of every rank's dict (each rank holds its own entries)."""
    if comm.size == 1:
        return dict(local)
    return {k: v for part in comm.allgather(local) for k, v in part.items()}


def gather_to_root[T](comm: MPI.Comm, obj: T) -> list[T] | None:
    """Collective: every rank's ``obj`` in rank order on :data:`ROOT`, ``None`` elsewhere."""
    return [obj] if comm.size == 1 else comm.gather(obj, root=ROOT)


def bcast_from_root[T](comm: MPI.Comm, obj: T) -> T:
    """Collective: :data:`ROOT`'s ``obj`` on every rank."""
    return obj if comm.size == 1 else comm.bcast(obj, root=ROOT)


def collective(comm: MPI.Comm, action: Callable[[], Any]) -> Any:
    """Run ``action`` on every rank; if any rank raises InputError, raise it on all ranks."""
    result, message = None, None
    try:
        result = action()
    except InputError as error:
        message = str(error)
    messages = [m for m in comm.allgather(message) if m is not None]
    if messages:
        raise InputError(messages[0])
    return result
