"""What the two paper demos share: run one algorithm step by step, compare runs, tabulate, chart.

A helper of `demo_parallelepiped.py` and `demo_pin_joint.py` (not a demo itself). Every
function is collective unless it says otherwise; pictures are drawn on rank 0.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import dd_contact as dc
from dd_contact import flops, viz

#: Steps over which every algorithm must match FULL to round-off (relative, max norm).
EARLY_STEPS = 2
EARLY_TOLERANCE = 1e-8


@dataclass
class Run:
    """One algorithm's run: what it did, what it cost, and its displacements."""

    algorithm: str  # as asked ("auto" included)
    chosen: str  # what ran
    model: str  # which variant of the model (layout) it ran on
    history: list[dict]
    step_seconds: np.ndarray
    early: list[np.ndarray]  # every subdomain's u after each of the first EARLY_STEPS steps
    final: np.ndarray  # ... and after the last step
    largest: float  # the largest displacement component over the run
    changes: dict[str, int]
    factorisations: int
    substitutions: int

    @property
    def seconds(self) -> float:
        return float(self.step_seconds.sum())

    def active(self, names: list[str]) -> np.ndarray:
        """Active contact points per step (rows) and contact region (columns)."""
        return np.array([[r["active"][n] for n in names] for r in self.history], dtype=int)


def displacements(scene: dc.Scene) -> np.ndarray:
    """Every subdomain's displacement in one vector (every rank holds them all)."""
    return np.concatenate([s.u.x.array for s in scene.subdomains])


def run_algorithm(
    make_scene: Callable[[], dc.Scene],
    algorithm: str,
    model: str,
    dt: float,
    n_steps: int,
    snapshot_step: int | None = None,
    snapshot: Callable[[dc.Scene, dc.TransientProblem], None] | None = None,
    **options,
) -> Run:
    """Time-step a fresh scene with one algorithm, timing each step.

    Energy-safe contact (``TransientProblem(energy_safe_contact=True)``): a point leaving
    contact never creates energy (docs/contact.md, "Impact"). ``snapshot(scene, problem)``
    is called after step ``snapshot_step`` (to draw the state there).
    """
    scene = make_scene()
    options = {"energy_safe_contact": True, "track_energy": False, **options}
    problem = dc.TransientProblem(scene, dt, algorithm=algorithm, expected_steps=n_steps, **options)
    seconds, early, largest = [], [], 0.0
    for step in range(1, n_steps + 1):
        scene.comm.Barrier()
        start = time.perf_counter()
        problem.advance()
        seconds.append(time.perf_counter() - start)
        largest = max(largest, float(np.abs(displacements(scene)).max()))
        if step <= EARLY_STEPS:
            early.append(displacements(scene))
        if snapshot is not None and step == snapshot_step:
            snapshot(scene, problem)
    work = problem.work_summary()
    run = Run(
        algorithm,
        problem.algorithm,
        model,
        list(problem.history),
        np.array(seconds),
        early,
        displacements(scene),
        largest,
        problem.changes,
        sum(b["decompositions"] for b in work.values()),
        sum(b["substitutions"] for b in work.values()),
    )
    problem.close()
    return run


def relative_difference(a: np.ndarray, b: np.ndarray, scale: float) -> float:
    """max |a - b| / scale."""
    return float(np.abs(a - b).max() / scale)


@dataclass
class Agreement:
    """How a run compares with FULL on the same model."""

    early: list[float]  # relative difference after each of the first EARLY_STEPS steps
    final: float  # ... after the last step (round-off that grows with the steps)
    same_history: bool  # same active points per contact region in every step

    @property
    def ok(self) -> bool:
        return max(self.early) < EARLY_TOLERANCE and self.same_history


def agreement(run: Run, full: Run, contacts: list[str]) -> Agreement:
    """Differences relative to FULL's largest displacement over the run (the scale of the
    response: early steps, when the load has just started, move little)."""
    scale = full.largest
    same = np.array_equal(run.active(contacts), full.active(contacts))
    return Agreement(
        [relative_difference(a, b, scale) for a, b in zip(run.early, full.early, strict=True)],
        relative_difference(run.final, full.final, scale),
        same,
    )


def model_gflops(scene: dc.Scene, n_steps: int, changes: dict[str, int]) -> dict[str, float]:
    """The paper's operation-count model for this scene and run (every fitting algorithm)."""
    sizes = flops.sizes_from_scene(scene, n_steps, changes)
    return {name: report.gflops_total for name, report in flops.compare(sizes).items()}


def table(runs: list[Run], checks: dict[str, Agreement], gflops: dict[str, float]) -> str:
    """The comparison table (text): cost, agreement with FULL, time relative to FULL."""
    full = next(r for r in runs if r.algorithm == "FULL")
    head = (
        f"{'algorithm':<13}{'model':<24}{'changes':>8}{'factor.':>9}{'subst.':>9}"
        f"{'time [s]':>10}{'model GFLOP':>13}{'time/FULL':>10}{'vs FULL, steps 1-2':>24}"
        f"{'last step':>11}{'history':>9}"
    )
    lines = [head, "-" * len(head)]
    for r in runs:
        name = r.algorithm if r.algorithm == r.chosen else f"{r.algorithm} ({r.chosen})"
        check = checks.get(r.algorithm)
        early = " ".join(f"{e:.0e}" for e in check.early) if check else "reference"
        final = f"{check.final:.1e}" if check else ""
        history = ("same" if check.same_history else "DIFFERS") if check else ""
        lines.append(
            f"{name:<13}{r.model:<24}{r.changes['gamma']:>8}{r.factorisations:>9}"
            f"{r.substitutions:>9}{r.seconds:>10.2f}{gflops.get(r.chosen, np.nan):>13.3g}"
            f"{r.seconds / full.seconds:>10.2f}{early:>24}{final:>11}{history:>9}"
        )
    return "\n".join(lines)


def markdown_table(text: str) -> str:
    """The text table as a markdown table (for the docs)."""
    rows = [line for line in text.splitlines() if not set(line) <= {"-"}]
    cells = [[c.strip() for c in _split(line)] for line in rows]
    out = ["| " + " | ".join(cells[0]) + " |", "|" + "---|" * len(cells[0])]
    out += ["| " + " | ".join(c) + " |" for c in cells[1:]]
    return "\n".join(out)


def _split(line: str) -> list[str]:
    widths = [13, 24, 8, 9, 9, 10, 13, 10, 24, 11, 9]
    cells, at = [], 0
    for w in widths:
        cells.append(line[at : at + w])
        at += w
    return cells


def check_agreement(checks: dict[str, Agreement]) -> None:
    """Stop the demo (SystemExit) if an algorithm does not agree with FULL."""
    wrong = {name: c for name, c in checks.items() if not c.ok}
    if wrong:
        raise SystemExit(
            f"algorithms disagree with FULL: {wrong}; expected a relative difference below "
            f"{EARLY_TOLERANCE} after {EARLY_STEPS} steps and the same contact history"
        )


# ----------------------------------------------------------------------------- charts


def pyplot():
    """matplotlib's pyplot without a display."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def strip_chart(path, times, active: np.ndarray, points: dict[str, int], names, title: str):
    """Which contact interfaces are in contact over time: one row each, shaded by the
    fraction of its points in contact (white: open; the scale ends at the largest fraction)."""
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


def step_time_chart(path, runs: list[Run], title: str):
    """Wall time of every step (log scale) and summed over the run, one line per algorithm."""
    plt = pyplot()
    fig, (each, total) = plt.subplots(1, 2, figsize=(11, 4))
    for r in runs:
        label = r.algorithm if r.algorithm == r.chosen else f"{r.algorithm} ({r.chosen})"
        steps = np.arange(1, len(r.step_seconds) + 1)
        each.semilogy(steps, 1e3 * r.step_seconds, lw=1, label=f"{label}, {r.model}")
        total.plot(steps, np.cumsum(r.step_seconds), lw=1.5, label=f"{label}, {r.model}")
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


def contact_fields_to_root(scene: dc.Scene) -> None:
    """Copy every contact surface's w and pressure from its owner to rank 0 (to draw them)."""
    comm = scene.comm
    if comm.size == 1:
        return
    mine = {
        c.name: (c.w.x.array.copy(), c.pressure.x.array.copy())
        for c in scene.contacts
        if scene.contact_owner(c) == comm.rank
    }
    everything = comm.gather(mine, root=0)
    if comm.rank == 0:
        fields = {k: v for part in everything for k, v in part.items()}
        for c in scene.contacts:
            c.w.x.array[:], c.pressure.x.array[:] = fields[c.name]


def plot_wall_pressures(scene: dc.Scene, path, title: str, scale: float = 50.0) -> None:
    """Every contact surface coloured by its contact pressure [MPa], one colour bar, the
    surfaces displaced by ``scale * w`` (rank-local: call contact_fields_to_root first)."""
    viz.use_headless_rendering()
    import pyvista

    pressures = np.concatenate([c.pressure.x.array for c in scene.contacts])
    top = float(pressures.max())
    plotter = pyvista.Plotter(off_screen=True, window_size=(1400, 700))
    for contact in scene.contacts:
        grid = viz.deformed_grid(contact.w, scale)
        grid.point_data["p"] = contact.pressure.x.array / 1e6
        plotter.add_mesh(
            grid,
            scalars="p",
            cmap="viridis",
            clim=[0.0, top / 1e6 if top > 0 else 1.0],
            show_edges=True,
            scalar_bar_args={"title": "contact pressure [MPa]", "position_x": 0.3},
        )
    plotter.add_text(f"{title}  (displacement x {scale:g})", font_size=10)
    plotter.view_vector((0.0, -1.0, 0.9))
    plotter.reset_camera()
    plotter.camera.zoom(1.6)
    plotter.add_axes()
    plotter.screenshot(str(path))
    plotter.close()


def summary(runs: list[Run], checks: dict[str, Agreement], gflops: dict[str, float], **extra):
    """What the demo measured, as JSON-ready data (``summary.json``; the tests read it)."""
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
                "model_gflops": gflops.get(r.chosen),
            }
            for r in runs
        ],
        "checks": {
            name: {"early": c.early, "final": c.final, "same_history": c.same_history}
            for name, c in checks.items()
        },
    }
