"""What friction on a contact pair costs per contact change: each algorithm with and without.

Block B ((n-1) x (n-1) x 4 hexahedra) on block A (n x n x 4, its base held), the two in a
ContactPair (B's bottom side a, non-matching), in static load steps. Without friction, B
starts a gap above A and its top is pushed down with a tilt: the contact closes from x = 1
towards x = 0, a few rows a step (the changes). With ``friction = mu``, B starts touching,
is pressed by its top and pushed along x: its points go from stick to slip, edges first
(the changes), as in ``dd-contact verify --case sliding-pair``. Not the frictional press:
points entering contact while they move along the other side start slipping at 1.6 to 33
times their limit (their trial counts the motion they had while open) and their slip
directions reversed at every iteration (docs/contact.md, "Friction", "Between bodies").
So the two kinds of change differ, but each re-factorises the same groups: Cholesky without
friction, LU with (the pair's region is unsymmetric: the orders factorise the group that
eliminates both w blocks with LU, and every group it reaches; FULL its whole matrix with
MUMPS's LU).

Runs interleaved: for every repeat and algorithm a frictionless run, then a frictional one,
each its own process with BLAS pinned to one thread. Per run: the seconds of each contact
iteration after a solve's first (a change: re-factorise what changed, solve again), the
factorisations in the work log, the changes, the peak memory. Per algorithm (medians over
the repeats): seconds per change with and without friction and their ratio, FULL's over
each order's.

Writes benchmarks/results/pair_friction_cost.json.

Run: python benchmarks/pair_friction_cost.py [--cells 20] [--steps 10] [--repeats 3] [--mu 0.3]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from decomposition_speed import PINNED

HERE = Path(__file__).parent / "results"
#: Scene of each algorithm: the lower block whole, or cut in two with an interface.
ALGORITHMS = {"FULL": "single", "w-u": "single", "v-w-u": "interface", "w-v-u": "interface"}
GAP, PUSH, HEIGHT = 1e-4, 5e-5, 0.25


def scene(kind: str, cells: int, mu: float, steps: int):
    """B on A (module docstring): pressed with a tilt (mu = 0) or pushed along (mu > 0)."""
    from mpi4py import MPI

    import numpy as np

    import dd_contact as dd
    from dd_contact import meshes

    material = dd.Material(1000.0, 0.3 if mu == 0 else 0.0, 1.0)

    def at(z):
        return lambda x: np.isclose(x[2], z)

    cuts = [0.0, HEIGHT] if kind == "single" else [0.0, HEIGHT / 2, HEIGHT]
    layers = 4 // (len(cuts) - 1)
    lower = [
        dd.Subdomain(
            meshes.box(MPI.COMM_SELF, [0, 0, z0], [1, 1, z1], [cells, cells, layers]),
            material,
            f"A{i}",
        )
        for i, (z0, z1) in enumerate(itertools.pairwise(cuts))
    ]
    lower[0].fix(at(0.0))
    interface = None
    if kind == "interface":
        surface = meshes.surface_from_boundary(lower[0].mesh, at(cuts[1]), comm=MPI.COMM_SELF)
        interface = dd.Interface(surface, lower)
    gap = GAP if mu == 0 else 0.0
    bottom, top = HEIGHT + gap, 2 * HEIGHT + gap
    mesh = meshes.box(MPI.COMM_SELF, [0, 0, bottom], [1, 1, top], [cells - 1, cells - 1, 4])
    upper = dd.Subdomain(mesh, material, "B")

    def pressed(x, t):  # reaches A at x = 1 half-way, about x = 1/3 at the end
        down = -2.0 * GAP * t / steps * (0.25 + 0.75 * x[0])
        return np.stack([0 * x[0], 0 * x[0], down])

    if mu == 0:
        upper.fix(at(top), value=pressed)
    else:  # the push of the sliding pair, scaled to reach mu N in about half the steps
        push = PUSH * 20 / steps
        upper.fix(at(top), components=[0, 1], value=lambda x, t: (push * t, 0.0, 0.0))
        upper.add_traction(at(top), [0.0, 0.0, -1.0])
    a = dd.ContactInterface.from_boundary(upper, at(bottom), None, name="bottom")
    b = dd.ContactInterface.from_boundary(lower[-1], at(HEIGHT), None, name="top")
    pair = dd.ContactPair(a, b, friction=mu, name="base")
    return dd.Scene(MPI.COMM_SELF, [*lower, upper], interface, contacts=[pair])


def worker(args) -> dict:
    """One run of one algorithm and mu (in its own process, BLAS already pinned)."""
    import resource
    import time

    import dd_contact as dd

    algorithm = args.worker
    problem = dd.StaticProblem(
        scene(ALGORITHMS[algorithm], args.cells, args.mu, args.steps), algorithm=algorithm
    )
    iterations: list[float] = []
    solve_once = problem.iteration._solve_once

    def timed(*a):
        t0 = time.perf_counter()
        out = solve_once(*a)
        iterations.append(time.perf_counter() - t0)
        return out

    problem.iteration._solve_once = timed  # type: ignore[method-assign]
    steps = []
    for step in range(1, args.steps + 1):
        iterations.clear()
        problem.solve(float(step))
        steps.append({"iterations": list(iterations), "changes": problem.iterations - 1})
    factors = [r for r in problem.work.records if r.kind in ("dense_factor", "sparse_factor")]
    out = {
        "algorithm": algorithm,
        "mu": args.mu,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "changes": problem.changes["gamma"],
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
    parser.add_argument("--cells", type=int, default=20)
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
    env = {**os.environ, **PINNED}
    runs: dict[str, list] = {}
    for repeat in range(args.repeats):
        for algorithm in args.algorithms:
            for mu in (0.0, args.mu):  # interleaved: the pair shares the machine's state
                command = [sys.executable, __file__, "--worker", algorithm, "--mu", str(mu)]
                command += ["--cells", str(args.cells), "--steps", str(args.steps)]
                print(f"run {repeat + 1}/{args.repeats}: {algorithm} mu={mu}", flush=True)
                done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
                run = json.loads(done.stdout.strip().splitlines()[-1])
                runs.setdefault(f"{algorithm} mu={mu:g}", []).append(run)
    summary = summarise(args, runs)
    out = Path(args.out)
    out.write_text(
        json.dumps({"arguments": vars(args), "summary": summary, "runs": runs}, indent=1)
    )
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
