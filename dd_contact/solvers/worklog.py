"""The work log: every factorisation and solve of a run, with its size, time and flops.

:class:`dd_contact.solvers.linalg.SparseCholesky` and
:class:`dd_contact.solvers.dense.DenseCholesky` append a :class:`WorkRecord` for each
factorisation and solve; :mod:`dd_contact.timing` builds records of the same kind for its
plans, so a run can report what it did and compare it with what was predicted.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from mpi4py import MPI

from dd_contact.parallel import allgathered

__all__ = ["WorkLog", "WorkRecord"]


@dataclass
class WorkRecord:
    """One factorisation or solve."""

    block: str
    # "sparse_factor", "sparse_solve", "sparse_forward", "sparse_backward" (half a
    # substitution each: MUMPS's Schur reduction and expansion), "dense_factor",
    # "dense_solve", "dense_product" (a group's coupling matrix times vectors: nrhs is its
    # columns), "schur", "dense_update" (a low-rank correction of contact changes instead of
    # a re-factorisation: dd_contact/solvers/lowrank.py; size its rank, nrhs the change's)
    kind: str
    size: int
    nrhs: int
    seconds: float
    flops: float | None = None
    what: str = ""  # what was solved for, e.g. "condense", "u_hat", "u"
    entries: float | None = None  # sparse: entries of the factor (MUMPS INFOG(29))
    nnz: int = 0  # sparse factorisation with its symbolic analysis: entries of the matrix


@dataclass
class WorkLog:
    """All factorisations and solves of a run.

    Attributes:
        records: Every operation, in order.
        calls: Per call of a solver's solve or finish (:meth:`solving`): the operations it
            recorded and the wall seconds it spent outside them (its Python around them).
    """

    records: list[WorkRecord] = field(default_factory=list)
    calls: list[tuple[int, float]] = field(default_factory=list)

    @contextmanager
    def solving(self) -> Iterator[None]:
        """A solver's solve or finish: its time outside the records it adds goes to calls."""
        first, start = len(self.records), time.perf_counter()
        try:
            yield
        finally:
            seconds = time.perf_counter() - start
            done = self.records[first:]
            self.calls.append((len(done), seconds - sum(r.seconds for r in done)))

    @classmethod
    def planned(cls, operations) -> WorkLog:
        """A log of scheduled operations, with zero seconds: what a run should record.

        ``operations``: :class:`~dd_contact.solvers.schedule.Operation` s, e.g. a plan.
        """
        return cls(
            [WorkRecord(o.target, o.kind, o.size, o.nrhs, 0.0, what=o.what) for o in operations]
        )

    def add(self, *args, **kwargs) -> None:
        """Append a :class:`WorkRecord`."""
        self.records.append(WorkRecord(*args, **kwargs))

    def count(self, kind: str, block: str | None = None) -> int:
        """Number of records of ``kind`` (for ``block``, if given)."""
        return sum(r.kind == kind and block in (None, r.block) for r in self.records)

    def summary(self) -> dict[str, dict[str, float]]:
        """Per kind: count, right-hand sides, total seconds, total flops."""
        out: dict[str, dict[str, float]] = {}
        for r in self.records:
            s = out.setdefault(r.kind, {"count": 0, "nrhs": 0, "seconds": 0.0, "flops": 0.0})
            s["count"] += 1
            s["nrhs"] += r.nrhs
            s["seconds"] += r.seconds
            s["flops"] += r.flops or 0.0
        return out

    def per_block(self) -> dict[str, dict]:
        """Per block: what was done with its matrix.

        Matrix kind (sparse/dense) and size, decompositions, substitutions (right-hand sides
        summed, as the paper counts them; a forward and a backward sweep make one),
        Schur complements, products with a coupling matrix, seconds and GFLOPs of each.
        """
        out: dict[str, dict] = {}
        for r in self.records:
            b = out.setdefault(
                r.block,
                {
                    "matrix": r.kind.split("_")[0],
                    "size": r.size,
                    "decompositions": 0,
                    "substitutions": 0,
                    "schur": 0,
                    "products": 0,
                    "updates": 0,
                    "seconds_decomposition": 0.0,
                    "seconds_substitution": 0.0,
                    "seconds_schur": 0.0,
                    "seconds_product": 0.0,
                    "gflops_decomposition": 0.0,
                    "gflops_substitution": 0.0,
                },
            )
            if r.kind.endswith("_factor"):
                b["decompositions"] += 1
                b["seconds_decomposition"] += r.seconds
                b["gflops_decomposition"] += (r.flops or 0.0) / 1e9
            elif r.kind.endswith(("_solve", "_forward", "_backward")):
                b["substitutions"] += r.nrhs if r.kind.endswith("_solve") else r.nrhs / 2
                b["seconds_substitution"] += r.seconds
                b["gflops_substitution"] += (r.flops or 0.0) / 1e9
            elif r.kind == "dense_update":
                b["updates"] += 1
                b["seconds_product"] += r.seconds
            elif r.kind.endswith("_product"):
                b["products"] += 1
                b["seconds_product"] += r.seconds
            else:
                b["schur"] += 1
                b["seconds_schur"] += r.seconds
        return out

    def merged(self, comm: MPI.Comm) -> WorkLog:
        """Collective: one log with the records of every rank."""
        if comm.size == 1:
            return self
        return WorkLog([r for part in allgathered(comm, self.records) for r in part])

    def table(self) -> str:
        """The per-block summary as a text table."""
        rows = [
            f"{'block':<24} {'matrix':<6} {'size':>8} {'decompositions':>14} "
            f"{'substitutions':>13} {'s decomp.':>10} {'s subst.':>9} {'GFLOP decomp.':>13} "
            f"{'updates':>7}"
        ]
        for name, b in self.per_block().items():
            rows.append(
                f"{name:<24} {b['matrix']:<6} {b['size']:>8} {b['decompositions']:>14} "
                f"{b['substitutions']:>13g} {b['seconds_decomposition']:>10.3f} "
                f"{b['seconds_substitution']:>9.3f} {b['gflops_decomposition']:>13.3g} "
                f"{b['updates']:>7}"
            )
        return "\n".join(rows)
