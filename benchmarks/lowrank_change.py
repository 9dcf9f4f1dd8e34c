"""A contact change of a few points: the low-rank correction against re-factorising.

Issue 28's target: a change in which at most 5 % of a contact group's points change state
costs at least 10 times less than re-factorising that group, with the same answers to
1e-10. On the joint with elastic pins (``models.pin_joint(pins="elastic")``, every pin in
contact, no clearance), solved statically at the load's peak; then, on that settled state,
a fraction of the contact points chosen at random (the same in every process) flip their
state and the contact iteration's linear solve is repeated (``ContactIteration``'s solve
with the flipped active sets), then flipped back, then the same points flipped again
("again": a correction finds them eliminated) and back: four changes per trial. Before the
trials, a point no trial flips is flipped and back (``warm_up``, recorded apart): a run's
first corrected solve pays once what no later one does (the surface's norm, the first pages
of the kept columns' arrays; 15 ms on the 306k bar), which the first trial's flip took for
its own until stop 44 (the 1 % flips looked dearer than the 5 % ones). In w-v-u every
pair is in one dense group (the all-walls group); in v-w-u each pin's two pairs are one
group, eliminated into the interface's.

Per change: the seconds of its change work in the work log (``problem.work``:
factorisations, or the update's forward elimination and ``dense_update``) and the solve's
wall time; in CPU seconds the surface's change work (its ``factorise``) and its solve. A
first flip's points may be eliminated by that solve, beside its own substitution: its
whole cost is the change's work plus its surface solve less a plain one (the corrected
run's solves back at the factorised state), ``flip_and_solve_cpu_seconds``. The same in a
process with the correction off (``LowRankSurface.enabled = False``: the group
re-factorised), and with ``--before DIR`` in one running another checkout's
``dd_contact`` (DIR holds it), all interleaved, each with BLAS on one thread; medians over
the trials and processes, peak memory of each process. The solutions
of the first trial are compared (w, relative to the largest entry), and each one's normwise
backward error on the whole system (14) with the flipped contact terms is measured. Their
difference alone says little: at penalty 1e6 this joint's scaled condition number is
1e12-1e13, and any two exact solvers (w-v-u and v-w-u re-factorising: ``orders_spread``
when both orders run; FULL) differ by 1e-6 to 1e-5 (``benchmarks/lowrank_accuracy.py``
measures every one against an extended-precision reference: 1e-4 at 87k). A correction
that kept its digits has a backward error as small as a re-factorisation's (about 1e-16)
and differs from it by no more than exact solvers differ (the two orders share the
subdomains' condensations: FULL's difference is the larger, 6.8e-5 at 87k).

With ``--model bar``, the 306k bar of ``benchmarks/paper_scale.py`` (the parallelepiped
at a quarter of the paper's cells, its demo's time step) after :data:`BAR_STEPS` steps, its
end on the wall: the same flips of its end's contact points (w-v-u: the end's group).

    python benchmarks/lowrank_change.py                   # 6,7,4,34: 87,405 dofs
    python benchmarks/lowrank_change.py --scale 3,2,1,4   # 5,460 dofs, seconds
    python benchmarks/lowrank_change.py --model bar --orders w-v-u   # 1/4: 306k dofs

Writes benchmarks/results/lowrank_change.json (another scale's file is named after it, the
bar's lowrank_change_bar_<scale>.json).
"""

import argparse
import dataclasses
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from lowrank_accuracy import Whole
from pinned import PINNED

DEFAULT_SCALE = "6,7,4,34"
#: Time steps of the bar before its changes: its end is on the wall by the fifth.
BAR_STEPS = 8
PERIOD = 2e-3
FRACTIONS = (0.01, 0.05)
#: A trial's changes: its points flipped, back, the same points again and back.
CYCLE = ("flip", "back", "again", "back")
#: Work records of a change: factorisations, or a correction in their place.
CHANGE_KINDS = ("sparse_factor", "dense_factor", "schur", "dense_update")


def change_seconds(records) -> float:
    """Seconds of a solve's change work (not its substitutions)."""
    return sum(r.seconds for r in records if r.kind in CHANGE_KINDS or r.what == "lowrank")


def settled_problem(model: str, order: str, scale: str):
    """The problem in its settled contact state: the joint statically at the load's peak; the
    bar (``paper_scale.py`` 's parallelepiped, its time step) after :data:`BAR_STEPS` steps,
    its end on the wall."""
    from mpi4py import MPI

    import dd_contact as dc
    from dd_contact.paper import models

    if model == "bar":
        from paper_scale import DEMO, scene_for

        scene = scene_for("parallelepiped", scale, order, MPI.COMM_SELF)
        dt = DEMO["parallelepiped"]["dt"]
        problem = dc.TransientProblem(scene, dt, algorithm=order, track_energy=False)
        for _ in range(BAR_STEPS):
            problem.advance()
        return problem
    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
    scene = models.pin_joint(layout, clearance=0.0, pins="elastic", comm=MPI.COMM_SELF)
    problem = dc.StaticProblem(scene, algorithm=order)
    problem.solve(PERIOD / 4)
    return problem


def one(order: str, lowrank: bool, args, out: str) -> dict:
    """Flip points on the settled scene in this process; per change its cost."""
    from dd_contact.solvers.lowrank import LowRankSurface

    LowRankSurface.enabled = False  # the settled state the same in every process
    if args.always_correct:  # what a correction costs where the price rule declines it
        LowRankSurface.refactorise_seconds = lambda self, blocks: np.inf
    rows, trials = [], args.trials
    with settled_problem(args.model, order, args.scale) as problem:
        scene = problem.analysis.scene
        it, solver = problem.iteration, problem.analysis.tie_solver
        surface = problem.analysis.solver.surface
        surface.lowrank = lowrank
        factorise, spent = surface.factorise, [0.0]

        def timed():  # the surface's change work (correct or re-factorise) in CPU seconds
            start = time.process_time()
            factorise()
            spent[0] += time.process_time() - start

        surface.factorise = timed
        solve_surface, solved = surface.solve, [0.0]

        def timed_solve(g, complete):  # its solve after the change, CPU: a first flip's points
            start = time.process_time()  # may be eliminated there, beside the solve's own
            out = solve_surface(g, complete)
            solved[0] += time.process_time() - start
            return out

        surface.solve = timed_solve
        settled = {k: a.copy() for k, a in it.active.items()}
        rhs = {k: v.copy() for k, v in it.last_solve[0].items()}  # any right-hand side will do
        points = sum(len(a) for a in settled.values())
        saved = None

        def states_of(flips: np.ndarray) -> dict:
            flipped = np.concatenate(list(settled.values())).copy()
            flipped[flips] = ~flipped[flips]
            start, states = 0, {"back": settled, "flip": {}}
            for k, a in settled.items():
                states["flip"][k] = flipped[start : start + len(a)]
                start += len(a)
            states["again"] = states["flip"]  # the same points: eliminated already
            return states

        def change(active: dict, what: str, fraction: float, flips: np.ndarray) -> dict:
            nonlocal saved, checked
            it.active = {k: a.copy() for k, a in active.items()}
            first = len(problem.work.records)
            tic, cpu, spent[0], solved[0] = time.perf_counter(), time.process_time(), 0, 0
            x = it._solve_once(solver, rhs, "benchmark")
            seconds, cpu = time.perf_counter() - tic, time.process_time() - cpu
            records = problem.work.records[first:]
            if saved is None and what == "flip" and fraction:  # the contact interfaces' w
                saved = np.concatenate([x[k] for k in sorted(x) if k.startswith("w:")])
                checked = (solver.finish(), it.solved_system(solver))
            return {
                "fraction": fraction,
                "points_changed": len(flips),
                "what": what,
                "seconds": seconds,
                "cpu_seconds": cpu,  # the whole solve's, this process's own
                "change_cpu_seconds": spent[0],  # the surface's factorise
                "surface_solve_cpu_seconds": solved[0],  # and its solve
                "change_seconds": change_seconds(records),
                "updates": sum(r.kind == "dense_update" for r in records),
                "factorisations": sum(r.kind == "dense_factor" for r in records),
            }

        rng = np.random.default_rng(28)
        draws = [
            (fraction, rng.choice(points, size=max(1, int(fraction * points)), replace=False))
            for fraction in FRACTIONS
            for _ in range(trials)
        ]
        # A run's first corrected solve pays once what no later change pays again: the
        # surface's norm (kept until a subdomain is condensed anew) and the first pages of
        # the kept columns' arrays. A point no trial flips, flipped and back first, apart.
        checked = None
        warm = np.setdiff1d(np.arange(points), np.concatenate([f for _, f in draws]))[:1]
        warm_up = [change(states_of(warm)[w], w, 0.0, warm) for w in ("flip", "back")]
        for fraction, flips in draws:
            states = states_of(flips)
            rows += [change(states[w], w, fraction, flips) for w in CYCLE]
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # before the check
        np.save(out, saved)
        whole = Whole(problem.analysis._system, *checked[1])
        backward = whole.backward_error(whole.vector(checked[0]))
    return {
        "order": order,
        "lowrank": lowrank,
        "dofs": sum(s.num_dofs for s in scene.subdomains),
        "points": points,
        "changes": rows,
        "warm_up": warm_up,
        "backward_error": backward,
        "peak_memory_mib": peak,
    }


#: The variants a comparison runs, each in processes of its own, interleaved: the correction,
#: the same with another checkout's ``dd_contact`` (``--before``), re-factorising.
VARIANTS = ("corrected", "before", "refactorised")


def _worker(order: str, label: str, args, out: str) -> dict:
    """One worker process of a variant; its record with its first flip's solution."""
    env = {**os.environ, **PINNED}
    if label == "before":  # the same benchmark on the other checkout's package
        env["PYTHONPATH"] = os.pathsep.join([args.before, env.get("PYTHONPATH", "")])
    command = [sys.executable, __file__, "--one", order, "--scale", args.scale]
    command += ["--model", args.model, "--trials", str(args.trials), "--out-array", out]
    command += ["--refactorise"] if label == "refactorised" else []
    command += ["--always-correct"] if args.always_correct else []
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    record = json.loads(done.stdout.strip().splitlines()[-1])
    record["solution"] = np.load(out)
    return record


def _by_what(rows: list[dict]) -> dict:
    """Medians per kind of change: a first flip, a flip back, the same points again."""
    keys = ("change_seconds", "seconds", "change_cpu_seconds", "surface_solve_cpu_seconds")
    return {
        what: {key: float(np.median([c[key] for c in rows if c["what"] == what])) for key in keys}
        for what in ("flip", "back", "again")
    }


def _summary(rows: list[dict], plain: float) -> dict:
    """A variant's changes of one fraction; ``plain``: a solve without a change (CPU)."""
    cpu = [c["change_cpu_seconds"] for c in rows]
    # the change's whole cost: its own work and what its solve cost beyond a plain one
    whole = [c["change_cpu_seconds"] + c["surface_solve_cpu_seconds"] - plain for c in rows]
    return {
        "change_seconds_median": float(np.median([c["change_seconds"] for c in rows])),
        "change_cpu_seconds_median": float(np.median(cpu)),
        "change_and_solve_cpu_seconds_median": float(np.median(whole)),
        "solve_seconds_median": float(np.median([c["seconds"] for c in rows])),
        "updates": sum(c["updates"] for c in rows),
        "factorisations": sum(c["factorisations"] for c in rows),
        "changes": len(rows),
        "by_what": _by_what(rows),
        "flip_and_solve_cpu_seconds": float(
            np.median([w for w, c in zip(whole, rows, strict=True) if c["what"] == "flip"])
        ),
    }


def compare(order: str, args) -> dict:
    """The variants, interleaved, each in processes of its own."""
    labels = [v for v in VARIANTS if v != "before" or args.before]
    runs: dict[str, list] = {label: [] for label in labels}
    with tempfile.TemporaryDirectory() as tmp:
        for repeat in range(args.repeats):
            for label in labels:
                out = str(Path(tmp) / f"{label}_{repeat}.npy")
                runs[label].append(_worker(order, label, args, out))
    reference = runs["refactorised"][0]["solution"]
    args.refactorised[order] = reference
    scale = np.abs(reference).max()
    out: dict = {"difference": {}, "backward_error": {}, "fractions": {}}
    for label in labels:
        solutions = [r.pop("solution") for r in runs[label]]
        out["difference"][label] = max(
            float(np.abs(x - reference).max() / scale) for x in solutions
        )
        # normwise, on the whole system (14) with the flipped contact terms: a backward-stable
        # solve leaves about 1e-16, whatever its forward error
        out["backward_error"][label] = max(r["backward_error"] for r in runs[label])
    # a solve without a change: the corrected runs' solves back at the factorised state
    plain = float(
        np.median(
            [
                c["surface_solve_cpu_seconds"]
                for c in runs["corrected"][0]["changes"]
                if c["what"] == "back"
            ]
        )
    )
    out["plain_surface_solve_cpu_seconds"] = plain
    for fraction in FRACTIONS:
        per: dict = {}
        for label in labels:
            rows = [c for r in runs[label] for c in r["changes"] if c["fraction"] == fraction]
            per[label] = _summary(rows, plain)
        per["points_changed"] = rows[0]["points_changed"]
        refactorise = per["refactorised"]["change_cpu_seconds_median"]
        for label in labels[:-1]:  # CPU, against re-factorising's change work
            f = per[label]
            for what in ("flip", "again"):
                f[f"ratio_{what}"] = refactorise / max(
                    f["by_what"][what]["change_cpu_seconds"], 1e-9
                )
            f["ratio_flip_and_solve"] = refactorise / max(f["flip_and_solve_cpu_seconds"], 1e-9)
        out["fractions"][str(fraction)] = per
    first = runs["corrected"][0]
    out["points"], out["dofs"] = first["points"], first["dofs"]
    out["peak_memory_mib"] = {
        label: max(r["peak_memory_mib"] for r in runs[label]) for label in labels
    }
    out["runs"] = runs
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model", default="joint", choices=("joint", "bar"))
    parser.add_argument(
        "--scale", help=f"joint: c,r,t,grip cell counts ({DEFAULT_SCALE}); bar: 1/4, nx,ny,nz"
    )
    parser.add_argument("--orders", default="w-v-u,v-w-u")
    parser.add_argument("--trials", type=int, default=3, help="flips per fraction and process")
    parser.add_argument("--repeats", type=int, default=2, help="processes per variant")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--refactorise", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--out-array", help=argparse.SUPPRESS)
    parser.add_argument(
        "--always-correct", action="store_true", help="a worker correcting every change"
    )
    parser.add_argument(
        "--before", help="another checkout's directory: its dd_contact run as a variant too"
    )
    parser.add_argument("--name", help="the results file's name (default from the scale)")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    args.scale = args.scale or (DEFAULT_SCALE if args.model == "joint" else "1/4")
    args.refactorised = {}
    if args.one:
        result = one(args.one, not args.refactorise, args, args.out_array)
        print(json.dumps(result))
        return
    start = time.perf_counter()
    report = {
        "model": args.model,
        "scale": args.scale,
        "machine": platform.node(),
        "blas_threads": 1,
        "trials": args.trials,
        "repeats": args.repeats,
        "orders": {order: compare(order, args) for order in args.orders.split(",")},
    }
    solutions = list(args.refactorised.values())
    if len(solutions) == 2 and len(solutions[0]) == len(solutions[1]):
        # two exact solvers of the same flipped system (each re-factorising): their spread
        a, b = solutions
        report["orders_spread"] = float(np.abs(a - b).max() / np.abs(b).max())
    report["seconds"] = time.perf_counter() - start
    suffix = "" if args.scale == DEFAULT_SCALE else f"_{args.scale}".replace("/", "-")
    suffix = f"_bar{suffix}" if args.model == "bar" else suffix
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    name = args.name or f"lowrank_change{suffix}.json"
    (out / name).write_text(json.dumps(report, indent=1))
    for order, r in report["orders"].items():
        print(f"{order}: {r['dofs']:,} dofs, {r['points']} contact points")
        print(f"  |x - x_refactorised| {r['difference']}; backward error {r['backward_error']}")
        for fraction, f in r["fractions"].items():
            refactorise = 1e3 * f["refactorised"]["change_cpu_seconds_median"]
            print(
                f"  {float(fraction):.0%} ({f['points_changed']} points): "
                f"re-factorise {refactorise:.2f} ms CPU"
            )
            for label in ("corrected", "before"):
                if label in f:
                    g, by = f[label], f[label]["by_what"]
                    flip, again = (
                        by["flip"]["change_cpu_seconds"],
                        by["again"]["change_cpu_seconds"],
                    )
                    whole = g["flip_and_solve_cpu_seconds"]
                    print(
                        f"    {label}: first flip {1e3 * flip:.2f} ms ({g['ratio_flip']:.1f}x), "
                        f"with its solve's extra {1e3 * whole:.2f} ms "
                        f"({g['ratio_flip_and_solve']:.1f}x); again {1e3 * again:.2f} ms "
                        f"({g['ratio_again']:.1f}x)"
                    )
    if "orders_spread" in report:
        print(f"w-v-u against v-w-u, both re-factorised: {report['orders_spread']:.1e}")


if __name__ == "__main__":
    main()
