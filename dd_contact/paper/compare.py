"""Run every algorithm on one model and compare them: cost, agreement with FULL, charts.

What the paper's two demos do, for any transient scene (``docs/compare.md``):
:func:`run_algorithm` time-steps a fresh scene with one algorithm and keeps what it did and
cost (:class:`Run`); :func:`agreement` compares a run with FULL's; :func:`table` and
:func:`summary` report them; :func:`strip_chart` and :func:`step_time_chart` chart them.

**What agreement to expect.** The block system (14) is ill-conditioned (the tiny bar's,
diagonally scaled: 7e10), so any two exact solvers of it differ by round-off: FULL's own
solution of one static step is 2-3e-8 (relative) from an iteratively refined one. The
trapezoidal rule neither damps nor amplifies such a difference, so it adds up over the
steps. FULL run again with another MUMPS ordering drifts from FULL as far as the orders do
(1e-7 to 1e-6 of the largest displacement after 80-640 steps). A run therefore
agrees with FULL when its difference stays within :data:`ROUNDOFF_FACTOR` times that of
the **round-off reference** (:func:`roundoff_run`; at least :data:`ROUNDOFF_FLOOR`), is
below :data:`EARLY_TOLERANCE` after the first :data:`EARLY_STEPS` steps, before the
round-off has grown, and has the same contact history (active points in every step).

Every function is collective unless it says otherwise; charts are rank-local (draw on one
rank).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dd_contact.paper import flops
from dd_contact.parallel import barrier
from dd_contact.problem import TransientProblem
from dd_contact.scene import Scene
from dd_contact.viz import pyplot

__all__ = [
    "EARLY_STEPS",
    "EARLY_TOLERANCE",
    "ROUNDOFF_FACTOR",
    "ROUNDOFF_FLOOR",
    "ROUNDOFF_OPTIONS",
    "Agreement",
    "Run",
    "agreement",
    "checkpoint_steps",
    "disagreements",
    "displacements",
    "markdown_table",
    "model_gflops",
    "pyplot",
    "roundoff_run",
    "run_algorithm",
    "step_time_chart",
    "strip_chart",
    "summary",
    "table",
]

#: Steps over which every algorithm must match FULL to :data:`EARLY_TOLERANCE` (relative).
EARLY_STEPS = 2
EARLY_TOLERANCE = 1e-8
#: A run agrees with FULL over the whole run when its difference is at most this many times
#: the round-off reference's, or than :data:`ROUNDOFF_FLOOR` (measured ratios 0.3-5).
ROUNDOFF_FACTOR = 10.0
#: The least round-off accepted: FULL's own error in one static solve of the bar is 2-3e-8,
#: so a round-off reference that happens to drift less than that is no yardstick.
ROUNDOFF_FLOOR = 1e-7
#: PETSc options of the round-off reference: FULL with MUMPS's AMD ordering (ICNTL(7) = 0)
#: instead of the default, the same equations eliminated in another order.
ROUNDOFF_OPTIONS = {"mat_mumps_icntl_7": 0}
ROUNDOFF_NAME = "FULL, AMD"


def checkpoint_steps(n_steps: int) -> list[int]:
    """The steps whose displacements a run keeps: 1, 2, 4, 8, ... and the last."""
    steps, k = [], 1
    while k < n_steps:
        steps.append(k)
        k *= 2
    return [*steps, n_steps]


@dataclass
class Run:
    """One algorithm's run: what it did, what it cost, and its displacements."""

    algorithm: str  # as asked ("auto" included)
    chosen: str  # what ran
    model: str  # which variant of the model it ran on
    history: list[dict]
    step_seconds: np.ndarray
    checkpoints: dict[int, np.ndarray]  # step -> every subdomain's u (checkpoint_steps)
    largest: float  # the largest displacement component over the run
    changes: dict[str, int]
    factorisations: int
    substitutions: int
    #: The energy balance's books per checked step, ``(step, gain, allowed)``
    #: (:class:`~dd_contact.monitors.EnergyBalance`; empty without ``track_energy``).
    gains: list[tuple[int, float, float]] = field(default_factory=list)

    @property
    def label(self) -> str:
        """The algorithm, and what ran if it was chosen (``auto (w-v-u)``)."""
        return (
            self.algorithm if self.chosen in self.algorithm else f"{self.algorithm} ({self.chosen})"
        )

    @property
    def seconds(self) -> float:
        """Wall time of all steps [s]."""
        return float(self.step_seconds.sum())

    def active(self, names: Sequence[str]) -> np.ndarray:
        """Active contact points per step (rows) and contact region (columns)."""
        return np.array([[r["active"][n] for n in names] for r in self.history], dtype=int)


def displacements(scene: Scene) -> np.ndarray:
    """Every subdomain's displacement in one vector (every rank holds them all)."""
    return np.concatenate([s.u.x.array for s in scene.subdomains])


def run_algorithm(
    make_scene: Callable[[], Scene],
    algorithm: str,
    dt: float,
    n_steps: int,
    model: str = "",
    snapshot_step: int | None = None,
    snapshot: Callable[[Scene, TransientProblem], None] | None = None,
    label: str | None = None,
    **options,
) -> Run:
    """Time-step a fresh scene with one algorithm, timing each step.

    ``options`` go to :class:`dd_contact.TransientProblem` (energy tracking off unless
    asked: it costs time). ``snapshot(scene, problem)`` is called after step
    ``snapshot_step`` (to draw the state there). ``label`` names the run instead of the
    algorithm (the round-off reference).
    """
    scene = make_scene()
    options = {"track_energy": False, **options}
    problem = TransientProblem(scene, dt, algorithm=algorithm, expected_steps=n_steps, **options)
    kept = set(checkpoint_steps(n_steps))
    seconds, checkpoints, largest = [], {}, 0.0
    for step in range(1, n_steps + 1):
        barrier(scene.comm)
        start = time.perf_counter()
        problem.advance()
        seconds.append(time.perf_counter() - start)
        u = displacements(scene)
        largest = max(largest, float(np.abs(u).max()))
        if step in kept:
            checkpoints[step] = u.copy()
        if snapshot is not None and step == snapshot_step:
            snapshot(scene, problem)
    work = problem.work_summary()
    run = Run(
        label or algorithm,
        problem.algorithm,
        model,
        list(problem.history),
        np.array(seconds),
        checkpoints,
        largest,
        problem.changes,
        sum(b["decompositions"] for b in work.values()),
        sum(b["substitutions"] for b in work.values()),
        list(problem.energy_balance.gains),
    )
    problem.close()
    return run


def roundoff_run(
    make_scene: Callable[[], Scene], dt: float, n_steps: int, model: str = "", **options
) -> Run:
    """FULL again with another MUMPS ordering: how far two exact solvers drift apart."""
    petsc = {**(options.pop("petsc_options", None) or {}), **ROUNDOFF_OPTIONS}
    return run_algorithm(
        make_scene, "FULL", dt, n_steps, model, label=ROUNDOFF_NAME, petsc_options=petsc, **options
    )


@dataclass
class Agreement:
    """How a run compares with FULL on the same model (relative to FULL's largest u)."""

    early: list[float]  # after each of the first EARLY_STEPS steps
    worst: float  # the largest over the checkpoints
    final: float  # after the last step
    same_history: bool  # same active points per contact region in every step
    roundoff: float | None  # the round-off reference's worst (None: not run)

    @property
    def limit(self) -> float:
        """The largest difference accepted over the run."""
        reference = ROUNDOFF_FLOOR if self.roundoff is None else self.roundoff
        return ROUNDOFF_FACTOR * max(reference, ROUNDOFF_FLOOR)

    @property
    def ok(self) -> bool:
        """Below the early tolerance, within the limit, and the same contact history."""
        return max(self.early) < EARLY_TOLERANCE and self.worst <= self.limit and self.same_history


def agreement(
    run: Run, full: Run, contacts: Sequence[str], roundoff: Run | None = None
) -> Agreement:
    """Differences from FULL at the checkpoints.

    Relative to FULL's largest displacement over the run (early steps, when a load has just
    started, move little).
    """

    def differences(other: Run) -> dict[int, float]:
        return {
            step: float(np.abs(u - full.checkpoints[step]).max() / full.largest)
            for step, u in other.checkpoints.items()
        }

    mine = differences(run)
    steps = sorted(mine)
    return Agreement(
        [mine[s] for s in steps[:EARLY_STEPS]],
        max(mine.values()),
        mine[steps[-1]],
        bool(np.array_equal(run.active(contacts), full.active(contacts))),
        None if roundoff is None else max(differences(roundoff).values()),
    )


def disagreements(checks: dict[str, Agreement]) -> str | None:
    """What disagrees with FULL, as a sentence, or ``None`` when every run agrees."""
    wrong = {name: c for name, c in checks.items() if not c.ok}
    if not wrong:
        return None
    parts = [
        f"{name}: early {max(c.early):.1e}, worst {c.worst:.1e} (limit {c.limit:.1e}), "
        f"history {'same' if c.same_history else 'differs'}"
        for name, c in wrong.items()
    ]
    return (
        f"algorithms disagree with FULL ({'; '.join(parts)}); expected below {EARLY_TOLERANCE:g} "
        f"after {EARLY_STEPS} steps, within {ROUNDOFF_FACTOR:g}x the round-off reference "
        f"(at least {ROUNDOFF_FLOOR:g}) over the run, and the same contact history"
    )


def model_gflops(scene: Scene, n_steps: int, changes: dict[str, int]) -> dict[str, float]:
    """The paper's operation-count model for this scene and run (every fitting algorithm)."""
    sizes = flops.sizes_from_scene(scene, n_steps, changes)
    return {name: report.gflops_total for name, report in flops.compare(sizes).items()}


# ----------------------------------------------------------------------------- the table

_COLUMNS = (  # heading, text width
    ("algorithm", 16), ("model", 24), ("changes", 8), ("factor.", 9), ("subst.", 9),
    ("time [s]", 10), ("model GFLOP", 13), ("time/FULL", 10), ("vs FULL, steps 1-2", 20),
    ("worst", 9), ("limit", 9), ("history", 9),
)  # fmt: skip


def _rows(runs: Sequence[Run], checks: dict[str, Agreement], gflops: dict[str, float]):
    full = next(r for r in runs if r.algorithm == "FULL")
    rows = []
    for r in runs:
        check = checks.get(r.algorithm)
        if check is None:
            agreed = ["reference" if r is full else "", "", "", ""]
        else:
            agreed = [
                " ".join(f"{e:.0e}" for e in check.early),
                f"{check.worst:.1e}",
                f"{check.limit:.1e}",
                "same" if check.same_history else "DIFFERS",
            ]
        rows.append([
            r.label, r.model, str(r.changes["gamma"]), f"{r.factorisations:.0f}",
            f"{r.substitutions:.0f}", f"{r.seconds:.2f}", f"{gflops.get(r.chosen, np.nan):.3g}",
            f"{r.seconds / full.seconds:.2f}", *agreed,
        ])  # fmt: skip
    return rows


def table(runs: Sequence[Run], checks: dict[str, Agreement], gflops: dict[str, float]) -> str:
    """The comparison table (text): cost, time relative to FULL, agreement with FULL."""
    rows = _rows(runs, checks, gflops)
    widths = [w for _, w in _COLUMNS]
    line = lambda cells: "".join(  # noqa: E731
        f"{c:<{w}}" if k < 2 else f"{c:>{w}}"
        for k, (c, w) in enumerate(zip(cells, widths, strict=True))
    )
    head = line([h for h, _ in _COLUMNS])
    return "\n".join([head, "-" * len(head), *map(line, rows)])


def markdown_table(
    runs: Sequence[Run], checks: dict[str, Agreement], gflops: dict[str, float]
) -> str:
    """The comparison table in markdown (for the docs)."""
    rows = [[h for h, _ in _COLUMNS], *_rows(runs, checks, gflops)]
    out = ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(_COLUMNS)]
    return "\n".join([*out[:1], out[1], *("| " + " | ".join(r) + " |" for r in rows[1:])])


def summary(
    runs: Sequence[Run], checks: dict[str, Agreement], gflops: dict[str, float], **extra
) -> dict:
    """What was measured, as JSON-ready data (the demos' ``summary.json``)."""
    return {
        **extra,
        "runs": [
            {
                "algorithm": r.algorithm,
                "chosen": r.chosen,
                "model": r.model,
                "changes": r.changes,
                "factorisations": r.factorisations,
                "substitutions": r.substitutions,
                "seconds": r.seconds,
                "step_seconds": r.step_seconds.tolist(),
                "model_gflops": gflops.get(r.chosen),
            }
            for r in runs
        ],
        "checks": {
            name: {
                "early": c.early,
                "worst": c.worst,
                "final": c.final,
                "roundoff": c.roundoff,
                "limit": c.limit,
                "same_history": c.same_history,
            }
            for name, c in checks.items()
        },
    }


# ----------------------------------------------------------------------------- charts


def strip_chart(
    path: str | Path,
    times: np.ndarray,
    active: np.ndarray,
    points: dict[str, int],
    names: Sequence[str],
    title: str,
) -> None:
    """Chart which contact regions are in contact over time.

    One row each, shaded by the fraction of its points in contact (white: open; the scale
    ends at the largest fraction).
    """
    plt = pyplot()
    fraction = active / np.array([points[n] for n in names])[None, :]
    top = float(fraction.max()) if fraction.max() > 0 else 1.0
    fig, ax = plt.subplots(figsize=(8, max(2.4, 0.9 + 0.32 * len(names))))
    dt = times[1] - times[0] if len(times) > 1 else 1.0
    extent = [1e3 * (times[0] - dt / 2), 1e3 * (times[-1] + dt / 2), len(names) - 0.5, -0.5]
    image = ax.imshow(
        fraction.T, aspect="auto", cmap="Reds", vmin=0.0, vmax=top, extent=extent,
        interpolation="nearest",
    )  # fmt: skip
    ax.set_yticks(range(len(names)), names)
    ax.set_xlabel("time [ms]")
    ax.set_title(title)
    fig.colorbar(image, ax=ax, label="points in contact [fraction]", pad=0.01)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def step_time_chart(path: str | Path, runs: Sequence[Run], title: str) -> None:
    """Wall time of every step (log scale) and summed over the run, one line per run."""
    plt = pyplot()
    fig, (each, total) = plt.subplots(1, 2, figsize=(11, 4))
    for r in runs:
        steps = np.arange(1, len(r.step_seconds) + 1)
        each.semilogy(steps, 1e3 * r.step_seconds, lw=1, label=f"{r.label}, {r.model}")
        total.plot(steps, np.cumsum(r.step_seconds), lw=1.5, label=f"{r.label}, {r.model}")
    each.set_ylabel("wall time of the step [ms]")
    total.set_ylabel("wall time since the start [s]")
    for ax in (each, total):
        ax.set_xlabel("time step")
        ax.grid(alpha=0.3, which="both")
    total.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
