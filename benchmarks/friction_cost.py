"""What friction costs per contact change: each algorithm with and without it, one session.

The bar of ``benchmarks/decomposition_speed.py`` (pressed on a tilted wall, its contact
area growing row by row) with ``friction = mu`` on its contact, runs interleaved: for every
repeat and algorithm a frictionless run, then a frictional one, each its own process with
BLAS pinned to one thread (``decomposition_speed.worker``). With friction a slipping point
makes the contact block unsymmetric: the orders factorise their dense contact group with
every point sticking (Cholesky) and correct for the slip (Woodbury), FULL factorises its
whole matrix with MUMPS's LU (docs/contact.md, "Friction").

Per algorithm (medians over the repeats): ``seconds_per_change`` with and without friction
and their ratio (the issue's target: at most 2), also of the changes' lower quartile
(``seconds_per_change_q1``: on a shared machine a preempted change costs a time slice
more, and friction's runs have several times more changes), the steps' base time, the
peak memory; and FULL's per-change time over each order's, with friction.

Writes benchmarks/results/friction_cost.json (``--out``), after every run.

Run: python benchmarks/friction_cost.py [--elements 80 12 4] [--steps 6] [--full-steps 3]
     [--repeats 3] [--mu 0.3]
At the issue's size (108k dofs, the bar of ``architecture_speed_108k.json``; FULL's LU
there takes 30-60 s a change, so few steps):
     python benchmarks/friction_cost.py --elements 160 24 8 --steps 4 --full-steps 2
     --algorithms w-u w-v-u v-w-u FULL --out benchmarks/results/friction_cost_108k.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
from pathlib import Path

import decomposition_speed
from decomposition_speed import derived, interleaved
from decomposition_speed import worker as speed_worker

HERE = Path(__file__).parent / "results"
ALGORITHMS = ["FULL", "w-u", "v-w-u", "w-v-u"]


def worker(args) -> dict:
    """One run: the bar of ``args.worker``'s algorithm with friction ``args.mu`` on its contact."""
    import dd_contact.paper.examples as examples

    plain = examples.parallelepiped

    def with_friction(*a, **k):
        scene = plain(*a, **k)
        for contact in scene.contacts:
            contact.friction = args.mu  # read when the contact operator is built
        return scene

    examples.parallelepiped = with_friction  # type: ignore[assignment]
    cpu: list[float] = []  # each iteration's CPU seconds: the wall's are a loaded machine's
    plain_timed = decomposition_speed.timed_iterations
    decomposition_speed.timed_iterations = lambda problem: plain_timed(problem, cpu)
    run = speed_worker(args)
    run["mu"], run["load_average"] = args.mu, os.getloadavg()  # 1, 5, 15 min, at its end
    run["cpu_iterations"], start = [], 0
    for step in run["steps"]:  # the step's iterations, in the order they ran
        run["cpu_iterations"].append(cpu[start : start + len(step["iterations"])])
        start += len(step["iterations"])
    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[80, 12, 4])
    parser.add_argument("--dt", type=float, default=1e-6)
    parser.add_argument("--steps", type=int, default=6)
    parser.add_argument("--full-steps", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--mu", type=float, default=0.3)
    parser.add_argument("--algorithms", nargs="+", default=ALGORITHMS, choices=ALGORITHMS)
    parser.add_argument("--out", default=str(HERE / "friction_cost.json"))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    options = ["--dt", str(args.dt), "--elements", *map(str, args.elements)]
    options += ["--steps", str(args.steps), "--full-steps", str(args.full_steps)]
    # written after every run: a session cut short keeps it
    runs = interleaved(__file__, args, options, (0.0, args.mu), lambda r: write(args, r))
    print(json.dumps(summarise(args, runs), indent=1))


def write(args, runs: dict) -> dict:
    """The summary of ``runs``, written with them to ``args.out``."""
    summary = summarise(args, runs)
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True)
    document = {
        "arguments": vars(args),
        "commit": commit.stdout.strip(),  # the code measured (uncommitted edits aside)
        "summary": summary,
        "runs": runs,
    }
    Path(args.out).write_text(json.dumps(document, indent=1))
    return summary


def summarise(args, runs: dict) -> dict:
    """Medians per algorithm and friction, the ratios friction / none and FULL / order."""
    summary: dict = {}
    for key, found in runs.items():
        parts = [derived(run) for run in found]
        summary[key] = {
            name: statistics.median(p[name] for p in parts if p[name] is not None)
            for name in ("seconds_per_change", "seconds_per_step_base")
            if any(p[name] is not None for p in parts)
        }
        # the machine is shared: a change preempted by another process takes a time
        # slice (~40 ms) more; the lower quartile of the changes is the one they spare
        changes = sorted(
            t for run in found for step in run["steps"] for t in step["iterations"][1:]
        )
        if changes:
            summary[key]["seconds_per_change_q1"] = changes[len(changes) // 4]
        per_run = [  # CPU seconds per change: the median of each run's, as the wall's
            statistics.median(t for step in run["cpu_iterations"] for t in step[1:])
            for run in found
            if any(step[1:] for step in run.get("cpu_iterations", []))
        ]
        if per_run:
            summary[key]["cpu_seconds_per_change"] = statistics.median(per_run)
        summary[key]["changes"] = [run["changes"] for run in found]
        summary[key]["dofs"] = found[0]["dofs"]
        summary[key]["peak_memory_mb"] = max(run["peak_memory_mb"] for run in found)
    mu = f"mu={args.mu:g}"
    for algorithm in args.algorithms:
        plain, rough = summary.get(f"{algorithm} mu=0", {}), summary.get(f"{algorithm} {mu}", {})
        for stat in ("seconds_per_change", "seconds_per_change_q1", "cpu_seconds_per_change"):
            if stat in plain and stat in rough:
                name = f"{algorithm} friction_over_none_{stat.replace('seconds_', '')}"
                summary[name] = rough[stat] / plain[stat]
        for stat in ("seconds_per_change", "seconds_per_change_q1", "cpu_seconds_per_change"):
            full = summary.get(f"FULL {mu}", {}).get(stat)
            if algorithm != "FULL" and full and stat in rough:
                name = f"FULL_over_{algorithm}_{stat.replace('seconds_', '')} {mu}"
                summary[name] = full / rough[stat]
    return summary


if __name__ == "__main__":
    main()
