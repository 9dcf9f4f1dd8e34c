"""Does the low-rank correction pay over a whole run? Updates on and off, priced and not.

The pin-joint demo's scene (``demos/demo_pin_joint.py``: rigid pins, 0.05 mm clearance,
20 kN at T = 2 ms, steps of 1.6 us, energy-safe contact) at a small scale runs the first hit
on the pins (400 steps: 0.64 ms) with FULL and with w-v-u and v-w-u, each order with the
low-rank correction of contact changes (``dd_contact/solvers/lowrank.py``) and without
(``"... refactorise"``: ``LowRankSurface.enabled = False``). A corrected solve is two passes
through the chain per Woodbury application, plus its refinements; that correction stays in
every later step until the groups are re-factorised. ``--package DIR`` runs the children
with another checkout of the package (the code before the correction priced its solves) and
labels the runs with ``--label``.

Every run is a process of its own with BLAS pinned to one thread; the runs are interleaved
(every configuration once, then again). Per run: the wall and CPU time of the whole run
(scene, problem, steps), contact changes, corrections (``"dense_update"`` records) and
dense factorisations, peak memory and ``|u - u_FULL|_max / |u_FULL|_max`` at the end.

    python benchmarks/lowrank_price.py --label after             # 8,3,2,12: 25,380 dofs
    python benchmarks/lowrank_price.py --label before --package /path/to/old/checkout

Writes (merges into) benchmarks/results/lowrank_price.json and prints a table.
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from pinned import PINNED

RUNS = ("FULL", "w-v-u", "w-v-u refactorise", "v-w-u", "v-w-u refactorise")
RESULT = Path(__file__).parent / "results" / "lowrank_price.json"


def one(run: str, scale: str, steps: int) -> dict:
    """One run in this process: its times, work counts and final field."""
    import dataclasses

    import dd_contact as dc
    from dd_contact.paper import models
    from dd_contact.solvers.lowrank import LowRankSurface

    algorithm, _, refactorise = run.partition(" ")
    LowRankSurface.enabled = not refactorise
    cpu, start = time.process_time(), time.perf_counter()
    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
    scene = models.pin_joint(layout, clearance=0.05e-3, load=20e3, period=2e-3)
    problem = dc.TransientProblem(scene, 1.6e-6, algorithm=algorithm, track_energy=False)
    for _ in range(steps):
        problem.advance()
    records = problem.work.records
    u = np.concatenate([s.u.x.array for s in scene.subdomains])
    return {
        "run": run,
        "whole_seconds": time.perf_counter() - start,
        "cpu_seconds": time.process_time() - cpu,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "changes": problem.changes["gamma"],
        "updates": sum(r.kind == "dense_update" for r in records),
        "dense_factorisations": sum(r.kind == "dense_factor" for r in records),
        "peak_memory_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "u": u[:: max(len(u) // 3000, 1)].tolist(),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scale", default="8,3,2,12", help="c,r,t,grip cell counts")
    parser.add_argument("--steps", type=int, default=400, help="steps of 1.6 us")
    parser.add_argument("--repeats", type=int, default=1, help="interleaved rounds")
    parser.add_argument("--runs", default=",".join(RUNS), help="runs, comma separated")
    parser.add_argument("--label", default="after", help="the results' name in the JSON")
    parser.add_argument("--package", help="checkout whose dd_contact the children import")
    parser.add_argument("--out", default=str(RESULT), help="the JSON file")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one(args.one, args.scale, args.steps)))
        return
    env = {**os.environ, **PINNED}
    if args.package:
        env["PYTHONPATH"] = args.package
    runs, rows = args.runs.split(","), {}
    for _ in range(args.repeats):
        for run in runs:
            command = [sys.executable, __file__, "--one", run, "--scale", args.scale]
            command += ["--steps", str(args.steps)]
            done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
            rows.setdefault(run, []).append(json.loads(done.stdout.strip().splitlines()[-1]))
    summary = summarise(rows)
    out = Path(args.out)
    report = json.loads(out.read_text()) if out.exists() else {}
    report.update({"scale": args.scale, "steps": args.steps, "blas_threads": 1})
    report.setdefault("labels", {})[args.label] = {
        "package": args.package or "this checkout",
        "load_average": os.getloadavg(),
        "summary": summary,
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1))
    print(
        f"{'run':<20}{'whole [s]':>11}{'cpu [s]':>9}{'x FULL cpu':>11}{'changes':>9}"
        f"{'updates':>9}{'factors':>9}{'|u-u_FULL|':>12}"
    )
    for run, r in summary.items():
        print(
            f"{run:<20}{r['whole_median']:>11.1f}{r['cpu_median']:>9.1f}"
            f"{r['cpu_over_full']:>11.2f}{r['changes']:>9}{r['updates']:>9}"
            f"{r['dense_factorisations']:>9}{r['difference_to_full']:>12.1e}"
        )


def summarise(rows: dict) -> dict:
    """Medians per run, and each against FULL's (CPU time: a shared machine's load aside)."""
    full = rows.get("FULL")
    out = {}
    for run, repeats in rows.items():
        first = repeats[0]
        u = np.array(first.pop("u"))
        for r in repeats[1:]:
            r.pop("u")
        out[run] = {
            "whole_median": statistics.median(r["whole_seconds"] for r in repeats),
            "cpu_median": statistics.median(r["cpu_seconds"] for r in repeats),
            "repeats": repeats,
            **{k: first[k] for k in ("dofs", "changes", "updates", "dense_factorisations")},
            "peak_memory_mib": max(r["peak_memory_mib"] for r in repeats),
            "u": u,
        }
    reference = out["FULL"]["u"] if full else None
    for r in out.values():
        u = r.pop("u")
        r["difference_to_full"] = (
            float(np.abs(u - reference).max() / np.abs(reference).max())
            if reference is not None
            else float("nan")
        )
        r["cpu_over_full"] = r["cpu_median"] / out["FULL"]["cpu_median"] if full else float("nan")
    return out


if __name__ == "__main__":
    main()
