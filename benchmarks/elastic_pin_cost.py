"""What a contact state change costs on the joint with elastic pins, FULL against the orders.

The paper's multi-pin joint with elastic steel pins (``models.pin_joint(pins="elastic")``:
each pin a subdomain held at its ends, in a contact pair with each of its two hole walls),
no clearance, solved statically at the load's peaks, alternately pulled and pushed
(t = T/4, 3T/4, 5T/4, ...): at every reversal the plates leave one side of each pin and
press on the other, and the contact iteration passes through several contact states. The
cost of a change is what it re-factorises: per solve, the seconds of the factorisations in
its work log (``problem.work``: MUMPS numeric factorisations, dense factorisations, Schur
complements, the condensation of a re-factorised group into the later levels
(``what="condense"``: B^T A^-1 B), and a low-rank correction's work in their place:
``"dense_update"`` and the ``what="lowrank"`` eliminations) over its contact state
changes; beside it the wall time of a contact iteration (a solve's seconds over its
iterations: re-factorisation and substitutions).
A pair's change is corrected point by point (dd_contact/solvers/pointwise.py): its cost is
the ``"dense_update"`` record and the eliminations of points not seen before.
Reported are the medians over the reversals (the first solve, which sets up, left out).
Each algorithm runs in its own process with every BLAS
pinned to one thread; its peak memory (max RSS) is reported too. The orders run twice:
with the low-rank correction of contact changes (dd_contact/solvers/lowrank.py) and with
it off ("... refactorise"); per solve the contact points and how many changed state.

    python benchmarks/elastic_pin_cost.py                   # 6,7,4,34: 87,405 dofs
    python benchmarks/elastic_pin_cost.py --scale 3,2,1,4   # 5,460 dofs, seconds
    python benchmarks/elastic_pin_cost.py --algorithms "FULL,v-w-u refactorise" \
        --variants "all 10" --package /old/checkout --out DIR   # some, another checkout's

Writes benchmarks/results/elastic_pin_cost.json (another scale's file is named after it)
and prints a table.
"""

import argparse
import dataclasses
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from pinned import PINNED

#: An order followed by " refactorise" runs with the low-rank correction of contact changes
#: off (dd_contact/solvers/lowrank.py): every change re-factorises the groups it makes stale.
ALGORITHMS = ("FULL", "v-w-u", "w-v-u", "v-w-u refactorise", "w-v-u refactorise")
DEFAULT_SCALE = "6,7,4,34"
#: The pins in the joint (their holes in contact), as benchmarks/pin_joint_ordering.py.
VARIANTS = {"all 10": [0, 1, 2, 3, 4], "2 holes": [2]}
PERIOD = 2e-3
#: The work records of a (re-)factorisation, and of a low-rank correction instead of one.
FACTOR_KINDS = ("sparse_factor", "dense_factor", "schur", "dense_update")


def change_work(record) -> bool:
    """Whether a work record is part of what a contact change costs (not a substitution)."""
    return record.kind in FACTOR_KINDS or record.what in ("lowrank", "condense")


def result_name(scale: str) -> str:
    """The JSON file of a run at ``scale``."""
    suffix = "" if scale == DEFAULT_SCALE else f"_{scale}"
    return f"elastic_pin_cost{suffix}.json"


def one(algorithm: str, scale: str, reversals: int, variant: str) -> dict:
    """Run one algorithm in this process; its timings, changes and peak memory."""
    from mpi4py import MPI

    import dd_contact as dc
    from dd_contact.paper import models
    from dd_contact.solvers.lowrank import LowRankSurface

    algorithm, _, refactorise = algorithm.partition(" ")
    LowRankSurface.enabled = not refactorise

    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
    start = time.perf_counter()
    scene = models.pin_joint(
        layout,
        clearance=0.0,
        pins="elastic",
        contact_pins=VARIANTS[variant],
        comm=MPI.COMM_SELF,
    )
    dofs = sum(s.num_dofs for s in scene.subdomains)
    rows = []
    with dc.StaticProblem(scene, algorithm=algorithm) as problem:
        setup = time.perf_counter() - start
        for k in range(reversals + 1):
            t = PERIOD * (0.25 + 0.5 * k)
            before, first = problem.changes["gamma"], len(problem.work.records)
            states = {k: a.copy() for k, a in problem.iteration.active.items()}
            tic = time.perf_counter()
            problem.solve(t)
            seconds = time.perf_counter() - tic
            records = problem.work.records[first:]
            factors = [r for r in records if change_work(r)]
            rows.append(
                {
                    "t": t,
                    "seconds": seconds,
                    "iterations": problem.iterations,
                    "changes": problem.changes["gamma"] - before,
                    "factor_seconds": sum(r.seconds for r in factors),
                    "updates": sum(r.kind == "dense_update" for r in records),
                    "points": sum(len(a) for a in states.values()),
                    "points_changed": sum(
                        int(np.count_nonzero(a != problem.iteration.active[k]))
                        for k, a in states.items()
                    ),
                    "factorisations": {
                        f"{r.kind} {r.block} ({r.size})": sum(
                            1 for q in factors if (q.kind, q.block) == (r.kind, r.block)
                        )
                        for r in factors
                        if r.kind in FACTOR_KINDS[:3]
                    },
                }
            )
        fields = np.concatenate([s.u.x.array for s in scene.subdomains])
        forces = {k: v.tolist() for k, v in problem.contact_forces().items()}
    later = [r for r in rows[1:] if r["changes"] > 0]  # the first solve also sets up
    per_change = [r["factor_seconds"] / r["changes"] for r in later]
    per_iteration = [r["seconds"] / r["iterations"] for r in later]
    return {
        "algorithm": algorithm + (" refactorise" if refactorise else ""),
        "dofs": dofs,
        "setup_seconds": setup,
        "solves": rows,
        "per_change": per_change,
        "per_change_median": float(np.median(per_change)) if per_change else float("nan"),
        "per_iteration_median": float(np.median(per_iteration)),
        "peak_memory_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "field_norm": float(np.linalg.norm(fields)),
        "fields_head": fields[:: max(len(fields) // 2000, 1)].tolist(),
        "contact_forces": forces,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scale", default=DEFAULT_SCALE, help="c,r,t,grip cell counts")
    parser.add_argument("--reversals", type=int, default=4, help="load reversals measured")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # a child: run this algorithm
    parser.add_argument("--variant", default="all 10", help=argparse.SUPPRESS)
    parser.add_argument("--variants", default=",".join(VARIANTS), help="variants run")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    parser.add_argument("--algorithms", default=",".join(ALGORITHMS), help="those run")
    parser.add_argument("--package", help="checkout whose dd_contact the children import")
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one(args.one, args.scale, args.reversals, args.variant)))
        return
    start = time.perf_counter()
    report = {
        "scale": args.scale,
        "reversals": args.reversals,
        "machine": platform.node(),
        "blas_threads": 1,
        "variants": {v: run_variant(v, args) for v in args.variants.split(",")},
    }
    report["seconds"] = time.perf_counter() - start
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / result_name(args.scale)).write_text(json.dumps(report, indent=1))
    for variant, v in report["variants"].items():
        print(f"elastic-pin joint {args.scale}, {variant}: {v['dofs']:,} dofs")
        print(
            f"{'algorithm':<10}{'per change [ms]':>17}{'x FULL':>8}{'per iteration [ms]':>20}"
            f"{'x FULL':>8}{'peak MiB':>10}{'|u - u_FULL|':>14}"
        )
        for algorithm, r in v["algorithms"].items():
            print(
                f"{algorithm:<10}{1e3 * r['per_change_median']:>17.1f}"
                f"{r['ratio_to_full']:>8.1f}{1e3 * r['per_iteration_median']:>20.1f}"
                f"{r['iteration_ratio_to_full']:>8.1f}"
                f"{r['peak_memory_mib']:>10.0f}{r['difference_to_full']:>14.2e}"
            )
        print(f"best order {v['best_order']}: a change {v['best_ratio']:.1f}x cheaper than FULL's")


def run_variant(variant: str, args) -> dict:
    """Every algorithm on one variant, each in a process of its own with BLAS pinned."""
    env = {**os.environ, **PINNED}
    if args.package:
        env["PYTHONPATH"] = args.package
    results, algorithms = {}, args.algorithms.split(",")
    for algorithm in algorithms:
        command = [sys.executable, __file__, "--one", algorithm, "--scale", args.scale]
        command += ["--reversals", str(args.reversals), "--variant", variant]
        done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
        results[algorithm] = json.loads(done.stdout.strip().splitlines()[-1])
    full = results["FULL"]
    reference = np.array(full["fields_head"])
    for r in results.values():
        difference = np.abs(np.array(r.pop("fields_head")) - reference).max()
        r["difference_to_full"] = float(difference / np.abs(reference).max())
        r["ratio_to_full"] = full["per_change_median"] / r["per_change_median"]
        r["iteration_ratio_to_full"] = full["per_iteration_median"] / r["per_iteration_median"]
    best = min(algorithms[1:], key=lambda a: results[a]["per_change_median"])
    return {
        "pins": VARIANTS[variant],
        "dofs": full["dofs"],
        "best_order": best,
        "best_ratio": results[best]["ratio_to_full"],
        "algorithms": results,
    }


if __name__ == "__main__":
    main()
