"""Where a time step of w-v-u goes, per rank (issue 14 item 5: two ranks per step).

Runs the bar of ``benchmarks/two_ranks.py`` (``examples.parallelepiped``, w-v-u, dt = 1 us)
under ``mpiexec -n 1`` or ``-n 2`` with every BLAS on one thread, takes the first step
(set-up) unprofiled, then profiles the next steps with cProfile on every rank. Per rank it
reports the wall clock of a step and the cumulative seconds of each part of it (the parts
below, by function), the time spent inside MPI calls (waiting included) and the bytes this
rank sent through :mod:`dd_contact.parallel`'s counter, per step.

Writes (or adds to) benchmarks/results/rank_profile.json under the key ``"<ranks> ranks"``
(``"<ranks> ranks cpu"`` with ``--cpu``: CPU seconds per rank instead of the wall clock).

Run: OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 mpiexec -n 2 python benchmarks/rank_profile.py
     [--elements 120,30,10] [--steps 6] [--out benchmarks/results/rank_profile.json]
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import time
from pathlib import Path

from mpi4py import MPI

import dd_contact as dc
from dd_contact import analysis, impact, iteration, parallel
from dd_contact import problem as problem_module
from dd_contact.paper import examples
from dd_contact.solvers import engine, subdomains, surface

HERE = Path(__file__).parent / "results"

#: The parts of a step: label -> the function whose cumulative time counts.
PARTS = {
    "step (advance)": problem_module.TransientProblem.advance,
    "loads": analysis.Analysis._loads,
    "start forces": impact.StartForces.__init__,
    "right-hand side": analysis.Analysis.rhs,
    "contact iteration": iteration.ContactIteration.solve,
    "  one solve": iteration.ContactIteration._solve_once,
    "    engine solve": engine.BlockEliminationSolver.solve,
    "      subdomain reduction": subdomains.SubdomainCondensation.surface_rhs,
    "      subdomain factorise": subdomains.SubdomainCondensation.factorise,
    "      surface factorise": surface.Surface.factorise,
    "      surface solve": surface.Surface.solve,
    "  finish": engine.BlockEliminationSolver.finish,
    "    subdomain expansion": subdomains.SubdomainCondensation.back_substitute,
    "  residual check": iteration.ContactIteration._checked,
    "publish": analysis.Analysis.publish,
    "agree results": analysis.Analysis.agree,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", default="120,30,10", help="nx,ny,nz")
    parser.add_argument("--steps", type=int, default=6)
    parser.add_argument("--out", default=str(HERE / "rank_profile.json"))
    parser.add_argument("--tag", default="", help="suffix of the result's key, e.g. ' before'")
    parser.add_argument(
        "--cpu",
        action="store_true",
        help="CPU seconds of each rank (time.process_time) instead of the wall clock: what a "
        "rank computes, unaffected by other processes on a busy machine (MPICH's waiting "
        "spins, so time inside MPI still counts)",
    )
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    elements = tuple(int(n) for n in args.elements.split(","))
    scene = examples.parallelepiped("w-v-u", elements, comm=comm)
    problem = dc.TransientProblem(scene, 1e-6, algorithm="w-v-u", track_energy=False)
    problem.advance()  # set-up: the factorisations
    clock = time.process_time if args.cpu else time.perf_counter
    profile, walls, iterations = cProfile.Profile(clock), [], []
    counter = getattr(parallel, "traffic", None)  # absent before the counter existed
    if counter is not None:
        counter.reset()
    for _ in range(args.steps):
        comm.Barrier()
        t0 = clock()
        profile.enable()
        record = problem.advance()
        profile.disable()
        walls.append(clock() - t0)
        iterations.append(record["iterations"])
    traffic = counter.snapshot() if counter is not None else {}
    inside_mpi = dict(counter.seconds) if counter is not None else {}  # wall clock always
    stats = pstats.Stats(profile).stats
    parts = {}
    for label, function in PARTS.items():
        code = function.__code__
        key = (code.co_filename, code.co_firstlineno, code.co_name)
        parts[label] = stats[key][3] if key in stats else 0.0
    mine = {
        "clock": "cpu" if args.cpu else "wall",
        "per_step_s": sorted(walls)[len(walls) // 2],
        "parts_per_step_s": {k: v / args.steps for k, v in parts.items()},
        "helpers_wall_per_step_s": {k: v / args.steps for k, v in inside_mpi.items()},
        "traffic_per_step": {k: v / args.steps for k, v in traffic.items()},
        "iterations_per_step": iterations,
    }
    ranks = comm.gather(mine, root=0)
    problem.close()
    if comm.rank == 0:
        out = Path(args.out)
        data = json.loads(out.read_text()) if out.exists() else {}
        data["elements"] = args.elements
        data[f"{comm.size} ranks{' cpu' if args.cpu else ''}{args.tag}"] = {
            "load_average": os.getloadavg(),
            "dofs": int(sum(problem.solver.system.sizes.values())),
            "steps_profiled": args.steps,
            "per_rank": ranks,
        }
        out.write_text(json.dumps(data, indent=1))
        for r, part in enumerate(ranks):
            print(f"rank {r}: {part['per_step_s']:.3f} s per step ({part['clock']})")
            for label, seconds in part["parts_per_step_s"].items():
                print(f"  {label:30s} {seconds:.4f}")
            for helper, seconds in part["helpers_wall_per_step_s"].items():
                print(f"  in {helper:27s} {seconds:.4f} (wall)")
            print(f"  traffic {part['traffic_per_step']}")


if __name__ == "__main__":
    main()
