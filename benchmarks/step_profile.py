"""Where a time step without a contact change goes: FULL, w-u and w-v-u on the pressed bar.

Each algorithm runs in its own process with every BLAS pinned to one thread. After the
set-up and ``--warm`` steps, ``--steps`` steps are timed: wall-clock timers wrap each part of
a step (the package's own functions, wrapped here only), and a second series of steps runs
under cProfile for the functions that the timers do not name. Only steps without a contact
state change count (their iterations: one solve, its check and the finish): the bar moves
100x slower than in ``decomposition_speed.py``.

Parts (seconds per quiet step, medians of wall-clock and of the process's CPU time):
``loads`` (r(t_n+1), and r(t_n) when not kept), ``rhs`` (prescribed values' right-hand side
plus loads), ``start_forces`` (K x_n, the step's start forces), ``reduction`` (the
subdomains' forward sweeps, or FULL's whole solve), ``gather_bcast`` (the surface pieces to
the root and the solution back), ``surface`` (the dense surface solve), ``expansion`` (the
subdomains' backward sweeps), ``contact_check`` (the active set from the solution),
``contact_rhs`` (the contact terms and the step's correction added to the right-hand side),
``residual_check``, ``publish`` (solution into the dolfinx Functions), ``agree`` (forces,
reactions, areas agreed over ranks), ``energy`` (with ``--track-energy``: the energy at the
step's end, whose product K x the next step's start forces read), ``other`` (the rest of
``advance``: the Newmark history M h, the velocity update, copies).

Writes benchmarks/results/step_profile_<nx>x<ny>x<nz>[_<tag>].json.

``--body-force`` adds a body force ``t -> 3-vector`` to every subdomain (the paper's bar
is shaken so), whose load is assembled over the whole volume. ``--track-energy`` runs with
``track_energy=True`` (the package's default) instead of False.

Run: python benchmarks/step_profile.py [--elements 120 30 10] [--steps 4] [--body-force]
     [--tag before]
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import os
import pstats
import statistics
import subprocess
import sys
import time
from pathlib import Path

from pinned import PINNED

HERE = Path(__file__).parent / "results"
ALGORITHMS = ["FULL", "w-u", "w-v-u"]


def _parts():
    """(part, owner, attribute) of every timed function."""
    from dd_contact import analysis, impact, iteration, problem
    from dd_contact.contact import ContactOperator
    from dd_contact.solvers import engine, full, subdomains, surface

    return [
        ("loads", analysis.Analysis, "_loads"),
        ("rhs", analysis.Analysis, "rhs"),
        ("start_forces", impact.StartForces, "__init__"),
        ("reduction", subdomains.SubdomainCondensation, "surface_rhs"),
        ("reduction", full.MonolithicSolver, "solve"),
        ("gather_bcast", engine, "gather_to_root"),
        ("gather_bcast", engine, "bcast_array"),
        ("surface", surface.Surface, "solve"),
        ("surface", surface.Surface, "back_substitute"),
        ("expansion", subdomains.SubdomainCondensation, "back_substitute"),
        ("contact_check", ContactOperator, "active_set"),
        ("contact_rhs", iteration.ContactIteration, "_solve_once"),
        ("residual_check", iteration.ContactIteration, "_checked"),
        ("publish", analysis.Analysis, "publish"),
        ("agree", analysis.Analysis, "agree"),
        ("energy", problem.TransientProblem, "energy"),
        ("other", problem.TransientProblem, "advance"),
    ]


def worker(args) -> dict:
    """One algorithm's profile (in its own process, BLAS already pinned)."""
    from mpi4py import MPI

    import numpy as np

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped

    scene = parallelepiped(args.worker, tuple(args.elements), speed=args.speed, comm=MPI.COMM_SELF)
    if args.body_force:  # a periodic body force, as the paper's bar (dd_contact.paper.models)
        for sub in scene.subdomains:
            sub.set_body_force(lambda t: [-1e5 * np.sin(2e4 * np.pi * t), 0.0, 0.0])
    problem = dd.TransientProblem(
        scene, args.dt, algorithm=args.worker, track_energy=args.track_energy
    )
    problem.start()
    for _ in range(args.warm):
        problem.advance()
    seconds: dict[str, float] = {}
    cpu: dict[str, float] = {}  # CPU time of the process: less moved by other processes
    calls: dict[str, int] = {}
    # a part's time excludes the parts timed inside it (e.g. the solve inside _solve_once)
    stack: list[list[float]] = []

    def timer(part, function):
        def timed(*a, **k):
            stack.append([0.0, 0.0])
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return function(*a, **k)
            finally:
                elapsed, used = time.perf_counter() - t0, time.process_time() - c0
                inner = stack.pop()
                seconds[part] = seconds.get(part, 0.0) + elapsed - inner[0]
                cpu[part] = cpu.get(part, 0.0) + used - inner[1]
                calls[part] = calls.get(part, 0) + 1
                if stack:
                    stack[-1][0] += elapsed
                    stack[-1][1] += used

        return timed

    for part, owner, name in _parts():
        setattr(owner, name, timer(part, getattr(owner, name)))

    quiet = []
    for _ in range(args.steps):
        seconds.clear(), cpu.clear(), calls.clear()
        record = problem.advance()
        if record["changes"] == 0:
            quiet.append({"parts": dict(seconds), "cpu": dict(cpu), "calls": dict(calls)})
    profile = cProfile.Profile()
    profiled = 0
    for _ in range(args.steps):
        profile.enable()
        record = problem.advance()
        profile.disable()
        profiled += record["changes"] == 0
    text = io.StringIO()
    pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(25)
    names = sorted({p for q in quiet for p in q["parts"]})
    median = {p: statistics.median(q["parts"].get(p, 0.0) for q in quiet) for p in names}
    median["step"] = statistics.median(sum(q["parts"].values()) for q in quiet) if quiet else 0.0
    median_cpu = {p: statistics.median(q["cpu"].get(p, 0.0) for q in quiet) for p in names}
    median_cpu["step"] = statistics.median(sum(q["cpu"].values()) for q in quiet) if quiet else 0.0
    return {
        "algorithm": args.worker,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "quiet_steps": len(quiet),
        "median_seconds": median,
        "median_cpu_seconds": median_cpu,
        "calls": quiet[0]["calls"] if quiet else {},
        "steps": quiet,
        "cprofile_steps": args.steps,
        "cprofile_quiet_steps": int(profiled),
        "cprofile_top": text.getvalue().splitlines()[:60],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[120, 30, 10])
    parser.add_argument("--dt", type=float, default=1e-6)
    # 100x slower than the speed benchmark's bar: its contact area grows by 0.02 element
    # rows a step, so most steps change nothing
    parser.add_argument("--speed", type=float, default=0.01)
    parser.add_argument("--warm", type=int, default=1, help="steps before the timed ones")
    parser.add_argument("--steps", type=int, default=4)
    parser.add_argument("--algorithms", nargs="+", default=ALGORITHMS)
    parser.add_argument("--body-force", action="store_true", help="a body force t -> 3-vector")
    parser.add_argument("--track-energy", action="store_true", help="track_energy=True")
    parser.add_argument("--tag", default="")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    nx, ny, nz = args.elements
    out = HERE / f"step_profile_{nx}x{ny}x{nz}{'_' + args.tag if args.tag else ''}.json"
    results = {}
    for algorithm in args.algorithms:
        command = [sys.executable, __file__, "--worker", algorithm, "--elements"]
        command += [str(n) for n in args.elements]
        command += ["--steps", str(args.steps), "--warm", str(args.warm), "--dt", str(args.dt)]
        command += ["--speed", str(args.speed)] + (["--body-force"] if args.body_force else [])
        command += ["--track-energy"] if args.track_energy else []
        done = subprocess.run(
            command, env={**os.environ, **PINNED}, capture_output=True, text=True, check=True
        )
        results[algorithm] = json.loads(done.stdout.splitlines()[-1])
        for kind in ("median_seconds", "median_cpu_seconds"):
            median = results[algorithm][kind]
            print(algorithm, kind, json.dumps({k: round(v, 4) for k, v in median.items()}))
    settings = {"elements": args.elements, "track_energy": args.track_energy}
    out.write_text(json.dumps({**settings, "results": results}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
