"""This machine's measured rates, the prices of :mod:`dd_contact.timing`.

:class:`MachineRates` holds measured seconds for each kind of operation at a few sizes
(:func:`calibrate`: MUMPS on elasticity matrices of cube meshes, LAPACK on random dense
matrices, never on the scenes they price), cached per machine (:func:`machine_rates`) and
checked against plausible bounds before being cached or used. The rate of an operation is
interpolated in log-log between the measured sizes, flat beyond them.
"""

from __future__ import annotations

import json
import logging
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import scipy.linalg as sla
from tqdm import tqdm

from dd_contact.parallel import ROOT, bcast_from_root
from dd_contact.solvers.linalg import SparseCholesky, dense_threads, sparse_statistics
from dd_contact.solvers.worklog import WorkLog

__all__ = [
    "CALIBRATION_SIZES",
    "PLAUSIBLE_RATES",
    "RATE_KINDS",
    "MachineRates",
    "cached_rates",
    "calibrate",
    "machine_fingerprint",
    "machine_rates",
]

#: What each measured rate is counted in.
RATE_KINDS = {
    "sparse_factor": "flops of a MUMPS numeric Cholesky factorisation",
    "sparse_analysis": "matrix entries of a first factorisation: its analysis, fresh memory",
    "sparse_solve": "factor entries read by one forward and backward substitution",
    "sparse_solve_block": "factor entries x right-hand sides of a multi-RHS substitution",
    "dense_factor": "flops of a LAPACK Cholesky factorisation (n^3/3)",
    "dense_solve": "flops of one LAPACK substitution pair (2 n^2)",
    "dense_solve_block": "flops of triangular solves with many columns (n^2 per column)",
    "call": "operations of a solver (factorisations, solves, products): its time outside them",
}

logger = logging.getLogger(__name__)

_FORMAT = 2  # version of the cached file's layout (2: tiny sizes, the "call" kind)

#: Plausible rates per core, kind -> (least, most) units per second: a measured point
#: outside ``least`` .. ``most x cores`` is an artefact (a timer hiccup, a loaded machine,
#: a difference of two noisy times) and is measured again, never cached. Generous: about
#: 50x around what 2015-2025 x86 cores do (a core: 1-50 Gflop/s in LAPACK/MUMPS kernels).
PLAUSIBLE_RATES = {
    "sparse_factor": (2e7, 1e11),
    "sparse_analysis": (2e5, 1e9),
    "sparse_solve": (1e6, 2e10),
    "sparse_solve_block": (1e6, 1e11),
    "dense_factor": (2e7, 1e11),
    "dense_solve": (1e6, 2e10),
    "dense_solve_block": (1e6, 1e11),
    "call": (1e2, 1e7),
}


@dataclass
class MachineRates:
    """Measured seconds per operation kind at a few sizes.

    Attributes:
        points: Per kind of :data:`RATE_KINDS`, ``[work, seconds]`` pairs, work ascending.
        machine: Where and how they were measured (host, CPU, BLAS threads, date).
    """

    points: dict[str, list[list[float]]]
    machine: dict[str, Any] = field(default_factory=dict)

    def seconds(self, kind: str, work: float) -> float:
        """Predicted seconds of ``work`` units of ``kind``.

        The rate is interpolated in log-log between the measured sizes and flat beyond the
        largest; below the smallest the time is flat: a call costs at least what the
        smallest measured call did (its overhead).
        """
        if work <= 0:
            return 0.0
        pts = np.asarray(self.points[kind], dtype=float)
        w, t = pts[:, 0], pts[:, 1]
        if work < w[0]:
            return float(t[0])
        rate = np.exp(np.interp(np.log(work), np.log(w), np.log(w / t)))
        return float(work / rate)

    def least_seconds(self, kind: str, work: float) -> float:
        """Seconds of ``work`` units of ``kind`` at the fastest rate measured: a lower bound."""
        return work / max(w / t for w, t in self.points[kind]) if work > 0 else 0.0

    def rate(self, kind: str, work: float) -> float:
        """Work units per second at ``work`` units."""
        return work / self.seconds(kind, work)

    def implausible(self, cores: int | None = None) -> list[str]:
        """The measured points outside :data:`PLAUSIBLE_RATES` for ``cores`` cores."""
        cores = cores or os.cpu_count() or 1
        out = []
        for kind, points in self.points.items():
            low, high = PLAUSIBLE_RATES[kind]
            for work, seconds in points:
                if not low <= work / seconds <= high * cores:
                    out.append(f"{kind}: {work / seconds:.3g}/s at {work:.3g}")
        return out

    def scaled(self, factors: dict[str, float]) -> MachineRates:
        """These rates with the seconds of each kind in ``factors`` multiplied by its factor."""
        points = {
            kind: [[w, t * factors.get(kind, 1.0)] for w, t in pts]
            for kind, pts in self.points.items()
        }
        return MachineRates(points, {**self.machine, "scaled": factors})

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (see :meth:`from_dict`)."""
        return {"format": _FORMAT, **asdict(self)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> MachineRates:
        """Rates from :meth:`to_dict`'s output; ValueError if it is not such a record."""
        missing = set(RATE_KINDS) - set(data.get("points", {}))
        if data.get("format") != _FORMAT or missing:
            raise ValueError(f"not a machine-rates record of format {_FORMAT} (missing {missing})")
        return cls(
            {k: [list(map(float, p)) for p in v] for k, v in data["points"].items()},
            dict(data.get("machine", {})),
        )


def machine_fingerprint() -> dict[str, Any]:
    """What the rates depend on: the host, its CPU, and the BLAS/OpenMP thread settings."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(
                (ln.split(":", 1)[1].strip() for ln in info if ln.startswith("model name")), cpu
            )
    except OSError:
        pass
    threads = {k: os.environ.get(k, "") for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    return {"host": platform.node(), "cpu": cpu, "cores": os.cpu_count(), **threads}


def _cache_file() -> Path:
    root = os.environ.get("DD_CONTACT_CACHE") or Path.home() / ".cache" / "dd_contact"
    return Path(root) / "machine_rates.json"


def cached_rates() -> MachineRates | None:
    """This machine's rates if they are cached and plausible, else ``None`` (no measuring).

    For a price that must not stop to calibrate (a solver choosing how to take a change).
    """
    file = _cache_file()
    key = json.dumps(machine_fingerprint(), sort_keys=True)
    try:
        rates = MachineRates.from_dict(json.loads(file.read_text())[key])
    except (OSError, KeyError, ValueError):
        return None
    return None if rates.implausible() else rates


def machine_rates(
    path: str | os.PathLike[str] | None = None,
    recalibrate: bool = False,
    quick: bool = False,
    comm: MPI.Comm | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> MachineRates:
    """This machine's rates: from the cache, or measured now (:func:`calibrate`) and cached.

    The cache (``$DD_CONTACT_CACHE`` or ``~/.cache/dd_contact``, file ``machine_rates.json``)
    keeps one record per machine fingerprint (host, CPU, thread settings). Cached rates
    outside :data:`PLAUSIBLE_RATES` are measured again; measured ones outside them are not
    cached. Collective over ``comm`` (default ``MPI.COMM_SELF``: this rank alone): its root
    reads or measures, every rank of ``comm`` gets the result. ``progress(done, total)`` is
    called as :func:`calibrate` measures (default: a message and a progress bar on stderr).
    """
    comm = MPI.COMM_SELF if comm is None else comm
    rates: MachineRates | None = None
    if comm.rank == ROOT:
        file = Path(path) if path is not None else _cache_file()
        key = json.dumps(machine_fingerprint(), sort_keys=True) + (" quick" if quick else "")
        cached = json.loads(file.read_text()) if file.exists() else {}
        if key in cached and not recalibrate:
            try:
                rates = MachineRates.from_dict(cached[key])
            except ValueError:
                rates = None
            if rates is not None and rates.implausible():
                logger.warning(
                    "cached machine rates in %s are implausible (%s): measuring again",
                    file,
                    "; ".join(rates.implausible()),
                )
                rates = None
        if rates is None:
            bar = None if progress is not None else _ConsoleProgress(quick, file)
            try:
                rates = calibrate(quick=quick, progress=progress or bar)
            finally:
                if bar is not None:
                    bar.close()
            if not rates.implausible():
                cached[key] = rates.to_dict()
                file.parent.mkdir(parents=True, exist_ok=True)
                file.write_text(json.dumps(cached, indent=1))
    rates = bcast_from_root(comm, rates)
    assert rates is not None  # the root's
    return rates


class _ConsoleProgress:
    """A one-line message and a progress bar on stderr while the rates are measured."""

    def __init__(self, quick: bool, file: Path):
        self.quick, self.file = quick, file
        self.bar: tqdm | None = None

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            seconds = "about 3 s" if self.quick else "about 12 s"
            print(
                f"dd_contact: measuring this machine's rates for algorithm='auto' ({seconds}, "
                f"once; cached in {self.file})",
                file=sys.stderr,
            )
            self.bar = tqdm(total=total, desc="calibrate", unit="size", file=sys.stderr)
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class _Clock:
    """Seconds since it started: the wall clock's, or the process's CPU time if less.

    Another job on the machine stretches the wall-clock time of every kind of work, by
    however much it runs at that moment; the CPU time of one thread's work is what it takes
    on a core of its own. Threaded work (CPU time above the wall clock's) keeps its wall time.
    """

    def __init__(self):
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def seconds(self) -> float:
        wall, cpu = time.perf_counter() - self.wall, time.process_time() - self.cpu
        return min(wall, cpu) if cpu > 0 else wall

    def share(self) -> float:
        """CPU time over wall time since it started (at most 1: threads count once)."""
        wall, cpu = time.perf_counter() - self.wall, time.process_time() - self.cpu
        return min(cpu / wall, 1.0) if wall > 0 and cpu > 0 else 1.0


def _timed(action, repeats: int = 1, cold: bool = False) -> float:
    """Median seconds of ``action`` after one warm-up call; ``cold``: evict the caches first."""
    action()
    times = []
    flush = np.ones(16_000_000) if cold else None  # 128 MB: more than any CPU cache
    for _ in range(repeats):
        if flush is not None:
            flush += 1.0
        clock = _Clock()
        action()
        times.append(clock.seconds())
    return statistics.median(times)


def _elasticity_matrix(n: tuple[int, int, int]):
    """Stiffness plus a little mass of a hexahedral cube mesh (an SPD elasticity matrix)."""
    import dolfinx
    import dolfinx.fem.petsc
    import ufl

    mesh = dolfinx.mesh.create_box(
        MPI.COMM_SELF,
        [[0.0, 0.0, 0.0], list(map(float, n))],
        list(n),
        dolfinx.mesh.CellType.hexahedron,
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    a = (
        2.0 * ufl.inner(eps(u), eps(v)) + ufl.div(u) * ufl.div(v) + 1e-2 * ufl.inner(u, v)
    ) * ufl.dx
    A = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a))
    A.assemble()
    return A


#: Sizes :func:`calibrate` measures: hexahedral cube meshes (elements per edge) and dense
#: matrices (rows). The largest cube takes about 2 s to factorise on one core of this
#: 2-core machine; rates are flat beyond the largest size measured, times below the
#: smallest (a 3^3 cube of 192 dofs, 10 rows: what a call costs at least).
CALIBRATION_SIZES = {
    "full": ([3, 6, 10, 14, 18], [10, 50, 200, 600, 1200, 2000]),
    "quick": ([3, 6, 10], [10, 50, 200, 800]),
}
_ATTEMPTS = 3  # measurements of a size whose rates are implausible before it is dropped


def calibrate(
    quick: bool = False, progress: Callable[[int, int], None] | None = None
) -> MachineRates:
    """Measure this machine's rates (about 12 s; ``quick``: about 3 s, small sizes only).

    Sparse: MUMPS on elasticity matrices of cube meshes (analysis, numeric factorisation,
    substitutions with one and with 128 right-hand sides). Dense: LAPACK potrf, potrs and
    triangular solves on random SPD matrices. Calls: the orders' engine on a block system of
    many small blocks, its time outside its factorisations and solves. A size whose rates
    fall outside :data:`PLAUSIBLE_RATES` is measured again (up to 3 times), then left out.
    Run with the thread settings of the real runs. ``progress(done, total)``, if given, is
    called after each measured size.
    """
    cubes, dense_sizes = CALIBRATION_SIZES["quick" if quick else "full"]
    sizes: list[tuple[Callable[[int, Any], dict[str, list[float]]], int]] = [
        (_sparse_points, n) for n in cubes
    ]
    sizes += [(_dense_points, n) for n in dense_sizes] + [(_call_points, 0)]
    points: dict[str, list[list[float]]] = {k: [] for k in RATE_KINDS}
    rng = np.random.default_rng(0)
    for done, (measure, n) in enumerate(sizes, 1):
        for _ in range(_ATTEMPTS):
            measured = measure(n, rng)
            if not MachineRates({k: [point] for k, point in measured.items()}).implausible():
                for kind, point in measured.items():
                    points[kind].append(point)
                break
        if progress is not None:
            progress(done, len(sizes))
    for kind in points:
        points[kind].sort()
    machine = {**machine_fingerprint(), "date": time.strftime("%Y-%m-%d %H:%M"), "quick": quick}
    return MachineRates(points, machine)


def _sparse_points(n: int, rng) -> dict[str, list[float]]:
    """One point of each sparse kind, on the elasticity matrix of an n^3 cube mesh."""
    A = _elasticity_matrix((n, n, n))
    clock = _Clock()
    stats = sparse_statistics(A)  # the symbolic analysis alone, timed directly
    analysis = clock.seconds()
    log = WorkLog()
    clock = _Clock()
    factor = SparseCholesky(A, log, "calibration")
    first = clock.seconds()
    A.scale(1.0 + 1e-9)  # new values: the next set-up re-factorises numerically
    clock = _Clock()
    factor.refactorise()
    numeric_seconds = clock.seconds()
    numeric = log.records[-1]
    # A first factorisation costs more than a numeric one by its analysis and its factor's
    # fresh memory (page faults): up to 2.5x the analysis alone on this machine.
    analysis = max(analysis, first - min(numeric.seconds, numeric_seconds))
    assert numeric.flops is not None  # a factorisation's record counts its flops
    b = A.createVecRight()
    b.set(1.0)
    # In a time step other work runs between two substitutions with the same factor.
    solve = _timed(lambda: factor.solve(b), 5, cold=True)
    B = np.ones((A.getSize()[0], 128))
    block = _timed(lambda: factor.solve_many(B), cold=True)
    out = {
        "sparse_factor": [numeric.flops, min(numeric.seconds, numeric_seconds)],
        "sparse_analysis": [float(stats.nnz), analysis],
        "sparse_solve": [factor.entries, solve],
        "sparse_solve_block": [factor.entries * 128, block],
    }
    factor.destroy()
    b.destroy()
    A.destroy()
    return out


def _dense_points(n: int, rng) -> dict[str, list[float]]:
    """One point of each dense kind, on a random n x n SPD matrix, threaded as the solver's."""
    with dense_threads(n):
        return _dense_points_threaded(n, rng)


def _dense_points_threaded(n: int, rng) -> dict[str, list[float]]:
    X = rng.standard_normal((n, n))
    S = X @ X.T + n * np.eye(n)
    L = sla.cho_factor(S.copy(), lower=True, check_finite=False)
    seconds = _timed(lambda: sla.cho_factor(S.copy(), lower=True, check_finite=False), 3)
    seconds -= _timed(lambda: S.copy(), 3)
    v = rng.standard_normal(n)
    # In a time step other work runs between two substitutions with the same factor: a
    # factor larger than a core's cache (1 MB) comes from memory.
    solve = _timed(lambda: sla.cho_solve(L, v, check_finite=False), 7, cold=8 * n * n > 2**20)
    m = min(n, 256)
    Bd = rng.standard_normal((n, m))
    block = _timed(lambda: sla.solve_triangular(L[0], Bd, lower=True, check_finite=False), 3)
    return {
        "dense_factor": [n**3 / 3.0, max(seconds, 1e-7)],
        "dense_solve": [2.0 * n * n, solve],
        "dense_solve_block": [float(n * n * m), block],
    }


#: The block system on which :func:`_call_points` runs the engine: subdomains, their dofs
#: and the contact dofs of each (its interface ties as many dofs of each subdomain).
CALL_SYSTEM = (8, 400, 100)


def _call_points(_: int, rng) -> dict[str, list[float]]:
    """Seconds per operation that the orders' engine spends outside its operations.

    The engine's Python around each factorisation, solve and product (surface blocks
    gathered, right-hand sides compared, vectors copied and split), measured with v-w-u
    and w-v-u on a many-block system (:data:`CALL_SYSTEM`): 1D Laplacians tied to one
    interface and each to a contact interface of its own. The mean of the two orders'
    medians over a few solves after the first.
    """
    from dd_contact.solvers.engine import BlockEliminationSolver

    system = _many_blocks(*CALL_SYSTEM)
    per_call = []
    for order in ("v-w-u", "w-v-u"):
        log = WorkLog()
        solver = BlockEliminationSolver(MPI.COMM_SELF, system, [], log, order)
        samples = []
        for repeat in range(6):
            rhs = {b: rng.standard_normal(n) for b, n in system.sizes.items() if b.kind == "u"}
            first, clock = len(log.records), _Clock()
            solver.solve(rhs)
            solver.finish()
            seconds = time.perf_counter() - clock.wall
            done = log.records[first:]
            if repeat:  # the first factorises; records are wall-clock: scaled by the share
                outside = (seconds - sum(r.seconds for r in done)) * clock.share()
                samples.append(outside / len(done))
        per_call.append(statistics.median(samples))
        solver.destroy()
    return {"call": [1.0, max(statistics.fmean(per_call), 1e-7)]}


def _many_blocks(k: int, n: int, m: int):
    """A system of k subdomains of n dofs, each tied to m interface dofs and m contact dofs."""
    import scipy.sparse as sp

    from dd_contact.blocks import Block, BlockSystem

    ones = np.ones(n - 1)
    laplacian = sp.csr_array(sp.diags_array([-ones, 4.0 * np.ones(n), -ones], offsets=[-1, 0, 1]))
    v = Block("v", "interface")
    sizes, matrices = {v: k * m}, {(v, v): sp.csr_array(2.0 * sp.eye_array(k * m))}
    for j in range(k):
        u, w = Block("u", f"s{j}"), Block("w", f"c{j}")
        sizes[u], sizes[w] = n, m
        rows = np.arange(m)
        matrices[(u, u)] = laplacian
        matrices[(u, v)] = sp.csr_array((-np.ones(m), (rows, j * m + rows)), shape=(n, k * m))
        matrices[(u, w)] = sp.csr_array((-np.ones(m), (n - m + rows, rows)), shape=(n, m))
        matrices[(w, w)] = sp.csr_array(2.0 * sp.eye_array(m))
    return BlockSystem(sizes, dict.fromkeys(sizes, 0), matrices)
