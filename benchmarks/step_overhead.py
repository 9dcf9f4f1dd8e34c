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

Writes benchmarks/results/step_overhead_<cells>.json.

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
    args = parser.parse_args()
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


if __name__ == "__main__":
    main()
