"""The paper's two examples at the paper's size on this machine (issue 14 item 4, issue 15).

Runs ``models.parallelepiped`` (400 x 100 x 10 hexahedra, 1,336,533 dofs at ``paper``) and
``models.pin_joint`` (174,080 hexahedra at ``paper``) with the demos' loads and time steps,
each algorithm in its own process with every BLAS pinned to one thread. The parent watches
the resident memory of the worker and its children every half second, kills a run that
passes ``--memory-limit`` (the machine is shared), and samples the load average.

Per run it records: dofs, set-up time (scene, assembly, first factorisations: the first
step's first contact iteration), time per contact change (every contact iteration after
the first of a step), time per step without its change iterations, peak memory (the
worker's own ``ru_maxrss`` and the sampled whole-tree RSS), contact changes, the load
average over the run, and MUMPS's analysis (factor entries, flops) of what it factorises.
FULL runs until ``--full-changes`` contact changes are done.

``--analyse`` runs MUMPS's symbolic analysis only (no factorisation): factor entries, flops
and the timing model's prediction (``dd_contact.timing``) of set-up, step and change, used
to size the runs and to extrapolate FULL where it cannot run ("extrapolated").

The summary puts, per order, the whole-run time of the paper's study (Table 3: N_TS steps,
D changes; ``flops.paper.PAPER_BAR``) from the measured rates over FULL's, next to the
paper's FLOP ratios 0.600 / 0.153 / 0.146 %.

Besides the algorithms, ``--algorithms`` takes the iterative peers ``CG+GAMG`` and
``CG+Jacobi`` (FULL's matrix by warm-started CG on the one-mesh bar, iterative_peer.py) and
``"w-u reduced m=N"`` (every subdomain reduced to N modes); runs record CPU times too, the
summary gives each run's study against each peer's at the same scale, and carries reduced
runs (two scales) and peers to the paper's size (``benchmarks/study_estimate.py`` makes
the estimate of the reduced study from these runs).

Writes benchmarks/results/paper_scale.json after every finished run and resumes from it
(a run already in the file is skipped).

Run: python benchmarks/paper_scale.py --model parallelepiped --scale paper
     [--algorithms w-v-u w-u v-w-u FULL] [--steps 20] [--full-changes 2]
     python benchmarks/paper_scale.py --analyse --model parallelepiped --scale 1/4

The recorded results came from: ``--scale paper --algorithms w-v-u --petsc-options
'{"mat_mumps_icntl_22": 1}' --tag +ooc`` (out-of-core; in core it passed 16 GiB), ``--scale
1/4`` (all four), ``--analyse --scale 1/8`` and ``1/4`` (FULL's extrapolation), merged into
paper_scale.json with ``--merge``; the pin joint with ``--model pin_joint --out
benchmarks/results/paper_scale_pin_joint.json`` (w-v-u out-of-core: ``--petsc-options
'{"mat_mumps_icntl_22": 1}' --tag +ooc``; its memory per phase: setup_memory.py; v-w-u in
core with ``--memory-limit 20``). ``--table``
prints the summary.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import sys
import time
from pathlib import Path

from pinned import PINNED
from process_watch import timed_run

sys.path.insert(0, str(Path(__file__).parent))  # iterative_peer

HERE = Path(__file__).parent / "results"
#: The demos' loads and time steps (demos/demo_parallelepiped.py, demos/demo_pin_joint.py).
DEMO = {
    "parallelepiped": {"dt": 1e-4, "algorithms": ["w-v-u", "w-u", "v-w-u", "FULL"]},
    "pin_joint": {"dt": 4e-5, "algorithms": ["w-v-u", "v-w-u", "FULL"]},
    # benchmarks/decomposition_speed.py's bar pressed on a tilted wall (benchmarks/two_ranks.py)
    "bar": {"dt": 1e-6, "algorithms": ["w-v-u"]},
}
#: The paper's Table 3: an order's FLOPs in % of FULL's for the bar's study.
PAPER_PERCENT = {"v-w-u": 0.600, "w-v-u": 0.153, "w-u": 0.146}
GIB = 1024.0**3


# ------------------------------------------------------------------------------ the worker
def case_of(label: str) -> tuple[str, dict | None, bool]:
    """(algorithm, reduction, peer) of a run's label: an algorithm, an iterative peer
    (``CG+GAMG``, ``CG+Jacobi``: FULL by CG on the one-mesh bar, iterative_peer.py) or an
    order with every subdomain reduced (``"w-u reduced m=20"``: m fixed-interface modes;
    ``"w-u reduced m=320 tol=0.1"``: found to that tolerance; a trailing ``" ooc"``: the
    interior's factor out of core), the reduction as ``Subdomain.reduce``'s arguments."""
    import iterative_peer

    if label in iterative_peer.PEERS:
        return "FULL", None, True
    algorithm, _, reduction = label.partition(" reduced m=")
    if not reduction:
        return algorithm, None, False
    reduction, ooc, _ = reduction.partition(" ooc")
    modes, _, tolerance = reduction.partition(" tol=")
    options: dict = {"modes": int(modes)}
    if tolerance:
        options["tolerance"] = float(tolerance)
    if ooc:
        options["out_of_core"] = True
    return algorithm, options, False


def scene_for(model: str, scale: str, algorithm: str | None, comm, layout=None):
    """The model's scene at ``scale`` for ``algorithm`` (FULL runs the orders' split scene;
    ``layout``, the bar's: another, e.g. "FULL": one mesh, contact on its boundary)."""
    from dd_contact.paper import examples, models

    if model == "bar":
        return examples.parallelepiped(algorithm, _bar_scale(scale), comm=comm)

    if model == "parallelepiped":
        size = scale if scale in models.BAR_SCALES else _bar_scale(scale)
        layout = layout or ("w-u" if algorithm == "w-u" else None)
        return models.parallelepiped(size, algorithm=layout, comm=comm)
    if scale in models.PIN_JOINT_SCALES:
        return models.pin_joint(scale, comm=comm)
    return models.pin_joint(_joint_layout(scale), comm=comm)


def _bar_scale(scale: str):
    """A fraction of the paper's cells (``"1/8"``: nz kept, nx and ny scaled) or nx,ny,nz."""
    if "," in scale:
        return tuple(int(n) for n in scale.split(","))
    num, _, den = scale.partition("/")
    fraction = float(num) / float(den or 1)
    return (round(400 * fraction**0.5), round(100 * fraction**0.5), 10)


def _joint_layout(scale: str):
    """Cell counts ``c,r,t,grip`` of the pin joint (as demos/demo_pin_joint.py)."""
    import dataclasses

    from dd_contact.paper import models

    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    return dataclasses.replace(models.pin_joint_layout("small"), **counts)


def _analysis(problem) -> dict:
    """MUMPS's analysis of what the run factorises, and the timing model's prediction."""
    from dd_contact import timing
    from dd_contact.solvers import analysed

    full = problem.algorithm == "FULL"
    with problem.analysis.petsc_options():  # the analysis reads the factorisations' options
        structure = analysed.scene_structure(
            problem.comm,
            problem.solver.system,
            [z.region for z in problem.zones],
            problem.condensation,
            full=full,
            orders=not full,
        )
    rates = timing.machine_rates(comm=problem.comm)
    p = timing.predict(timing.plan(structure, problem.algorithm), rates, 1, 1)
    stats = {"FULL": structure.full} if full else structure.subdomains
    return {
        "factor_entries": {k: s.entries for k, s in stats.items()},
        "factor_gflop": {k: s.flops / 1e9 for k, s in stats.items()},
        "predicted_seconds": {"setup": p.setup, "step": p.step, "change": p.change},
    }


def worker(args) -> dict:
    """One run of one algorithm (its own process, BLAS pinned); collective over the ranks."""
    import contextlib

    from mpi4py import MPI

    import iterative_peer

    import dd_contact as dc

    comm = MPI.COMM_WORLD
    start, cpu_start = time.perf_counter(), time.process_time()
    algorithm, reduction, peer = case_of(args.worker)
    scene = scene_for(args.model, args.scale, algorithm, comm, "FULL" if peer else None)
    for sub in scene.subdomains if reduction is not None else ():
        sub.reduce(**reduction)
    options = dict(json.loads(args.petsc_options)) if args.petsc_options else None
    with iterative_peer.peer(args.worker, scene) if peer else contextlib.nullcontext():
        problem = dc.TransientProblem(
            scene, args.dt, algorithm=algorithm, track_energy=False, petsc_options=options
        )
    built = time.perf_counter() - start
    record: dict = {
        "model": args.model,
        "scale": args.scale,
        "algorithm": args.worker,
        "modes": None if reduction is None else reduction["modes"],
        "tolerance": None if reduction is None else reduction.get("tolerance"),
        "ranks": comm.size,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "blocks": {str(k): int(v) for k, v in problem.solver.system.sizes.items()},
        "petsc_options": options,
        "build_seconds": built,
    }
    if args.analyse:
        record.update(_analysis(problem))
        record["peak_rss_gib"] = comm.allgather(_peak_rss_gib())
        problem.close()
        return record
    iterations: list[float] = []
    cpu: list[float] = []  # the same in CPU time: the steadier clock on a loaded machine
    solve_once = problem.iteration._solve_once

    def timed(*a):
        comm.Barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        out = solve_once(*a)
        iterations.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        return out

    problem.iteration._solve_once = timed  # the benchmark's probe: one time per iteration
    steps = []
    changes_wanted = args.full_changes if args.worker == "FULL" else None
    record["build_cpu_seconds"] = time.process_time() - cpu_start
    for _ in range(args.steps):
        iterations.clear()
        cpu.clear()
        comm.Barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        result = problem.advance()
        steps.append(
            {
                "seconds": time.perf_counter() - t0,
                "cpu_seconds": time.process_time() - c0,
                "changes": int(result["changes"]),
                "iterations": list(iterations),
                "iterations_cpu": list(cpu),
                "active": {k: int(v) for k, v in result["active"].items()},
                "force": {k: [float(f) for f in v] for k, v in result["force"].items()},
            }
        )
        print(json.dumps({"progress": steps[-1]}), file=sys.stderr, flush=True)
        done = sum(s["changes"] for s in steps)
        if changes_wanted is not None and done >= changes_wanted and len(steps) >= 2:
            break
    record.update(
        {
            "steps": steps,
            "changes": int(sum(s["changes"] for s in steps)),
            "work": problem.work_summary(),
            "peak_rss_gib": comm.allgather(_peak_rss_gib()),
            "cg_iterations": getattr(problem.solver, "iterations", None),
        }
    )
    problem.close()
    return record


def _peak_rss_gib() -> float:
    """This process's peak resident memory [GiB] (Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0**2


# ------------------------------------------------------------------------------ the parent
def derived(run: dict) -> dict:
    """Set-up, per change and per step (medians) of one run; by CPU time too if recorded."""
    steps = run["steps"]
    first = steps[0]["iterations"][0] if steps and steps[0]["iterations"] else 0.0
    change = [t for s in steps for t in s["iterations"][1:]]
    base = [s["seconds"] - sum(s["iterations"][1:]) for s in steps[1:]]
    cpu = {}
    if steps and "cpu_seconds" in steps[0]:
        c_change = [t for s in steps for t in s["iterations_cpu"][1:]]
        c_base = [s["cpu_seconds"] - sum(s["iterations_cpu"][1:]) for s in steps[1:]]
        cpu = {
            "setup_cpu_seconds": run["build_cpu_seconds"] + steps[0]["iterations_cpu"][0],
            "cpu_per_change": statistics.median(c_change) if c_change else None,
            "cpu_per_step": statistics.median(c_base) if c_base else None,
        }
    return cpu | {
        "setup_seconds": run["build_seconds"] + first,
        "seconds_per_change": statistics.median(change) if change else None,
        "seconds_per_step": statistics.median(base) if base else None,
        "changes": run["changes"],
        "steps": len(steps),
        "total_seconds": run["build_seconds"] + sum(s["seconds"] for s in steps),
        "peak_rss_gib": max(run["peak_rss_gib"]),
    }


def summary(data: dict) -> dict:
    """Per run key (model|scale|algorithm): derived values, and per order the ratios to FULL
    at the same scale (measured) or, at the paper's size, to FULL extrapolated."""
    from dd_contact.paper.flops.paper import PAPER_BAR

    runs = {k.removesuffix("|run"): r for k, r in data["runs"].items() if k.endswith("|run")}
    out = {key: derived(run) for key, run in runs.items() if "steps" in run}
    models = {key.split("|")[0] for key in data["runs"]}
    full_paper = {m: extrapolated_full(data, m) for m in models}
    n, changes = PAPER_BAR.steps, PAPER_BAR.changes  # N_TS and D of Table 3

    def whole(x):
        return x["setup_seconds"] + n * x["seconds_per_step"] + changes * x["seconds_per_change"]

    for key, d in out.items():
        model, scale, algorithm = key.split("|")
        full = out.get(f"{model}|{scale}|FULL") or out.get(
            f"{model}|{scale.removesuffix('+ooc')}|FULL"  # FULL in core, the order out-of-core
        )
        if full is None and scale.startswith("paper") and full_paper[model]:
            full, d["full_extrapolated"] = full_paper[model], True
        if algorithm == "FULL" or not full or full["seconds_per_change"] is None:
            continue
        if d["seconds_per_change"] is None:
            continue
        d["full_over_this_per_change"] = full["seconds_per_change"] / d["seconds_per_change"]
        d["this_over_full_per_step"] = d["seconds_per_step"] / full["seconds_per_step"]
        if model == "parallelepiped":  # Table 3 is the bar's study
            d["percent_of_full_paper_study"] = 100.0 * whole(d) / whole(full)
            d["paper_percent_flops"] = PAPER_PERCENT.get(algorithm)
    for model, extrapolated in full_paper.items():
        if extrapolated:
            out[f"{model}|paper|FULL (extrapolated)"] = extrapolated
    for model in models:
        _extrapolate_by_cells(out, model, full_paper[model], whole)
    _against_peers(out, whole)
    return out


#: Runs carried to the paper's size by a power law in the cells (:func:`_extrapolate_by_cells`).
CARRIED = ("reduced", "CG+")


def _extrapolate_by_cells(out: dict, model: str, full: dict | None, whole) -> None:
    """Reduced runs and the peers at the paper's size, from their measured runs.

    Measured at two or more scales: a power law in the cell count through them per rate
    (set-up, step, change, peak memory; wall and CPU). A peer at one scale: linear in the
    cells (its CG iteration is a sweep over the matrix; its iteration count is taken to stay
    the same, which favours the peer). Marked ``extrapolated`` with the exponents used.
    """
    import numpy as np

    keys = ("setup_seconds", "seconds_per_step", "seconds_per_change", "peak_rss_gib")
    keys += ("setup_cpu_seconds", "cpu_per_step", "cpu_per_change")
    by_label: dict[str, dict[float, dict]] = {}
    for key, d in out.items():
        m, scale, label = key.split("|")
        if m == model and scale != "paper" and "extrapolated" not in d:
            if any(c in label for c in CARRIED) and not scale.startswith("paper"):
                by_label.setdefault(label, {})[float(cells(model, scale))] = d
    target = float(cells(model, "paper"))
    for label, runs in by_label.items():
        sizes = sorted(runs)
        if len(sizes) < 2 and "CG+" not in label:  # a reduced run: two sizes needed
            continue
        estimate: dict = {"extrapolated": True, "from_cells": sizes, "exponents": {}}
        for k in keys:
            points = [(c, runs[c][k]) for c in sizes if runs[c].get(k)]
            if not points:
                continue
            if len(points) >= 2:
                slope = float(
                    np.polyfit(np.log([c for c, _ in points]), np.log([v for _, v in points]), 1)[0]
                )
            else:
                slope = 1.0
            c, v = points[-1]
            estimate[k] = v * (target / c) ** slope
            estimate["exponents"][k] = slope
        if full and estimate.get("seconds_per_change") and estimate.get("seconds_per_step"):
            estimate["percent_of_full_paper_study"] = 100.0 * whole(estimate) / whole(full)
        out[f"{model}|paper|{label} (extrapolated)"] = estimate


def _against_peers(out: dict, whole) -> None:
    """Per run, the paper's study by each iterative peer at the same scale over its own."""
    import iterative_peer

    for key, d in out.items():
        model, scale, algorithm = key.split("|")
        for label in iterative_peer.PEERS:
            suffix = " (extrapolated)" if algorithm.endswith(" (extrapolated)") else ""
            peer = out.get(f"{model}|{scale}|{label}{suffix}")
            if peer is None or algorithm.startswith(label) or not peer.get("seconds_per_change"):
                continue
            if d.get("seconds_per_change") is None or d.get("seconds_per_step") is None:
                continue
            d[f"{label}_over_this_paper_study"] = whole(peer) / whole(d)
            if peer.get("cpu_per_change") and d.get("cpu_per_change") and d.get("cpu_per_step"):
                d[f"{label}_over_this_paper_study_cpu"] = whole_cpu(peer) / whole_cpu(d)


def whole_cpu(x: dict) -> float:
    """The paper's study (Table 3's steps and changes) by a run's CPU-time rates."""
    from dd_contact.paper.flops.paper import PAPER_BAR

    steps, changes = PAPER_BAR.steps * x["cpu_per_step"], PAPER_BAR.changes * x["cpu_per_change"]
    return x["setup_cpu_seconds"] + steps + changes


def cells(model: str, scale: str) -> int:
    """Hexahedra of a model at a scale of this script (bar: ``paper``, ``1/4``, ``nx,ny,nz``;
    joint: ``paper`` or ``c,r,t,grip``)."""
    from dd_contact.paper import models
    from dd_contact.paper.flops.paper import pin_joint_mesh_counts

    scale = scale.split("+")[0]  # a tag (+ooc, ...) names the run, not the size
    if model == "pin_joint":
        layout = models.pin_joint_layout("paper") if scale == "paper" else _joint_layout(scale)
        return pin_joint_mesh_counts(layout)["hexahedra"]
    nx, ny, nz = (400, 100, 10) if scale == "paper" else _bar_scale(scale)
    return nx * ny * nz


def extrapolated_full(data: dict, model: str = "parallelepiped") -> dict | None:
    """FULL at the paper's size from its measured run at a smaller size (marked extrapolated).

    MUMPS's analysis of FULL's matrix at the analysed sizes (``--analyse``) gives factor
    flops and entries; a power law in the cell count through them carries the measured
    set-up and change time (flops) and the step time and memory (entries) to the paper.
    """
    import numpy as np

    analysed = {
        key.split("|")[1]: run
        for key, run in data["runs"].items()
        if key.startswith(f"{model}|") and key.endswith("|FULL|analysis") and "failed" not in run
    }
    measured = {
        key.split("|")[1]: run
        for key, run in data["runs"].items()
        if key.startswith(f"{model}|") and key.endswith("|FULL|run") and "steps" in run
    }
    if len(analysed) < 2 or not measured or "paper" in measured:  # measured: no need
        return None
    n = np.log([cells(model, s) for s in analysed])
    fits = {}
    for what in ("factor_gflop", "factor_entries"):
        y = np.log([sum(r[what].values()) for r in analysed.values()])
        fits[what] = np.polyfit(n, y, 1)  # slope, intercept

    def law(what: str, scale: str) -> float:
        slope, intercept = fits[what]
        return float(np.exp(intercept + slope * np.log(cells(model, scale))))

    scale, run = max(measured.items(), key=lambda item: cells(model, item[0]))
    d = derived(run)
    flops = law("factor_gflop", "paper") / law("factor_gflop", scale)
    entries = law("factor_entries", "paper") / law("factor_entries", scale)
    return {
        "extrapolated": True,
        "from_scale": scale,
        "exponent_flops": float(fits["factor_gflop"][0]),
        "exponent_entries": float(fits["factor_entries"][0]),
        "factor_gflop": law("factor_gflop", "paper"),
        "factor_entries": law("factor_entries", "paper"),
        "setup_seconds": d["setup_seconds"] * flops,
        "seconds_per_change": d["seconds_per_change"] * flops,
        "seconds_per_step": d["seconds_per_step"] * entries,
        "peak_rss_gib": d["peak_rss_gib"] * entries,
        "load_average_mean": run.get("load_average_mean"),
    }


def markdown(data: dict) -> str:
    """The summary as a markdown table (for the README and the demo pages)."""
    head = (
        "| model, scale | algorithm | dofs | steps | changes | set-up [s] | per step [s] "
        "| per change [s] | peak RSS [GiB] | load avg | % of FULL, paper's study | paper |"
    )
    rows = [head, "|" + "---|" * 12]
    for key, d in data.get("summary", {}).items():
        model, scale, algorithm = key.split("|")
        run = data["runs"].get(key + "|run", {})
        dofs = run.get(
            "dofs",
            data["runs"].get(f"{model}|{scale.removesuffix('+ooc')}|w-v-u|run", {}).get("dofs"),
        )
        percent = d.get("percent_of_full_paper_study")
        paper = d.get("paper_percent_flops")
        change = d["seconds_per_change"]
        load = d.get("load_average_mean", run.get("load_average_mean"))
        rows.append(
            f"| {model}, {scale} | {algorithm} | {dofs or '-'} | {d.get('steps', '-')} "
            f"| {d.get('changes', '-')} | {d['setup_seconds']:.0f} | {d['seconds_per_step']:.2f} "
            f"| {'-' if change is None else f'{change:.3g}'} | {d['peak_rss_gib']:.1f} "
            f"| {'-' if load is None else f'{load:.1f}'} "
            f"| {'-' if percent is None else f'{percent:.3f} %'} "
            f"| {'-' if paper is None else f'{paper:.3f} %'} |"
        )
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model", choices=sorted(DEMO), default="parallelepiped")
    parser.add_argument("--scale", default="paper", help="paper, a fraction '1/4', or counts")
    parser.add_argument("--algorithms", nargs="+")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--full-changes", type=int, default=2)
    parser.add_argument("--memory-limit", type=float, default=16.0, help="GiB, whole tree")
    parser.add_argument("--petsc-options", help="JSON, e.g. '{\"mat_mumps_icntl_35\": 2}'")
    parser.add_argument("--tag", default="", help="suffix of the scale in the run key, e.g. '+ooc'")
    parser.add_argument("--analyse", action="store_true", help="MUMPS analysis only")
    parser.add_argument("--table", action="store_true", help="print the file as markdown")
    parser.add_argument("--merge", nargs="+", help="add the runs of these JSON files (resumed)")
    parser.add_argument("--out", default=str(HERE / "paper_scale.json"))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--dt", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        record = worker(args)
        from mpi4py import MPI

        if MPI.COMM_WORLD.rank == 0:
            print(json.dumps(record), flush=True)
        return
    out = Path(args.out)
    data = json.loads(out.read_text()) if out.exists() else {}
    if args.table:
        print(markdown(data))
        return
    runs = data.setdefault("runs", {})
    if args.merge:
        for other in args.merge:
            runs.update(json.loads(Path(other).read_text())["runs"])
        data["summary"] = summary(data)
        out.write_text(json.dumps(data, indent=1))
        return
    env = {**os.environ, **PINNED}
    for algorithm in args.algorithms or DEMO[args.model]["algorithms"]:
        kind = "analysis" if args.analyse else "run"
        key = "|".join([args.model, args.scale + args.tag, algorithm, kind])
        if key in runs and "failed" not in runs[key]:
            print(f"{key}: in the file, skipped", flush=True)
            continue
        command = [sys.executable, __file__, "--worker", algorithm, "--model", args.model]
        command += ["--scale", args.scale, "--steps", str(args.steps)]
        command += ["--full-changes", str(args.full_changes)]
        command += ["--dt", str(DEMO[args.model]["dt"])]
        command += ["--analyse"] * args.analyse
        if args.petsc_options:
            command += ["--petsc-options", args.petsc_options]
        print(f"{key}: running", flush=True)
        log = out.with_name(f"paper_scale_{key.replace('|', '_').replace('/', 'over')}.log")
        runs[key] = timed_run(command, env, args.memory_limit, log)
        data["summary"] = summary(data)
        data["note"] = (
            "each run its own process, BLAS pinned to one thread; a shared 2-core machine "
            "(load average recorded per run); FULL runs the orders' split scene"
        )
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(data, indent=1))
        brief = {k: v for k, v in runs[key].items() if k not in ("steps", "work", "blocks")}
        print(json.dumps(brief), flush=True)


if __name__ == "__main__":
    main()
