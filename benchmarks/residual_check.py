"""Cost of the residual check that follows every solve, against the cost of a time step.

Runs the paper's parallelepiped (``dd_contact.paper.examples.parallelepiped``) with every
algorithm given on the command line, times each step's solves, and times the check
(:class:`dd_contact.solvers.residual.ResidualCheck.estimate`) on the same solution. The
check's share of a step is the median check time over the median step time. Also records
the estimate against the exact residual of the last solve, and the peak memory of the run.

Writes benchmarks/results/residual_check.json.

Run: python benchmarks/residual_check.py [--elements 120 18 6] [--steps 6] [--repeats 7]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time
from pathlib import Path

from mpi4py import MPI

from dd_contact import TransientProblem
from dd_contact.paper.examples import parallelepiped
from dd_contact.solvers.residual import exact_residual

OUT = Path(__file__).parent / "results" / "residual_check.json"


def run(algorithm: str, elements: tuple[int, int, int], steps: int, repeats: int) -> dict:
    scene = parallelepiped(algorithm, elements, comm=MPI.COMM_SELF)
    problem = TransientProblem(scene, 1e-6, algorithm=algorithm, track_energy=False)
    step_seconds = []
    for step in range(1, steps + 1):
        start = time.perf_counter()
        problem.run(step, progress=False, summary=False)
        step_seconds.append(time.perf_counter() - start)
    x = problem.solver.finish()
    rhs, contact = problem.iteration.solved_system(problem.tie_solver)
    check_seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        estimate = problem.iteration.check.estimate(rhs, x, contact)
        check_seconds.append(time.perf_counter() - start)
    start = time.perf_counter()
    exact = exact_residual(problem.solver.system, rhs, x, contact).whole
    exact_seconds = time.perf_counter() - start
    step = statistics.median(step_seconds[1:])  # the first step factorises
    check = statistics.median(check_seconds)
    return {
        "algorithm": algorithm,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "median_step_seconds": step,
        "median_check_seconds": check,
        "check_share_of_step": check / step,
        "exact_residual_seconds": exact_seconds,
        "exact_share_of_step": exact_seconds / step,
        "estimated_whole_residual": estimate.whole,
        "exact_whole_residual": exact,
        "estimated_free_residual": estimate.free,
        "changes": problem.changes["gamma"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs=3, default=[120, 18, 6])
    parser.add_argument("--steps", type=int, default=6)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--algorithms", nargs="+", default=["FULL", "w-v-u", "w-u"])
    args = parser.parse_args()
    records = []
    for algorithm in args.algorithms:
        record = run(algorithm, tuple(args.elements), args.steps, args.repeats)
        records.append(record)
        print(
            f"{algorithm:6s} {record['dofs']} dofs: step {record['median_step_seconds']:.4f} s, "
            f"check {1e3 * record['median_check_seconds']:.2f} ms "
            f"({100 * record['check_share_of_step']:.2f} %), exact residual "
            f"{100 * record['exact_share_of_step']:.1f} %, estimate/exact "
            f"{record['estimated_whole_residual']:.2e} / {record['exact_whole_residual']:.2e}",
            flush=True,
        )
    result = {
        "elements": args.elements,
        "records": records,
        "peak_memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
