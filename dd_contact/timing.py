"""Predicted wall time of the solvers as they really run, and ``algorithm="auto"``.

:mod:`dd_contact.paper.flops` counts flops with the paper's banded kernels (method.md section 6).
This module predicts *seconds* for what the solvers here actually do:

* **The work.** MUMPS's symbolic analysis of every sparse matrix an algorithm factorises
  (flops and factor entries; exact for SPD matrices, which MUMPS does not pivot), and the
  dense LAPACK operations on the surface groups of the order, planned exactly as the
  engine runs them (both follow :mod:`dd_contact.solvers.schedule`). A :class:`Plan` lists
  the operations of the set-up, of one time step without a contact change, and of one more
  contact iteration after a change on each contact region.
* **Around the work.** Each operation also costs the solver's Python around it (the
  machine's ``"call"`` rate), and energy-safe contact and stiff ties solve again: a
  :class:`Plan` lists one release solve per region (:meth:`Schedule.release`), and a solve
  with stiff ties repeats a step's substitutions once per extra solve of their iteration.
* **The machine.** :class:`~dd_contact.calibration.MachineRates`: measured seconds for each
  kind of operation at a few sizes, cached per machine (:mod:`dd_contact.calibration`).

Predicted run time = set-up + steps x step + changes x change + releases x release (means
over the contact regions) + the stiff ties' extra solves. :func:`choose` picks the
algorithm with the least predicted time; :func:`replan` chooses again from the clock.
"""

from __future__ import annotations

import dataclasses
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field

from dd_contact.calibration import (
    PLAUSIBLE_RATES,
    RATE_KINDS,
    MachineRates,
    calibrate,
    machine_rates,
)
from dd_contact.solvers.analysed import SceneStructure
from dd_contact.solvers.linalg import SparseStatistics
from dd_contact.solvers.schedule import ALGORITHMS, SWEEPS, Operation
from dd_contact.solvers.worklog import WorkRecord

__all__ = [
    "MISS",
    "PLAUSIBLE_RATES",
    "RATE_KINDS",
    "RELEASES_PER_CHANGE",
    "TIE_SOLVES",
    "Choice",
    "Expected",
    "MachineRates",
    "Plan",
    "Prediction",
    "calibrate",
    "choose",
    "full_cannot_win",
    "machine_rates",
    "misses",
    "overhead_seconds",
    "plan",
    "rate_kind",
    "record_seconds",
    "replan",
]


def rate_kind(record: WorkRecord) -> str:
    """The kind of :data:`RATE_KINDS` that prices a work record (a factorisation: its flops).

    A coupling product ``W^T W`` of a condensation is a BLAS-3 product like the triangular
    solve before it; a product with a vector reads the matrix once, like a substitution.
    """
    if record.kind in ("sparse_solve", "dense_solve") and record.nrhs > 1:
        return f"{record.kind}_block"
    if record.kind in SWEEPS:
        return "sparse_solve"
    if record.kind == "dense_product":
        return "dense_solve_block" if record.what == "condense" else "dense_solve"
    if record.kind == "dense_update":  # a low-rank correction's small dense LU and products
        return "dense_factor"
    return "dense_solve" if record.kind == "schur" else record.kind


def record_seconds(record: WorkRecord, rates: MachineRates) -> float:
    """Predicted seconds of one factorisation or solve, from its size and work counts."""
    kind, n = record.kind, record.size
    if kind == "sparse_factor":
        return rates.seconds("sparse_factor", record.flops or 0.0) + rates.seconds(
            "sparse_analysis", record.nnz
        )
    if kind == "sparse_solve":
        if record.nrhs == 1:
            return rates.seconds("sparse_solve", record.entries or 0.0)
        return rates.seconds("sparse_solve_block", (record.entries or 0.0) * record.nrhs)
    if kind in SWEEPS:  # half a substitution: one pass over the factor
        return 0.5 * rates.seconds("sparse_solve", record.entries or 0.0)
    if kind == "schur":  # a copy of the m x m complement: memory traffic like a substitution
        return rates.seconds("dense_solve", 2.0 * n * n)
    if kind == "dense_factor":
        return rates.seconds("dense_factor", n**3 / 3.0)
    if kind == "dense_update":  # a low-rank correction's k x k work: (M G and its LU)
        return rates.seconds("dense_factor", record.flops or 8.0 * n**3 / 3.0)
    if kind == "dense_solve":
        if record.nrhs == 1:
            return rates.seconds("dense_solve", 2.0 * n * n)
        return rates.seconds("dense_solve_block", record.flops or float(n * n * record.nrhs))
    if kind == "dense_product":  # n x m coupling matrix B: W^T W (n m^2), or B^T y, B x
        m = record.nrhs
        if record.what == "condense":
            return rates.seconds("dense_solve_block", float(n * m * m))
        return rates.seconds("dense_solve", 2.0 * n * m)
    raise ValueError(f"unknown work kind {kind!r}")


def overhead_seconds(count: float, rates: MachineRates) -> float:
    """Predicted seconds a solver spends around ``count`` operations, outside them."""
    return rates.seconds("call", count) if "call" in rates.points else 0.0


def solver_records(records: Sequence[WorkRecord]) -> list[WorkRecord]:
    """The records of the solver's own operations (not the initial acceleration's)."""
    return [r for r in records if not r.block.startswith("mass:")]


#: Energy-safe release solves expected per contact state change (the median of the paper's
#: scenes, 0 to 0.85: benchmarks/results/auto_choice.json); the re-plan counts them.
RELEASES_PER_CHANGE = 0.5

#: Solves of the stiff ties' iteration expected per solve (4 from scratch, fewer with the
#: previous forces to start from: dd_contact.solvers.stiff_ties); the re-plan counts them.
TIE_SOLVES = 3.0


# -- the work -------------------------------------------------------------------------------
@dataclass
class Plan:
    """The factorisations and solves of one algorithm (records with zero seconds).

    Attributes:
        algorithm: FULL or an order.
        setup: Before the first solution: factorisations and condensations.
        step: One time step (one solution) without a contact state change.
        changes: Per contact region, one more contact iteration after a change there.
        releases: Per contact region, one more solve of the same contact state with its
            points let go (energy-safe contact).
    """

    algorithm: str
    setup: list[WorkRecord]
    step: list[WorkRecord]
    changes: dict[str, list[WorkRecord]]
    releases: dict[str, list[WorkRecord]] = field(default_factory=dict)

    def seconds(self, part: list[WorkRecord], rates: MachineRates) -> float:
        """Predicted seconds of a list of operations (e.g. :attr:`setup`), with around them."""
        return sum(record_seconds(r, rates) for r in part) + overhead_seconds(len(part), rates)

    def change_seconds(self, rates: MachineRates) -> float:
        """Mean over the contact regions of a change's cost (0 without contact regions)."""
        return self._mean(self.changes, rates)

    def release_seconds(self, rates: MachineRates) -> float:
        """Mean over the contact regions of a release solve's cost."""
        return self._mean(self.releases, rates)

    def _mean(self, parts: dict[str, list[WorkRecord]], rates: MachineRates) -> float:
        costs = [self.seconds(ops, rates) for ops in parts.values()]
        return statistics.fmean(costs) if costs else 0.0


def _record(op: Operation, stats: SparseStatistics | None) -> WorkRecord:
    """The work record of a scheduled operation, with the work counts that price it."""
    n, nrhs = op.size, op.nrhs
    if op.kind == "sparse_factor":
        assert stats is not None  # a sparse operation's matrix is analysed
        nnz = stats.nnz if op.analysis else 0
        what = f"with a Schur complement of {stats.schur}" if stats.schur else ""
        return WorkRecord(op.target, op.kind, n, 0, 0.0, stats.flops, what, stats.entries, nnz)
    if op.kind == "sparse_solve":
        assert stats is not None
        flops = 4.0 * stats.entries * nrhs
        return WorkRecord(op.target, op.kind, n, nrhs, 0.0, flops, op.what, stats.entries)
    if op.kind in SWEEPS:
        assert stats is not None
        flops = 2.0 * stats.entries
        return WorkRecord(op.target, op.kind, n, nrhs, 0.0, flops, op.what, stats.entries)
    if op.kind == "dense_factor":
        return WorkRecord(op.target, op.kind, n, 0, 0.0, n**3 / 3.0)
    if op.kind == "dense_solve":  # a condensation solves n^2 per column (triangular only)
        flops = float(n * n * nrhs) if op.what == "condense" else 2.0 * n * n * nrhs
        return WorkRecord(op.target, op.kind, n, nrhs, 0.0, flops, op.what)
    if op.kind == "dense_product":
        flops = float(n * nrhs * nrhs) if op.what == "condense" else 2.0 * n * nrhs
        return WorkRecord(op.target, op.kind, n, nrhs, 0.0, flops, op.what)
    return WorkRecord(op.target, op.kind, n, 0, 0.0)  # "schur": a copy of the complement


def plan(structure: SceneStructure, algorithm: str) -> Plan:
    """What ``algorithm`` factorises and solves for this scene (its schedule, with counts).

    Made once per structure and algorithm (kept in ``structure.plans``).
    """
    if algorithm in structure.plans:
        return structure.plans[algorithm]
    if algorithm == "FULL" and structure.full is None:
        raise ValueError("FULL's matrix was not analysed (scene_structure(full=True))")
    if algorithm not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algorithm!r}; valid: {', '.join(ALGORITHMS)}")
    schedule = structure.schedule(algorithm)

    def records(ops: list[Operation]) -> list[WorkRecord]:
        stats = {**structure.subdomains, "FULL": structure.full}
        return [_record(op, stats.get(op.target)) for op in ops]

    changes = {key: records(schedule.change(key)) for key in structure.regions}
    releases = {key: records(schedule.release(key)) for key in structure.regions}
    made = Plan(algorithm, records(schedule.setup()), records(schedule.step()), changes, releases)
    structure.plans[algorithm] = made
    return made


# -- predictions and the choice ------------------------------------------------------------
@dataclass(frozen=True)
class Prediction:
    """Predicted seconds of one algorithm's solver (serial; one process).

    Attributes:
        algorithm: FULL or an order.
        setup, step, change, release: Seconds of the set-up, of a step without a contact
            change, of a contact change's solve, of a release solve.
        steps, changes, releases: How many of each the run is expected to do.
        tie_solves: Solves of the stiff ties' iteration per solve (1: no stiff ties); each
            extra one substitutes like a step.
    """

    algorithm: str
    setup: float
    step: float
    change: float
    steps: float
    changes: float
    release: float = 0.0
    releases: float = 0.0
    tie_solves: float = 1.0

    @property
    def total(self) -> float:
        """Set-up, steps, contact changes, release solves and the stiff ties' extra solves."""
        solves = self.steps + self.changes + self.releases
        extra = (self.tie_solves - 1.0) * solves * self.step
        return (
            self.setup
            + self.steps * self.step
            + self.changes * self.change
            + self.releases * self.release
            + extra
        )


@dataclass(frozen=True)
class Expected:
    """What a run is expected to do: its steps, contact changes, release and tie solves."""

    steps: float
    changes: float
    releases: float = 0.0
    tie_solves: float = 1.0


def predict(
    plan: Plan,
    rates: MachineRates,
    steps: float,
    changes: float,
    releases: float = 0.0,
    tie_solves: float = 1.0,
) -> Prediction:
    """Predicted time of a run: its steps, contact changes, release solves, tie solves.

    ``tie_solves``: solves of the stiff ties' iteration per solve (1: no stiff ties).
    """
    return Prediction(
        plan.algorithm,
        plan.seconds(plan.setup, rates),
        plan.seconds(plan.step, rates),
        plan.change_seconds(rates),
        steps,
        changes,
        plan.release_seconds(rates),
        releases,
        tie_solves,
    )


@dataclass
class Choice:
    """The outcome of ``algorithm="auto"``: the prediction of every candidate.

    Attributes:
        algorithm: The chosen algorithm.
        predictions: Per candidate.
        replanned: The choice was made again after the first solves missed their
            prediction by more than :data:`MISS` (:func:`replan`).
        misses: Per rate kind, measured over predicted seconds of the first solves.
    """

    algorithm: str
    predictions: dict[str, Prediction]
    replanned: bool = False
    misses: dict[str, float] = field(default_factory=dict)
    #: Candidates not analysed because they cannot win: the least their run can cost [s].
    skipped: dict[str, float] = field(default_factory=dict)

    def table(self) -> str:
        """The candidates' predicted times, cheapest first."""
        rows = [
            f"{'algorithm':<8} {'set-up s':>10} {'step s':>10} {'change s':>10} "
            f"{'release s':>10} {'total s':>11}"
        ]
        for p in sorted(self.predictions.values(), key=lambda p: p.total):
            mark = "  <- chosen" if p.algorithm == self.algorithm else ""
            rows.append(
                f"{p.algorithm:<8} {p.setup:>10.4g} {p.step:>10.4g} {p.change:>10.4g} "
                f"{p.release:>10.4g} {p.total:>11.5g}{mark}"
            )
        for algorithm, least in self.skipped.items():
            rows.append(f"{algorithm:<8} not analysed: cannot win (at least {least:.4g} s)")
        return "\n".join(rows)


def choose(
    structure: SceneStructure,
    rates: MachineRates,
    candidates: tuple[str, ...],
    expected: Expected,
) -> Choice:
    """The candidate with the least predicted time for the ``expected`` run."""
    predictions = {a: _predict(structure, a, rates, expected) for a in candidates}
    best = min(candidates, key=lambda a: (predictions[a].total, candidates.index(a)))
    return Choice(best, predictions)


def _predict(structure, algorithm: str, rates: MachineRates, expected: Expected) -> Prediction:
    e = expected
    return predict(plan(structure, algorithm), rates, e.steps, e.changes, e.releases, e.tie_solves)


#: A prediction misses when the measured seconds are more than MISS times the predicted
#: ones, or less than 1 / MISS times.
MISS = 2.0
_NOISE_SECONDS = 0.05  # kinds with less measured time than this are not judged
#: A re-plan switches algorithm only if the other's predicted rest of the run, its set-up
#: included, is this many times cheaper than going on with the current one.
SWITCH_GAIN = 1.25


def misses(
    records: Sequence[WorkRecord],
    rates: MachineRates,
    calls: Sequence[tuple[int, float]] = (),
    share: float = 1.0,
) -> dict[str, float]:
    """Measured over predicted seconds of ``records``, per rate kind (enough time only).

    What the rest of a run repeats is judged: a first factorisation (its symbolic analysis,
    its factor's fresh memory: 1.3-3x a numeric one, and up to 4x the cube's analysis rate
    per entry on the pin joint's whole matrix) is left out. ``calls``: per call of the
    solver (:attr:`WorkLog.calls`), its operations and its seconds outside them: the
    ``"call"`` kind (the first call, which builds the surface system, is left out).
    ``share``: the share of a core the process had while they ran (CPU over wall-clock
    time, at most 1): the rates are a core's own (calibration), and the wall-clock seconds
    measured are scaled by it, so that another job on the machine, which slows every kind
    alike, is not taken for a wrong rate.
    """
    measured: dict[str, float] = {}
    predicted: dict[str, float] = {}
    for r in records:
        if r.nnz:  # a first factorisation, with its analysis: once a run
            continue
        kind = rate_kind(r)
        measured[kind] = measured.get(kind, 0.0) + r.seconds * share
        predicted[kind] = predicted.get(kind, 0.0) + record_seconds(r, rates)
    later = list(calls)[1:]
    if later and "call" in rates.points:
        measured["call"] = share * sum(seconds for _, seconds in later)
        predicted["call"] = overhead_seconds(sum(n for n, _ in later), rates)
    return {
        kind: measured[kind] / predicted[kind]
        for kind in measured
        if measured[kind] >= _NOISE_SECONDS and predicted[kind] > 0
    }


def replan(
    choice: Choice,
    structure: SceneStructure,
    rates: MachineRates,
    observed: dict[str, float],
    expected: Expected,
) -> Choice:
    """The choice again, for the ``expected`` rest of the run, with corrected rates.

    ``observed``: measured over predicted seconds per rate kind (:func:`misses`); only the
    kinds measured are corrected. The current algorithm's set-up is done (it costs nothing
    more), the others' is not.
    """
    corrected = rates.scaled(observed)
    predictions = {}
    for algorithm in choice.predictions:
        p = _predict(structure, algorithm, corrected, expected)
        if algorithm == choice.algorithm:
            p = dataclasses.replace(p, setup=0.0)
        predictions[algorithm] = p
    best = min(predictions, key=lambda a: (predictions[a].total, a != choice.algorithm))
    if SWITCH_GAIN * predictions[best].total > predictions[choice.algorithm].total:
        best = choice.algorithm  # a switch builds and factorises anew: only for a clear gain
    return Choice(best, predictions, True, dict(observed), dict(choice.skipped))


#: FULL factorises a matrix that holds every subdomain's: its factorisation is taken to
#: cost at least this fraction of the flops of the subdomains' factorisations with their
#: Schur complements, and a substitution with it to read at least this fraction of their
#: factors' entries (a safe bound: measured 0.62-0.95 of the flops and 0.88-1.06 of the
#: entries on the paper's joint and bar, docs/timing.md).
FULL_FACTOR_BOUND = 0.5


def full_cannot_win(
    structure: SceneStructure,
    rates: MachineRates,
    orders: tuple[str, ...],
    expected: Expected,
) -> float | None:
    """The least FULL's run can cost [s] if that is more than the best order's, else ``None``.

    FULL's factorisation and every re-factorisation, and every substitution (one per solve),
    cost at least :data:`FULL_FACTOR_BOUND` of the subdomains' work (analysed in
    ``structure``), done at the fastest rate measured: when that bound already loses to the
    best of ``orders``, FULL need not be analysed at all.
    """
    if not orders:
        return None
    best = min(_predict(structure, a, rates, expected).total for a in orders)
    flops = sum(s.flops for s in structure.subdomains.values())
    entries = sum(s.entries for s in structure.subdomains.values())
    e = expected
    solves = (e.steps + e.changes + e.releases) * e.tie_solves
    least = (1.0 + e.changes) * rates.least_seconds("sparse_factor", FULL_FACTOR_BOUND * flops)
    least += solves * rates.least_seconds("sparse_solve", FULL_FACTOR_BOUND * entries)
    return least if least > best else None
