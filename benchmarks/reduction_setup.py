"""A reduced subdomain's set-up, phase by phase: CPU seconds and peak memory (issue 28).

Builds the parallelepiped of ``paper_scale.py`` at ``--scale`` (``1/16``: about 85k dofs,
``1/4``: about 340k) with every subdomain reduced to ``--modes`` fixed-interface modes, runs
``--steps`` steps with w-u, and records per phase the wall and CPU seconds and the peak
resident memory (``VmHWM``, reset at each phase's start; ``setup_memory.Phases``). The
phases end where the reduction's calls return (wrapped here, unchanged): the interior's
pieces and factor, the fixed-interface modes, the load modes, ``A_r``/``M_r`` (the
constraint modes), the rest of the model's reduction, the solver, the steps. Also recorded:
the seconds the reduction's solves took by what they were for (the work log), and how
many columns the modes' solves took in how many solves. ``--modes`` ``none`` runs the
unreduced w-u, whose peak is the target. ``--eigensolvers`` runs each case with each of
``Subdomain.reduce``'s eigensolvers (``block``, ``slepc``), interleaved; ``--tolerance``
sets ``reduce(tolerance=...)``. Each block eigensolve's statistics (CPU by part, columns,
solves, restarts, each restart's largest residual) are recorded too.

``--trees`` runs each case once per source tree (``PYTHONPATH``), the trees interleaved and
the whole ``--repeats`` times: e.g. a checkout of main against this branch. Writes
``benchmarks/results/reduction_setup.json`` (``--out``), keyed by label, scale and case,
after every run.

Run: python benchmarks/reduction_setup.py --scale 1/16 --modes 320 --trees before=/tmp/main
     after=. [--repeats 2] [--label 1over16] [--eigensolvers block slepc]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from pin_joint_reduced import eigen_recorder
from pinned import PINNED
from setup_memory import Phases, wrap_after, wrap_before

OUT = Path(__file__).parent / "results" / "reduction_setup.json"


class CpuPhases(Phases):
    """:class:`setup_memory.Phases` with each phase's CPU seconds too."""

    def __init__(self, trim):
        self._cpu = time.process_time()
        super().__init__(trim)

    def close(self, name: str) -> None:
        cpu = time.process_time() - self._cpu
        super().close(name)
        self.records[-1]["cpu_seconds"] = round(cpu, 2)
        print(json.dumps({"phase": self.records[-1]}), file=sys.stderr, flush=True)  # if cut
        self._cpu = time.process_time()


def run_case(args, phases, **options):
    """The bar at ``args.scale`` reduced (``options``: more of ``reduce``'s), its solver and
    its steps, each closing a phase: ``(modes, elements, scene, problem)``."""
    from mpi4py import MPI

    import paper_scale

    import dd_contact as dc
    from dd_contact.paper import examples

    modes = None if args.modes == "none" else int(args.modes)
    elements = paper_scale._bar_scale(args.scale)
    scene = examples.parallelepiped("w-u", elements, comm=MPI.COMM_SELF)
    for sub in scene.subdomains if modes is not None else ():
        sub.reduce(modes=modes, **options)
    phases.close("scene")
    problem = dc.TransientProblem(scene, args.dt, algorithm="w-u", track_energy=False)
    phases.close("solver")
    for _ in range(args.steps):
        problem.advance()
    phases.close(f"{args.steps} steps")
    return modes, elements, scene, problem


def worker(args) -> dict:
    """One case in this process: the scene, its reduction by phases, the steps."""

    from dd_contact import analysis
    from dd_contact.solvers import reduced
    from dd_contact.solvers.linalg import release_freed_memory

    phases = CpuPhases(release_freed_memory)
    basis = reduced.ReducedBasis
    wrap_before(basis, "_modes", phases, "assembly, pieces, interior factor")
    wrap_after(basis, "_modes", phases, f"fixed-interface modes ({args.eigensolver})")
    wrap_before(basis, "_reduced", phases, "load modes")
    wrap_after(basis, "_reduced", phases, "A_r, M_r (constraint modes)")
    wrap_after(analysis, "reduce_model", phases, "rest of the reduction")
    options = {"eigensolver": args.eigensolver} if args.eigensolver else {}
    if args.tolerance:
        options["tolerance"] = args.tolerance
    eigen = eigen_recorder()
    modes, elements, scene, problem = run_case(args, phases, **options)
    by_what: dict[str, float] = {}
    modes_solves = {"solves": 0, "columns": 0}
    for r in problem.work.records:
        if r.block.endswith("(interior)"):
            key = f"{r.kind} {r.what}".strip()
            by_what[key] = round(by_what.get(key, 0.0) + r.seconds, 2)
            if r.what == "modes":  # SLEPc's one record: its single-column solves
                modes_solves["solves"] += r.nrhs if args.eigensolver == "slepc" else 1
                modes_solves["columns"] += r.nrhs
    out = {
        "modes": modes,
        "elements": list(elements),
        "dofs": int(sum(s.num_dofs for s in scene.subdomains)),
        "reduced_sizes": {b: int(problem.model.system.sizes[b]) for b in problem.model.reduced},
        "phases": phases.records,
        "peak_mb": max(r["peak_mb"] for r in phases.records),
        "cpu_seconds": round(sum(r["cpu_seconds"] for r in phases.records), 2),
        "reduction_solves_seconds": by_what,
        "modes_solves": modes_solves,
        "omega2": {b: problem.model.reduced[b].omega2.tolist() for b in problem.model.reduced},
        "eigensolver": args.eigensolver,
        "block_eigensolver": eigen,
    }
    problem.close()
    return out


def run(args, tree: str, script: str = __file__) -> dict:
    """One case of ``script`` in a fresh process on source tree ``tree``, BLAS pinned."""
    command = [sys.executable, script, "--worker", "--scale", args.scale]
    command += ["--modes", args.modes, "--steps", str(args.steps), "--dt", str(args.dt)]
    command += ["--eigensolver", args.eigensolver] if getattr(args, "eigensolver", "") else []
    command += ["--tolerance", str(args.tolerance)] if getattr(args, "tolerance", None) else []
    here = str(Path(__file__).parent)
    env = {**os.environ, **PINNED, "PYTHONPATH": os.pathsep.join([str(Path(tree)), here])}
    with open(args.out.with_suffix(".log"), "a") as log:  # each phase as it ends
        done = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=log, text=True)
    if done.returncode:
        raise RuntimeError(f"{tree} failed: see {args.out.with_suffix('.log')}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def case_parser(description: str, modes: str, out: Path) -> argparse.ArgumentParser:
    """The options of a reduction's case run per source tree (this script's and others')."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--scale", default="1/16", help="paper_scale.py's bar scale")
    parser.add_argument("--modes", default=modes, help="fixed-interface modes, or none")
    parser.add_argument("--steps", type=int, default=2)
    parser.add_argument("--dt", type=float, default=1e-6)
    parser.add_argument("--trees", nargs="+", default=["after=."], help="name=path ...")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--label", default="", help="prefix of the runs' keys")
    parser.add_argument("--out", type=Path, default=out)
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    return parser


def main() -> None:
    parser = case_parser(__doc__.split("\n")[0], "320", OUT)
    parser.add_argument("--eigensolvers", nargs="+", default=[""], help="block slepc")
    parser.add_argument("--eigensolver", default="", help=argparse.SUPPRESS)
    parser.add_argument("--tolerance", type=float, help="reduce(tolerance=...)")
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    results = json.loads(args.out.read_text()) if args.out.exists() else {}
    trees = dict(t.split("=", 1) for t in args.trees)
    cases = [(name, tree, e) for name, tree in trees.items() for e in args.eigensolvers]
    for _ in range(args.repeats):
        for name, tree, eigensolver in cases:  # interleaved: each case once per round
            args.eigensolver = eigensolver
            load = os.getloadavg()[0]
            record = {**run(args, tree), "load_average": round(load, 2)}
            key = f"{args.label}|{args.scale}|m={args.modes}|{name}"
            key += f"|{eigensolver}" if eigensolver else ""
            results.setdefault("runs", {}).setdefault(key, []).append(record)
            print(key, json.dumps({k: record[k] for k in ("cpu_seconds", "peak_mb")}))
            args.out.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
