"""What friction on a contact pair costs per contact change: each algorithm with and without.

The pressed pair (``paper/verify/pair_friction.pressed_pair``): block B ((n-1) x (n-1) x 4
hexahedra) a gap above block A (n x n x 4, its base held), the two in a ContactPair (B's
bottom side a, non-matching), B's top pressed down with a tilt in static load steps: the
contact closes from x = 1 towards x = 0, a few rows a step. Without friction the changes
are the rows closing; with ``friction = mu`` also the points moving between stick and slip
(nu = 0.3: they slide along each other as they close), and the pair's contact region is
unsymmetric: the orders factorise the group that eliminates both w blocks with LU (and
every group it reaches), FULL its whole matrix with MUMPS's LU (docs/contact.md,
"Friction").

Runs interleaved: for every repeat and algorithm a frictionless run, then a frictional one,
each its own process with BLAS pinned to one thread. Per run: the seconds of each contact
iteration after a solve's first (a change: re-factorise what changed, solve again), the
factorisations in the work log, the changes, the peak memory; a run whose contact
iteration does not settle stops there and says so (``failed``: FULL's slip directions
jittered by 1e-5 at step 10 on 20 x 20 cells, above ``friction.DIRECTION_TOLERANCE``).
Per algorithm (medians over the repeats): seconds per change with and without friction and
their ratio, FULL's over each order's.

Writes benchmarks/results/pair_friction_cost.json.

Run: python benchmarks/pair_friction_cost.py [--cells 16] [--steps 10] [--repeats 3] [--mu 0.3]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from decomposition_speed import interleaved, timed_iterations

HERE = Path(__file__).parent / "results"
#: Scene of each algorithm: the lower block whole, or cut in two with an interface.
ALGORITHMS = {"FULL": "single", "w-u": "single", "v-w-u": "interface", "w-v-u": "interface"}


def scene(kind: str, cells: int, mu: float, steps: int):
    """The pressed pair (module docstring) on one rank."""
    from mpi4py import MPI

    from dd_contact.paper.verify.pair_friction import pressed_pair

    return pressed_pair(kind, mu, cells, steps, comm=MPI.COMM_SELF)


def worker(args) -> dict:
    """One run of one algorithm and mu (in its own process, BLAS already pinned)."""
    import resource

    import dd_contact as dd

    algorithm = args.worker
    problem = dd.StaticProblem(
        scene(ALGORITHMS[algorithm], args.cells, args.mu, args.steps), algorithm=algorithm
    )
    iterations = timed_iterations(problem)
    steps, failed = [], None
    for step in range(1, args.steps + 1):
        iterations.clear()
        try:
            problem.solve(float(step))
        except dd.errors.ContactIterationError as error:  # a result too: said, not timed
            failed = f"step {step}: {error}"
            break
        steps.append({"iterations": list(iterations), "changes": problem.iterations - 1})
    factors = [r for r in problem.work.records if r.kind in ("dense_factor", "sparse_factor")]
    out = {
        "algorithm": algorithm,
        "mu": args.mu,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "changes": problem.changes["gamma"],
        "failed": failed,
        "steps": steps,
        "factorisations": [[r.block, r.kind, r.size, r.seconds] for r in factors],
        "peak_memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
    problem.close()
    return out


def summarise(args, runs: dict) -> dict:
    """Medians per algorithm and friction, the ratios friction / none and FULL / order."""
    summary: dict = {}
    for key, found in runs.items():
        changes = [t for run in found for s in run["steps"] for t in s["iterations"][1:]]
        summary[key] = {
            "seconds_per_change": statistics.median(changes) if changes else None,
            "changes": [run["changes"] for run in found],
            "failed": [run["failed"] for run in found if run["failed"]],
            "dofs": found[0]["dofs"],
            "peak_memory_mb": max(run["peak_memory_mb"] for run in found),
        }
    mu = f"mu={args.mu:g}"
    for algorithm in args.algorithms:
        plain = summary.get(f"{algorithm} mu=0", {}).get("seconds_per_change")
        rough = summary.get(f"{algorithm} {mu}", {}).get("seconds_per_change")
        if plain and rough:
            summary[f"{algorithm} friction_over_none_per_change"] = rough / plain
        full = summary.get(f"FULL {mu}", {}).get("seconds_per_change")
        if algorithm != "FULL" and full and rough:
            summary[f"FULL_over_{algorithm}_per_change {mu}"] = full / rough
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cells", type=int, default=16)
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--mu", type=float, default=0.3)
    parser.add_argument("--algorithms", nargs="+", default=list(ALGORITHMS), choices=ALGORITHMS)
    parser.add_argument("--out", default=str(HERE / "pair_friction_cost.json"))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    options = ["--cells", str(args.cells), "--steps", str(args.steps)]
    runs = interleaved(__file__, args, options, (0.0, args.mu))
    summary = summarise(args, runs)
    out = Path(args.out)
    out.write_text(
        json.dumps({"arguments": vars(args), "summary": summary, "runs": runs}, indent=1)
    )
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
