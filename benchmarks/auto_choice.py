"""Is ``algorithm="auto"`` within 1.15x of the best algorithm, whole run included? (issue 30)

Every algorithm that fits a scene, and ``auto``, runs the same run of the scene in its own
process, every BLAS pinned to one thread; the runs are interleaved (every scene and
algorithm once, then again), and each scene's medians over the repeats are compared. The
scenes are the targets of issue 30:

* ``pin_small``: ``demos/demo_pin_joint.py`` at its default scale (100 steps of 40 us);
* ``pin_tests``: the same joint at the tests' scale (cells ``3,2,1,4``, 30 steps);
* ``pin_demo``: the joint as ``demos/demo_pin_joint.py`` runs it now (cells ``8,3,2,12``,
  steps of 1.6 us), 400 steps (0.64 ms: the first hit on the pins, 0.35-0.53 ms, with its
  contact changes) instead of the demo's 1,250;
* ``bar_small`` and ``bar_tiny``: ``demos/demo_parallelepiped.py`` at ``small`` (its
  default) and ``tiny`` (the tests'), 80 steps of 0.1 ms, on the split model every algorithm
  that fits runs (FULL, v-w-u, w-v-u; auto chooses among them);
* ``bar_49k`` and ``bar_124k``: the bar of ``benchmarks/decomposition_speed.py`` (120 x 18
  x 6 and 120 x 30 x 10 hexahedra, 8 steps of 1 us) on its w-v-u scene; auto is told the
  run's length and 1.25 changes a step, as there.

auto is told the run's length (``expected_steps``) as the demos tell it. Per run: the wall
time of building the scene, of building the problem (assembly, auto's analysis and choice),
of the steps (the first one factorises), their sum (``whole``), the peak resident memory
(``ru_maxrss``), auto's choice, its predicted table and whether it re-planned, the contact
changes and release solves, the work log's seconds and counts per kind, and the machine's
load average (``os.getloadavg``, as ``uptime`` shows it) before and after the run. The machine's
rates are measured before the first run (``dd-contact calibrate``, pinned like the runs).

Per scene: the median whole time of each algorithm with its spread (min, max), the best
named algorithm, and ``auto_over_best``: auto's median over the best's (target <= 1.15);
on a machine shared with other jobs also ``auto_over_best_fastest`` (the fastest run of
each: the least disturbed) and ``auto_over_best_cpu`` (medians of the process's CPU time,
which another job's load stretches far less than the wall clock).

``--clock cpu`` times the package's work records with the process's CPU time instead of
the wall clock (its timers patched in each worker): the predicted-against-measured check
of each step and change on a machine other jobs load (the rates are a core's own).

``--threads default`` runs every process with the BLAS threads a user gets (no thread
variable set: numpy's and scipy's OpenBLAS start one thread per core), as the demos run.

Writes benchmarks/results/auto_choice.json (resumes from it if interrupted; a scene's
runs are kept while its settings are the same).

Run: python benchmarks/auto_choice.py [--scenes pin_small bar_49k ...] [--repeats 3]
     [--algorithms FULL auto ...] [--threads pinned|default] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from pinned import PINNED

HERE = Path(__file__).parent / "results"
#: Scene -> (builder, dt, steps, the algorithms that fit it, auto's expected changes per step)
SCENES: dict[str, dict] = {
    "pin_small": {"build": ("pin", "small"), "dt": 4e-5, "steps": 100},
    "pin_tests": {"build": ("pin", "3,2,1,4"), "dt": 4e-5, "steps": 30},
    "pin_demo": {"build": ("pin", "8,3,2,12"), "dt": 1.6e-6, "steps": 400},
    "bar_small": {"build": ("bar", "small"), "dt": 1e-4, "steps": 80},
    "bar_tiny": {"build": ("bar", "tiny"), "dt": 1e-4, "steps": 80},
    "bar_49k": {"build": ("speed", "120,18,6"), "dt": 1e-6, "steps": 8, "changes": 1.25},
    "bar_124k": {"build": ("speed", "120,30,10"), "dt": 1e-6, "steps": 8, "changes": 1.25},
}
ALGORITHMS = ("FULL", "v-w-u", "w-v-u", "auto")


def build(kind: str, size: str):
    """The scene of a target (see the module's docstring)."""
    from mpi4py import MPI

    if kind == "pin":
        import dataclasses

        from dd_contact.paper import models

        if size in models.PIN_JOINT_SCALES:
            layout = models.pin_joint_layout(size)
        else:
            names = list(models.PIN_JOINT_SCALES["small"])
            counts = dict(zip(names, map(int, size.split(",")), strict=True))
            layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
        return models.pin_joint(layout, clearance=0.05e-3, load=20e3, period=2e-3)
    if kind == "bar":
        from dd_contact.paper import models

        return models.parallelepiped(size, algorithm=None, body_force=21e6, period=4e-3)
    from dd_contact.paper.examples import parallelepiped

    elements = tuple(int(n) for n in size.split(","))
    return parallelepiped("w-v-u", elements, comm=MPI.COMM_SELF)


def worker(name: str, algorithm: str) -> dict:
    """One run of one algorithm on one scene (in its own process, BLAS already pinned)."""
    import resource

    import dd_contact as dd

    spec = SCENES[name]
    cpu = [time.process_time()]
    start = time.perf_counter()
    scene = build(*spec["build"])
    built = time.perf_counter()
    cpu.append(time.process_time())
    expected = {}
    if algorithm == "auto":
        expected["expected_steps"] = spec["steps"]
        if "changes" in spec:
            expected["expected_changes"] = spec["changes"] * spec["steps"]
    problem = dd.TransientProblem(
        scene, spec["dt"], algorithm=algorithm, track_energy=False, **expected
    )
    ready = time.perf_counter()
    cpu.append(time.process_time())
    steps, solver = [], []
    it = problem.iteration
    for _ in range(spec["steps"]):
        calls = len(getattr(problem.work, "calls", ()))  # not in the code before issue 30
        marks = (len(problem.work.records), calls, it.gamma, it.release_solves)
        t0 = time.perf_counter()
        problem.advance()
        steps.append(time.perf_counter() - t0)
        solver.append(_solver_step(problem, marks))
    end = time.perf_counter()
    cpu.append(time.process_time())
    kinds: dict[str, list[float]] = {}
    for r in problem.work.records:
        k = kinds.setdefault(r.kind, [0, 0.0])
        k[0] += 1
        k[1] += r.seconds
    choice = problem.choice
    out = {
        "algorithm": algorithm,
        "chosen": problem.algorithm,
        "scene_seconds": built - start,
        "problem_seconds": ready - built,
        "first_step_seconds": steps[0],
        "steps_seconds": end - ready,
        "whole": end - start,
        "cpu": {
            "scene": cpu[1] - cpu[0],
            "problem": cpu[2] - cpu[1],
            "steps": cpu[3] - cpu[2],
            "whole": cpu[3] - cpu[0],
        },
        "median_step_seconds": statistics.median(steps[1:]) if len(steps) > 1 else None,
        "peak_memory_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "dofs": int(sum(problem.solver.system.sizes.values())),
        "changes": problem.changes["gamma"],
        "release_solves": problem.iteration.release_solves,
        "work": {k: {"count": c, "seconds": s} for k, (c, s) in kinds.items()},
    }
    from dd_contact import timing

    if algorithm != "auto" and hasattr(timing, "Expected"):  # the model of issue 30
        out["predicted"] = _predicted(problem, spec["steps"], solver)
    if choice is not None:
        out["choice"] = {
            "table": choice.table(),
            "replanned": choice.replanned,
            "misses": choice.misses,
            "predicted_total": {a: p.total for a, p in choice.predictions.items()},
        }
    problem.close()
    return out


def _solver_step(problem, marks) -> dict:
    """The solver's seconds in one step (its records and its time around them), its counts."""
    records, calls, gamma, releases = marks
    it = problem.iteration
    done = [r for r in problem.work.records[records:] if not r.block.startswith("mass:")]
    around = sum(seconds for _, seconds in getattr(problem.work, "calls", [])[calls:])
    return {
        "seconds": sum(r.seconds for r in done) + around,
        "changes": it.gamma - gamma,
        "releases": it.release_solves - releases,
    }


def _predicted(problem, n_steps: int, solver: list[dict]) -> dict:
    """The timing model's prediction of this run (its own counts) against the solver's time.

    Per step without change or release, and per change (a step with one change and no
    release, less a step without): medians of the solver's measured seconds.
    """
    import statistics as st

    from dd_contact import timing
    from dd_contact.solvers import analysed

    full = problem.algorithm == "FULL"
    structure = analysed.scene_structure(
        problem.comm,
        problem.solver.system,
        [z.region for z in problem.zones],
        full=full,
        orders=not full,
    )
    it = problem.iteration
    rates = timing.machine_rates()
    plan = timing.plan(structure, problem.algorithm)
    p = timing.predict(plan, rates, n_steps, it.gamma, it.release_solves)
    plain = [s["seconds"] for s in solver[1:] if not s["changes"] and not s["releases"]]
    one = [s["seconds"] for s in solver[1:] if s["changes"] == 1 and not s["releases"]]
    step = st.median(plain) if plain else None
    return {
        "total": p.total,
        "measured_total": sum(s["seconds"] for s in solver),
        "step": p.step,
        "measured_step": step,
        "change": p.change,
        "measured_change": st.median(one) - step if one and step is not None else None,
        "release": p.release,
    }


def _cpu_clocks() -> None:
    """The package's work records timed by the process's CPU time (``--clock cpu``)."""
    import types

    from dd_contact.solvers import linalg, mumps_schur, worklog

    clock = types.SimpleNamespace(perf_counter=time.process_time)
    for module in (linalg, mumps_schur, worklog):
        module.time = clock  # type: ignore[attr-defined]


def summarise(runs: dict) -> dict:
    """Per scene: medians and spreads of each algorithm, and auto over the best named."""
    summary = {}
    for name, by_algorithm in runs.items():
        med = {}
        for algorithm, rs in by_algorithm.items():
            whole = [r["whole"] for r in rs]
            cpu = [r["cpu"]["whole"] for r in rs]
            med[algorithm] = {
                "cpu_median": statistics.median(cpu),
                "cpu_min": min(cpu),
                "cpu_max": max(cpu),
                "runs": len(rs),
                "whole_median": statistics.median(whole),
                "whole_min": min(whole),
                "whole_max": max(whole),
                "steps_median": statistics.median(r["steps_seconds"] for r in rs),
                "problem_median": statistics.median(r["problem_seconds"] for r in rs),
                "peak_memory_mib": statistics.median(r["peak_memory_mib"] for r in rs),
                "dofs": rs[0]["dofs"],
                "changes": sorted({r["changes"] for r in rs}),
            }
            if algorithm == "auto":
                med[algorithm]["chosen"] = [r["chosen"] for r in rs]
                med[algorithm]["replanned"] = [r["choice"]["replanned"] for r in rs]
        named = {a: m["whole_median"] for a, m in med.items() if a != "auto"}
        if "auto" in med and named:
            best = min(named, key=named.get)
            auto = med["auto"]
            auto["best"] = best
            auto["auto_over_best"] = auto["whole_median"] / named[best]
            auto["auto_over_best_spread"] = [
                auto["whole_min"] / med[best]["whole_max"],
                auto["whole_max"] / med[best]["whole_min"],
            ]
            # the least disturbed runs (the fastest of each) of a machine shared with others
            fastest = {a: m["whole_min"] for a, m in med.items() if a != "auto"}
            auto["best_fastest"] = min(fastest, key=fastest.get)
            auto["auto_over_best_fastest"] = auto["whole_min"] / fastest[auto["best_fastest"]]
            cpus = {a: m["cpu_median"] for a, m in med.items() if a != "auto"}
            auto["best_cpu"] = min(cpus, key=cpus.get)
            auto["auto_over_best_cpu"] = auto["cpu_median"] / cpus[auto["best_cpu"]]
        summary[name] = med
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--algorithms", nargs="+", default=list(ALGORITHMS), choices=ALGORITHMS)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(HERE / "auto_choice.json"))
    parser.add_argument("--label", default="", help="what the code is (e.g. before, after)")
    parser.add_argument("--threads", default="pinned", choices=["pinned", "default"])
    parser.add_argument("--clock", default="wall", choices=["wall", "cpu"])
    parser.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        if args.clock == "cpu":
            _cpu_clocks()
        print(json.dumps(worker(*args.worker)))
        return
    out = Path(args.out)
    data = json.loads(out.read_text()) if out.exists() else {}
    runs = data.get("runs", {})
    for name in args.scenes:  # a scene's runs are kept while its settings are the same
        if data.get("scenes", {}).get(name) != json.loads(json.dumps(SCENES[name])):
            runs.pop(name, None)
    env = {k: v for k, v in os.environ.items() if k not in PINNED}
    if args.threads == "pinned":
        env.update(PINNED)
    show = "from dd_contact.cli import main; main(['calibrate', '--show'])"
    # cached before timing; run beside this script, so that PYTHONPATH says which package
    subprocess.run([sys.executable, "-c", show], env=env, check=True, cwd=Path(__file__).parent)
    for repeat in range(args.repeats):
        for name in args.scenes:
            for algorithm in args.algorithms:
                done = runs.setdefault(name, {}).setdefault(algorithm, [])
                if len(done) > repeat:
                    continue  # resumed
                print(f"run {repeat + 1}/{args.repeats}: {name} {algorithm}", flush=True)
                command = [sys.executable, __file__, "--worker", name, algorithm]
                command += ["--clock", args.clock]
                load = os.getloadavg()
                result = subprocess.run(command, env=env, capture_output=True, text=True)
                if result.returncode:
                    raise SystemExit(result.stderr[-3000:])
                done.append(json.loads(result.stdout.strip().splitlines()[-1]))
                done[-1]["load"] = {"before": load, "after": os.getloadavg()}
                write(out, args, runs)
    summary = write(out, args, runs)
    for name, med in summary.items():
        auto = med.get("auto", {})
        line = ", ".join(
            f"{a} {m['whole_median']:.2f} s [{m['whole_min']:.2f}-{m['whole_max']:.2f}] "
            f"(cpu {m['cpu_median']:.2f})"
            for a, m in med.items()
        )
        ratios = [auto.get(k) for k in ("auto_over_best", "auto_over_best_cpu")]
        shown = "/".join(f"{r:.2f}" for r in ratios if r is not None)
        print(f"{name}: {line}; auto chose {auto.get('chosen')}, auto/best (wall/cpu) {shown}")


def write(out: Path, args, runs: dict) -> dict:
    """Write the runs and their summary; returns the summary."""
    summary = summarise({n: r for n, r in runs.items() if r})
    data = {
        "label": args.label,
        "note": "each run in its own process; medians over repeats",
        "threads": args.threads,
        "clock": args.clock,
        "scenes": {n: SCENES[n] for n in runs},
        "summary": summary,
        "runs": runs,
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(data, indent=1))
    return summary


if __name__ == "__main__":
    main()
