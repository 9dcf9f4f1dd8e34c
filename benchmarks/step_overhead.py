"""The per-step work every algorithm shares (issue 28): CPU per step, before and after.

Runs the pin joint of ``pin_joint_reduced.py`` (its worker, ``--cells`` default 4,3,2,12,
``--steps`` 300) for each case (default ``FULL``, ``v-w-u`` and ``cheaper:300@v-w-u``) with
two copies of the package: ``--before`` (a directory holding an older ``dd_contact``, e.g.
``git archive main | tar -x -C /tmp/before``) and ``--after`` (default this tree; a copy
lets the tree change while it runs). Runs are interleaved
(case by case, before then after, ``--repeats`` times, every BLAS on one thread); the step
loop's CPU seconds per step are reported as medians, with the ratio before/after. One more
run of each under cProfile gives the CPU per step of the worker's parts (profiled runs
are slower: their times are shares, not speeds). The contact-force histories of the two
copies are compared: ``force_difference`` is their largest difference over the peak force
(0 when bit-identical).

Writes benchmarks/results/step_overhead_<cells>.json. ``--parts`` instead times the coarse
parts of :data:`TIMED` unprofiled (wrappers summing each call's CPU time), one interleaved
run per copy and case: benchmarks/results/step_overhead_parts_<cells>.json.

Run: python benchmarks/step_overhead.py --before /tmp/before [--cells 4,3,2,12]
     [--steps 300] [--repeats 3] [--cases FULL v-w-u cheaper:300@v-w-u]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from pinned import PINNED

HERE = Path(__file__).parent
AFTER = HERE.parent


#: Coarse parts of a step timed unprofiled (module, qualified name): each call's CPU time
#: summed by a wrapper (about a microsecond a call; parts overlap, a part includes its calls).
TIMED = [
    ("problem", "TransientProblem._advance"),
    ("analysis", "Analysis.solve"),
    ("iteration", "ContactIteration._solve_once"),
    ("solvers.full", "MonolithicSolver._solve"),
    ("solvers.engine", "BlockEliminationSolver._solve"),
    ("iteration", "ContactIteration._finished"),
    ("problem", "TransientProblem._inertia_loads"),
    ("impact", "StartForces.__init__"),
    ("analysis", "Analysis.publish"),
    ("analysis", "Analysis.agree"),
    ("iteration", "ContactIteration._checked"),
    ("iteration", "ContactIteration._decide"),
    ("assembly", "ContactZone.contribution"),
    ("solvers.full", "MonolithicSolver.set_contact"),
    ("solvers.engine", "BlockEliminationSolver.set_contact"),
    ("kinematics", "Kinematics.step"),
    ("post", "Reactions.of"),
    ("analysis", "Analysis.loads"),
]


def parts_worker(args) -> dict:
    """CPU ms a step of each of :data:`TIMED` (after 20 steps), in this process."""
    import functools
    import importlib
    import time
    import warnings

    import pin_joint_reduced as joint

    import dd_contact as dd

    spent: dict[str, float] = {}

    def timed(owner, name: str) -> None:
        function = getattr(owner, name)

        @functools.wraps(function)
        def wrapper(*a, **k):
            start = time.process_time()
            try:
                return function(*a, **k)
            finally:
                label = f"{owner.__name__}.{name}"
                spent[label] = spent.get(label, 0.0) + time.process_time() - start

        setattr(owner, name, wrapper)

    for module, name in TIMED:
        owner = importlib.import_module(f"dd_contact.{module}")
        *path, last = name.split(".")
        for attribute in path:
            owner = getattr(owner, attribute)
        timed(owner, last)
    scene = joint._scene(args.cells, args.parts_worker)
    algorithm = joint._case(args.parts_worker)[0]
    problem = dd.TransientProblem(
        scene, joint.DT, algorithm=algorithm, energy_safe_contact=True, track_energy=False
    )
    problem.start()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(20):
            problem.advance()
        spent.clear()
        start = time.process_time()
        for _ in range(args.steps):
            problem.advance()
    out = {k: round(1e3 * v / args.steps, 3) for k, v in spent.items()}
    return {"cpu_ms_per_step": round(1e3 * (time.process_time() - start) / args.steps, 3)} | out


def _run(tree: Path, case: str, args, dump: Path, profile: bool) -> dict:
    """One worker of ``pin_joint_reduced.py`` with the package of ``tree``."""
    command = [sys.executable, str(HERE / "pin_joint_reduced.py"), "--worker", case]
    command += ["--cells", args.cells, "--steps", str(args.steps), "--dump", str(dump)]
    command += ["--profile"] * profile
    env = {**os.environ, **PINNED, "PYTHONPATH": str(tree)}
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"{case} ({tree}): {done.stderr[-3000:]}")
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--before", required=True, help="directory with the older dd_contact")
    parser.add_argument("--after", default=str(AFTER), help="the newer one (default: here)")
    parser.add_argument("--label", default="main", help="what --before is (for the JSON)")
    parser.add_argument("--cells", default="4,3,2,12")
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cases", nargs="+", default=["FULL", "v-w-u", "cheaper:300@v-w-u"])
    parser.add_argument("--out", help="the JSON (default by the cells)")
    parser.add_argument("--parts", action="store_true", help="only the unprofiled parts")
    parser.add_argument("--parts-worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.parts_worker:
        print(json.dumps(parts_worker(args)))
        return
    if args.parts:
        _parts(args)
        return
    trees = {"before": Path(args.before).resolve(), "after": Path(args.after).resolve()}
    cpu: dict = {c: {t: [] for t in trees} for c in args.cases}
    loads: list[float] = []
    out: dict = {"cells": args.cells, "steps": args.steps, "repeats": args.repeats}
    out |= {"before": args.label, "cpus": os.cpu_count(), "threads": "pinned to 1"}
    results: dict = {}
    with tempfile.TemporaryDirectory() as temporary:
        dumps = {t: Path(temporary) / t for t in trees}
        for d in dumps.values():
            d.mkdir()
        for repeat in range(args.repeats):
            for case in args.cases:
                for tree, path in trees.items():  # interleaved: before, after
                    loads.append(round(os.getloadavg()[0], 2))
                    r = _run(path, case, args, dumps[tree], profile=False)
                    cpu[case][tree].append(r["steps_cpu_seconds"] / args.steps)
                    print(case, tree, repeat, round(1e3 * cpu[case][tree][-1], 3), "ms/step")
        for case in args.cases:
            forces = {t: np.load(dumps[t] / f"{case}.npy") for t in trees}
            parts = {
                t: _run(p, case, args, dumps[t], True)["profile_cpu_per_step"]
                for t, p in trees.items()
            }
            median = {t: statistics.median(v) for t, v in cpu[case].items()}
            difference = np.abs(forces["after"] - forces["before"]).max(initial=0.0)
            peak = np.abs(forces["before"]).max(initial=0.0)
            results[case] = {
                "cpu_per_step": median,
                "cpu_per_step_runs": {t: [round(v, 6) for v in vs] for t, vs in cpu[case].items()},
                "speedup": median["before"] / median["after"],
                "profile_cpu_per_step": parts,
                "force_difference": float(difference / peak) if peak else float(difference),
                "peak_force": float(peak),
                "bit_identical": bool(np.array_equal(forces["after"], forces["before"])),
            }
    out |= {"load_average": loads, "results": results}
    name = f"step_overhead_{args.cells.replace(',', '-')}.json"
    Path(args.out or HERE / "results" / name).write_text(json.dumps(out, indent=1))


def _parts(args) -> None:
    """CPU per step of each timed part, before and after, one interleaved run each."""
    trees = {"before": Path(args.before).resolve(), "after": Path(args.after).resolve()}
    results: dict = {case: {} for case in args.cases}
    loads = []
    for case in args.cases:
        for tree, path in trees.items():
            command = [sys.executable, __file__, "--parts-worker", case, "--before", "-"]
            command += ["--cells", args.cells, "--steps", str(args.steps)]
            env = {**os.environ, **PINNED, "PYTHONPATH": str(path)}
            loads.append(round(os.getloadavg()[0], 2))
            done = subprocess.run(command, env=env, capture_output=True, text=True)
            if done.returncode:
                raise RuntimeError(f"{case} ({tree}): {done.stderr[-3000:]}")
            results[case][tree] = json.loads(done.stdout.splitlines()[-1])
            print(case, tree, results[case][tree]["cpu_ms_per_step"], "ms/step")
    out = {"cells": args.cells, "steps": args.steps, "before": args.label, "load_average": loads}
    name = f"step_overhead_parts_{args.cells.replace(',', '-')}.json"
    out |= {"unit": "CPU ms per step (after 20 steps)", "results": results}
    Path(args.out or HERE / "results" / name).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
