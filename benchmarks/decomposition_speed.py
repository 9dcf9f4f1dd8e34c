"""Measured speed of every algorithm on the paper's rectangular parallelepiped (method.md 7.1).

The bar (``dd_contact.paper.examples.parallelepiped``) is pressed with one end against a tilted
rigid wall, so the contact area grows row by row and the contact state changes in most
steps. Every algorithm runs the same problem: FULL on one mesh with contact on its own end
face (the classical approach), v-w-u and w-v-u on two subdomains with an interface and a
contact interface, w-u on one mesh with a contact interface, v-u on two subdomains with
contact on the first one's end face.

Each run is its own process with every BLAS pinned to one thread (the PETSc wheel's
OpenBLAS is single-threaded; numpy's is not), so both sides get one core. Per run it records
the set-up time, the wall time of every time step and of every contact iteration, the work
log per block, and the peak memory. Derived, per algorithm (medians over runs):

* ``seconds_per_change``: a contact iteration that follows a state change (FULL:
  re-factorise the whole matrix and solve; the orders: re-factorise the small dense
  contact blocks and substitute);
* ``seconds_per_step_base``: a step without its change iterations (steps after the first,
  whose first iteration factorises and condenses: ``seconds_first_step``);
* ``seconds_per_step_2_changes``: base + 2 x per change (the issue's "two changes per step");
* ``floor_substitution``: the subdomain work of one step, the least a decomposition step can
  cost: per subdomain the median of its work for u_hat plus that for u (one substitution,
  MUMPS's forward and backward sweeps, with the default Schur condensation; two full
  substitutions before it);
* ``step_base_over_full``: an order's step without changes over FULL's (issue 14 target
  <= 1.1);
* ``whole_run_seconds``: scene, set-up and every step of one run; ``auto`` (on the w-v-u
  scene, told the run's length and 1.25 changes a step) gets ``auto_over_best_named``: its
  whole run over the best named algorithm's of the same number of steps (target <= 1.15);
* ``peak_memory_mb``: the largest peak resident memory of the runs (``_runs``: each), the
  worker's ``ru_maxrss`` / 1024: MiB (2^20 bytes; the key's name is kept for the earlier
  files).

``--algorithms "w-u classic" ...`` runs an algorithm with the paper's contact
(``energy_safe_contact=False``); beside its energy-safe run it gives
``safe_over_classic_per_change`` and ``safe_over_classic_per_step_base`` (issue 13: the
energy-safe steps' price, measured in one session).

``--before FILE`` adds the summary of an earlier run at the same size (e.g. of the code
before a change, run with its own copy of this script) under ``"before"``, with per-key
ratios after / before.

Writes benchmarks/results/decomposition_speed.json.

Run: python benchmarks/decomposition_speed.py [--elements 250 36 10] [--steps 8]
     [--full-steps 3] [--repeats 3] [--algorithms FULL w-v-u ...]
(about 40 minutes at the default size; it resumes from the JSON if interrupted).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from pinned import PINNED, pinned_record

HERE = Path(__file__).parent / "results"
ALGORITHMS = ["FULL", "v-w-u", "w-v-u", "w-u", "v-u", "auto"]
#: "<algorithm> classic": the same run with the paper's contact (energy_safe_contact=False),
#: to price the energy-safe steps (issue 13) in the same session
CLASSIC = [f"{a} classic" for a in ALGORITHMS if a != "auto"]
AUTO_SCENE = "w-v-u"  # auto runs on the two-subdomain scene with a contact interface
SLOW = ("FULL", "v-u")  # re-factorise a large sparse matrix on every change: fewer steps


def worker(args) -> dict:
    """One run of one algorithm (in its own process, BLAS already pinned)."""
    import resource

    from mpi4py import MPI

    import numpy as np

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped

    start = time.perf_counter()
    algorithm, *mode = args.worker.split()
    auto = algorithm == "auto"
    scene_of = AUTO_SCENE if auto else algorithm
    scene = parallelepiped(scene_of, tuple(args.elements), comm=MPI.COMM_SELF)
    n_steps = args.full_steps if algorithm in SLOW else args.steps
    # auto is told the run's length; the bar changes contact about 1.25 times a step
    expected = {"expected_steps": n_steps, "expected_changes": 1.25 * n_steps} if auto else {}
    problem = dd.TransientProblem(
        scene,
        args.dt,
        algorithm=algorithm,
        track_energy=False,
        energy_safe_contact=mode != ["classic"],
        **expected,
    )
    problem.start()
    setup = time.perf_counter() - start
    iterations = timed_iterations(problem)
    steps = []
    for _ in range(n_steps):
        iterations.clear()
        t0 = time.perf_counter()
        record = problem.advance()
        seconds = time.perf_counter() - t0
        steps.append(
            {
                "seconds": seconds,
                "changes": record["changes"],
                "iterations": list(iterations),
                "active": record["active"]["end"],
            }
        )
    records = problem.work.records
    substitutions = {}  # per subdomain: median seconds for u_hat plus median for u
    for block in {r.block for r in records if r.block.startswith("u:")}:
        parts = [
            [r.seconds for r in records if r.block == block and r.what == what]
            for what in ("u_hat", "u")
        ]
        substitutions[block] = sum(statistics.median(t) for t in parts if t) or None
    whole = time.perf_counter() - start
    return {
        "algorithm": args.worker,
        "chosen": problem.algorithm,
        "replanned": bool(getattr(problem.choice, "replanned", False)),
        "whole_run_seconds": whole,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "blocks": dict(problem.solver.system.sizes),
        "setup_seconds": setup,
        "steps": steps,
        "median_substitution_seconds": substitutions,
        "work": problem.work_summary(),
        "peak_memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "changes": problem.changes["gamma"],
        "check": float(np.linalg.norm(scene.subdomains[0].u.x.array)),
    }


def timed_iterations(problem, cpu: list[float] | None = None) -> list[float]:
    """The seconds of each contact iteration of ``problem`` from now on: a list it fills.

    ``cpu``: a list also given each iteration's CPU seconds (a loaded machine's wall is not).
    """
    iterations: list[float] = []
    solve_once = problem.iteration._solve_once

    def timed(*a):
        t0, c0 = time.perf_counter(), time.process_time()
        out = solve_once(*a)
        iterations.append(time.perf_counter() - t0)
        if cpu is not None:
            cpu.append(time.process_time() - c0)
        return out

    problem.iteration._solve_once = timed
    return iterations


def interleaved(
    script: str, args, options: list[str], mus: tuple[float, ...], after_each=None
) -> dict:
    """Runs of ``script``'s workers: per repeat and algorithm one per friction of ``mus``.

    Interleaved (the pair shares the machine's state), each its own process with BLAS
    pinned; ``options``: the worker's other arguments. By ``"<algorithm> mu=<mu>"``.
    ``after_each(runs)``: called after every run (to write what a cut session keeps).
    """
    runs: dict[str, list] = {}
    for repeat in range(args.repeats):
        for algorithm in args.algorithms:
            for mu in mus:
                command = [sys.executable, script, "--worker", algorithm, "--mu", str(mu)]
                print(f"run {repeat + 1}/{args.repeats}: {algorithm} mu={mu}", flush=True)
                run = pinned_record(command + options)
                runs.setdefault(f"{algorithm} mu={mu:g}", []).append(run)
                if after_each is not None:
                    after_each(runs)
    return runs


def derived(run: dict) -> dict:
    """Per-change, per-step and floor times of one run."""
    change = [t for s in run["steps"] for t in s["iterations"][1:]]
    # The first step's first iteration factorises and condenses everything: set-up, not a step.
    base = [s["seconds"] - sum(s["iterations"][1:]) for s in run["steps"][1:]]
    floor = None
    if run.get("chosen", run["algorithm"]) != "FULL":
        floor = sum(v for v in run["median_substitution_seconds"].values() if v)
    out = {
        "seconds_per_change": statistics.median(change) if change else None,
        "seconds_per_step_base": statistics.median(base),
        "seconds_per_step": statistics.median(s["seconds"] for s in run["steps"][1:]),
        "seconds_first_step": run["steps"][0]["seconds"],
        "changes_per_step": sum(s["changes"] for s in run["steps"]) / len(run["steps"]),
        "floor_substitution": floor,
        "whole_run_seconds": run.get("whole_run_seconds"),
    }
    if change:
        out["seconds_per_step_2_changes"] = (
            out["seconds_per_step_base"] + 2.0 * out["seconds_per_change"]
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[250, 36, 10])
    parser.add_argument("--dt", type=float, default=1e-6)
    parser.add_argument("--steps", type=int, default=8, help="steps of each decomposition run")
    parser.add_argument("--full-steps", type=int, default=3, help="steps of FULL and v-u runs")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--algorithms", nargs="+", default=ALGORITHMS, choices=ALGORITHMS + CLASSIC)
    parser.add_argument("--out", default=str(HERE / "decomposition_speed.json"))
    parser.add_argument("--before", help="JSON of an earlier run at the same size, to compare")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    out = Path(args.out)
    results = json.loads(out.read_text()) if out.exists() else {}
    same = results.get("elements") == args.elements and results.get("dt") == args.dt
    runs = results.get("runs", {}) if same else {}
    env = {**os.environ, **PINNED}
    for repeat in range(args.repeats):
        for algorithm in args.algorithms:
            if len(runs.get(algorithm, [])) > repeat:
                continue  # resumed: this run is already in the file
            command = [sys.executable, __file__, "--worker", algorithm, "--dt", str(args.dt)]
            command += ["--elements", *map(str, args.elements)]
            command += ["--steps", str(args.steps), "--full-steps", str(args.full_steps)]
            print(f"run {repeat + 1}/{args.repeats}: {algorithm}", flush=True)
            done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
            runs.setdefault(algorithm, []).append(json.loads(done.stdout.strip().splitlines()[-1]))
            summarise(args, runs, out)
    summarise(args, runs, out, show=True)


def summarise(args, runs: dict, out: Path, show: bool = False) -> None:
    """Medians over runs, FULL/order ratios, and the JSON file."""
    summary = {}
    for algorithm, rs in runs.items():
        ds = [derived(r) for r in rs]
        med = {}
        for key in ds[0]:
            values = [d[key] for d in ds if d.get(key) is not None]
            med[key] = statistics.median(values) if values else None
        med["setup_seconds"] = statistics.median(r["setup_seconds"] for r in rs)
        med["peak_memory_mb"] = max(r["peak_memory_mb"] for r in rs)
        med["peak_memory_mb_runs"] = [round(r["peak_memory_mb"], 1) for r in rs]
        med["dofs"] = rs[0]["dofs"]
        med["runs"] = len(rs)
        med["steps"] = len(rs[0]["steps"])
        if algorithm == "auto":
            med["chosen"] = sorted({r["chosen"] for r in rs})
            med["whole_run_seconds_runs"] = [r["whole_run_seconds"] for r in rs]
        summary[algorithm] = med
    auto = summary.get("auto")
    if auto and auto.get("whole_run_seconds"):
        # the best named algorithm of the same length of run (FULL and v-u run fewer steps)
        named = {
            a: m["whole_run_seconds"]
            for a, m in summary.items()
            if a != "auto" and m.get("whole_run_seconds") and m["steps"] == auto["steps"]
        }
        if named:
            best = min(named, key=named.get)
            auto["best_named"] = best
            auto["auto_over_best_named"] = auto["whole_run_seconds"] / named[best]
    full = summary.get("FULL")
    if full:
        for algorithm, med in summary.items():
            if algorithm in ("FULL", "auto"):
                continue
            for key in ("seconds_per_change", "seconds_per_step_2_changes", "seconds_per_step"):
                if med.get(key) and full.get(key):
                    med[f"full_over_this_{key.removeprefix('seconds_')}"] = full[key] / med[key]
            if med.get("seconds_per_step_base") and full.get("seconds_per_step_base"):
                med["step_base_over_full"] = (
                    med["seconds_per_step_base"] / full["seconds_per_step_base"]
                )
            if med.get("floor_substitution"):
                for key in ("seconds_per_step_base", "seconds_per_step_2_changes"):
                    if med.get(key):
                        med[f"{key}_over_floor"] = med[key] / med["floor_substitution"]
    for algorithm, med in summary.items():  # the energy-safe steps over the classic ones
        classic = summary.get(f"{algorithm} classic")
        for key in ("seconds_per_change", "seconds_per_step_base"):
            if classic and med.get(key) and classic.get(key):
                med[f"safe_over_classic_{key.removeprefix('seconds_')}"] = med[key] / classic[key]
    data = {
        "elements": args.elements,
        "dt": args.dt,
        "blas_threads": 1,
        "note": "each run in its own process, every BLAS pinned to one thread (one core each)",
        "summary": summary,
        "runs": runs,
    }
    if args.before:
        data["before"] = compared(Path(args.before), args.elements, summary)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(data, indent=1))
    if show:
        for algorithm, med in summary.items():
            print(algorithm, json.dumps({k: v for k, v in med.items()}, indent=None))


def compared(path: Path, elements: list[int], summary: dict) -> dict:
    """An earlier run's summary and, per algorithm, this run's values over its values."""
    before = json.loads(path.read_text())
    if before.get("elements") != elements:
        raise SystemExit(f"--before {path}: elements {before.get('elements')} != {elements}")
    ratios = {}
    for algorithm, old in before["summary"].items():
        new = summary.get(algorithm, {})
        ratios[algorithm] = {
            key: new[key] / value
            for key, value in old.items()
            if key.startswith(("seconds_", "peak_memory"))
            and isinstance(value, int | float)  # not the lists of each run's values
            and value
            and isinstance(new.get(key), int | float)
        }
    return {"file": path.name, "summary": before["summary"], "after_over_before": ratios}


if __name__ == "__main__":
    main()
