"""The pin joint with its subdomains reduced (issue 28): force history and whole-run time.

The joint of ``demos/demo_pin_joint.py`` (``--cells`` c,r,t,grip; default the demo's
8,3,2,12), energy-safe contact, steps of 1.6 us over ``--steps`` steps (2500: two load
periods), each case in its own process with every BLAS pinned to one thread:

* ``FULL``, ``v-w-u``, ``w-v-u``: the unreduced algorithms;
* ``reduced:M``: w-v-u with every subdomain reduced to M fixed-interface modes (a hole
  block with fewer interior dofs than M is kept whole: ``WHOLE_INTERIOR_LIMIT``);
* ``grips:M``: w-v-u with only the two grips reduced (the hole blocks, mostly boundary,
  stay sparse);
* ``cheaper:M``: w-v-u with every subdomain asked ``reduce(modes=M, if_cheaper=True)``: each
  reduced only where its dense block is priced below its sparse factor;
* a reduced case followed by ``@ORDER`` (``cheaper:300@v-w-u``) runs in that order instead.

Reported per case: set-up and step-loop wall and CPU seconds (the whole run is their sum),
the peak resident memory (``ru_maxrss``), each block eigensolve's statistics by
subdomain (``eigensolver``: wall, CPU by part, columns, solves, restarts, residuals),
contact state changes, and the force history's
error against the unreduced w-v-u run: the largest over steps and hole walls of the force
along y, relative to the largest such force (``force_error``), and the same for the sum
over each plate's walls (``plate_force_error``). ``FULL`` against w-v-u is the round-off
yardstick. Cases are interleaved over ``--repeats``; medians are given, the load average
before each run too (the machine is shared).

``--profile``: the steps run under cProfile (CPU clock), and each case's record gets the CPU
seconds per step of the parts in :data:`PARTS` (cumulative: a part includes what it calls,
so parts overlap; profiled runs are slower, their times are shares, not speeds).

Writes benchmarks/results/pin_joint_reduced_<cells>.json.

Run: python benchmarks/pin_joint_reduced.py [--cells 8,3,2,12] [--steps 2500]
     [--cases FULL v-w-u w-v-u reduced:100 grips:100] [--repeats 1]
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from pinned import PINNED

HERE = Path(__file__).parent / "results"
SIDES = ("surface_rhs", "back_substitute")
DT, PERIOD = 1.6e-6, 2e-3
REFERENCE = "w-v-u"  # the force histories' reference (``--reference``)

#: Profiled parts of a step: label -> (module, function's qualified name), each summed.
PARTS = {
    "advance": [("problem", "TransientProblem._advance")],
    "start_forces": [("problem", "TransientProblem._inertia_loads")],
    "contact_iteration": [("analysis", "Analysis.solve")],
    "set_contact": [
        ("solvers.engine", "BlockEliminationSolver.set_contact"),
        ("solvers.full", "MonolithicSolver.set_contact"),
    ],
    "solver_solve": [
        ("solvers.engine", "BlockEliminationSolver._solve"),
        ("solvers.full", "MonolithicSolver._solve"),
    ],
    "solver_finish": [("solvers.engine", "BlockEliminationSolver._finish")],
    "full_substitution": [("solvers.full", "MonolithicSolver._apply")],
    "full_refactorise": [("solvers.full", "MonolithicSolver._refactorise")],
    "sparse_sweeps": [("solvers.subdomains", f"SubdomainCondensation.{f}") for f in SIDES],
    "reduced_substitutions": [("solvers.reduced", f"DenseCondensation.{f}") for f in SIDES],
    "surface_factorise": [("solvers.surface", "Surface.factorise")],
    "reduced_loads": [("solvers.reduced", "ReducedBasis.project_load")],
    "wall_inertia": [("solvers.reduced_model", "wall_inertia")],
    "contact_update": [("contact", "ContactOperator.update")],
    "residual_check": [("solvers.residual", "ResidualCheck.estimate")],
    "publish": [("analysis", "Analysis.publish")],
    "agree": [("analysis", "Analysis.agree")],
}


def _case(case: str) -> tuple[str, str, int]:
    """A case's algorithm, reduction kind ("" when unreduced) and modes."""
    if ":" not in case:
        return case, "", 0
    which, rest = case.split(":")
    modes, _, algorithm = rest.partition("@")
    return algorithm or "w-v-u", which, int(modes)


def _scene(cells: str, case: str):
    import dataclasses

    from mpi4py import MPI

    from dd_contact.paper import models

    names = ("n_circumferential", "n_radial", "n_layers", "n_length")
    counts = dict(zip(names, map(int, cells.split(",")), strict=True))
    layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
    scene = models.pin_joint(layout, period=PERIOD, comm=MPI.COMM_SELF)
    _, which, modes = _case(case)
    for sub in scene.subdomains if which else ():
        if which in ("reduced", "cheaper") or sub.name.endswith("grip"):
            sub.reduce(modes=modes, if_cheaper=which == "cheaper")
    return scene


def worker(args) -> dict:
    import numpy as np

    import dd_contact as dd

    case = args.worker
    algorithm = _case(case)[0]
    eigen = eigen_recorder()
    start, cpu_start = time.perf_counter(), time.process_time()
    scene = _scene(args.cells, case)
    problem = dd.TransientProblem(
        scene, DT, algorithm=algorithm, energy_safe_contact=True, track_energy=False
    )
    problem.start()
    setup, setup_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    profile = cProfile.Profile(time.process_time) if args.profile else None
    start, cpu_start = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # coarse contact/time step: the demo's scene
        if profile is not None:
            profile.enable()
        for _ in range(args.steps):
            problem.advance()
        if profile is not None:
            profile.disable()
    steps, steps_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    walls = sorted(problem.history[0]["force"])
    forces = np.array([[r["force"][w][1] for w in walls] for r in problem.history])
    np.save(Path(args.dump) / f"{case}.npy", forces)
    sizes = {str(b): int(n) for b, n in problem.model.system.sizes.items() if b.kind == "u"}
    out = {
        "setup_seconds": setup,
        "setup_cpu_seconds": setup_cpu,
        "steps_seconds": steps,
        "steps_cpu_seconds": steps_cpu,
        "whole_seconds": setup + steps,
        "whole_cpu_seconds": setup_cpu + steps_cpu,
        "changes": int(problem.iteration.gamma),
        "peak_memory_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "block_sizes": sizes,
        "dofs": sum(s.num_dofs for s in scene.subdomains),
        "walls": walls,
        # where the time went: seconds and count of each kind of operation (set-up in)
        "work_by_kind": {
            kind: {"count": int(w["count"]), "seconds": round(w["seconds"], 3)}
            for kind, w in problem.work.summary().items()
        },
    }
    if eigen:
        out["eigensolver"] = eigen
    if profile is not None:
        out["profile_cpu_per_step"] = _parts(profile, args.steps)
    problem.close()
    return out


def eigen_recorder() -> dict:
    """Each block eigensolve's statistics, by subdomain (the set-up's modes phase)."""
    from dd_contact.solvers import eigen, reduced

    record: dict = {}

    def recorded(*args, **kwargs):
        stats = eigen.EigenStatistics()
        start = time.perf_counter()
        out = eigen.lowest_modes(*args, **kwargs, stats=stats)
        name = args[5] if len(args) > 5 else kwargs["name"]
        record[name] = {"seconds": time.perf_counter() - start, "cpu": stats.cpu}
        record[name] |= {k: getattr(stats, k) for k in ("columns", "solves", "restarts")}
        record[name]["residuals"] = [f"{r:.2e}" for r in getattr(stats, "residuals", ())]
        return out

    reduced.lowest_modes = recorded  # type: ignore[assignment]
    return record


def _parts(profile: cProfile.Profile, steps: int) -> dict[str, float]:
    """CPU seconds per step of each of :data:`PARTS` (cumulative, so parts overlap)."""
    import importlib
    import pstats

    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    out = {}
    for label, functions in PARTS.items():
        total = 0.0
        for module, name in functions:
            function = importlib.import_module(f"dd_contact.{module}")
            for attribute in name.split("."):
                function = getattr(function, attribute)
            code = function.__code__
            key = (code.co_filename, code.co_firstlineno, code.co_name)
            total += stats[key][3] if key in stats else 0.0
        out[label] = round(total / steps, 6)
    return out


def _errors(forces, reference) -> dict:
    """The force history's largest error against the reference, relative to its peak."""
    import numpy as np

    n = min(len(forces), len(reference))
    f, g = forces[:n], reference[:n]
    half = f.shape[1] // 2  # walls sorted: hole_lower*, then hole_upper*
    plates = [np.s_[:, :half], np.s_[:, half:]]
    plate = max(
        np.abs(f[p].sum(axis=1) - g[p].sum(axis=1)).max() / np.abs(g[p].sum(axis=1)).max()
        for p in plates
    )
    period = round(PERIOD / DT)  # the first load period's steps
    return {
        "force_error": float(np.abs(f - g).max() / np.abs(g).max()),
        "force_error_first_period": float(np.abs(f - g)[:period].max() / np.abs(g).max()),
        "plate_force_error": float(plate),
        "peak_force": float(np.abs(g).max()),
    }


def _medians(runs: list[dict]) -> dict:
    out = dict(runs[0])
    for key in ("setup", "steps", "whole"):
        for clock in ("seconds", "cpu_seconds"):
            values = [r[f"{key}_{clock}"] for r in runs]
            out[f"{key}_{clock}"] = statistics.median(values)
            out[f"{key}_{clock}_runs"] = [round(v, 3) for v in values]
    out["peak_memory_mib"] = max(r["peak_memory_mib"] for r in runs)
    return out


def main() -> None:
    import numpy as np

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cells", default="8,3,2,12")
    parser.add_argument("--steps", type=int, default=2500)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--cases", nargs="+", default=["FULL", "v-w-u", "w-v-u", "reduced:100"])
    parser.add_argument("--reference", default=REFERENCE, help="the unreduced case compared to")
    parser.add_argument("--out", help="the JSON (default by the cells)")
    parser.add_argument("--keep", help="keep the force histories here (to --combine later)")
    parser.add_argument("--combine", nargs="+", help="JSONs of runs kept in --keep: one JSON")
    parser.add_argument("--profile", action="store_true", help="the steps under cProfile")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--dump", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    if args.combine:  # cases run by several invocations at once (a loaded machine)
        parts = [json.loads(Path(f).read_text()) for f in args.combine]
        runs = {c: r.get("runs", [r]) for p in parts for c, r in p["results"].items()}
        loads = [x for p in parts for x in p["load_average"]]
        forces = {c: np.load(Path(args.keep) / f"{c}.npy") for c in runs}
        _write(args, runs, forces, loads)
        return
    runs: dict[str, list[dict]] = {case: [] for case in args.cases}
    loads = []
    with tempfile.TemporaryDirectory() as temporary:
        dump = args.keep or temporary
        forces = {}
        for repeat in range(args.repeats):
            for case in args.cases:
                command = [sys.executable, __file__, "--worker", case, "--cells", args.cells]
                command += ["--steps", str(args.steps), "--dump", dump]
                command += ["--profile"] * args.profile
                loads.append(os.getloadavg()[0])
                done = subprocess.run(
                    command, env={**os.environ, **PINNED}, capture_output=True, text=True
                )
                if done.returncode:
                    raise RuntimeError(f"{case}: {done.stderr[-3000:]}")
                runs[case].append(json.loads(done.stdout.splitlines()[-1]))
                forces.setdefault(case, np.load(Path(dump) / f"{case}.npy"))
                r = runs[case][-1]
                print(case, repeat, {k: round(r[k], 2) for k in ("setup_seconds", "whole_seconds")})
                _write(args, runs, forces, loads)  # after every run: a long study's part


def _write(args, runs: dict[str, list[dict]], forces: dict, loads: list[float]) -> None:
    """The JSON of the runs so far: medians, errors against the reference, speed-ups."""
    results = {case: _medians(r) | {"runs": r} for case, r in runs.items() if r}
    if args.reference in forces:
        for case in results:
            results[case] |= _errors(forces[case], forces[args.reference])
    unreduced = [c for c in results if ":" not in c]
    for clock in ("whole_seconds", "whole_cpu_seconds"):
        best = min(unreduced, key=lambda c: results[c][clock]) if unreduced else None
        for case, r in results.items():
            if best is not None:
                r[f"{clock}_speedup_vs_best_unreduced"] = results[best][clock] / r[clock]
                r[f"best_unreduced_by_{clock}"] = best
    settings = {"cells": args.cells, "steps": args.steps, "dt": DT, "period": PERIOD}
    settings |= {"repeats": args.repeats, "load_average": [round(x, 2) for x in loads]}
    settings |= {"reference": args.reference, "cpus": os.cpu_count(), "threads": "pinned to 1"}
    out = Path(args.out or HERE / f"pin_joint_reduced_{args.cells.replace(',', '-')}.json")
    out.write_text(json.dumps({**settings, "results": results}, indent=1))


if __name__ == "__main__":
    main()
