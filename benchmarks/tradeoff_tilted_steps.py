"""Why the tilted wall's default (the paper's 0.1 ms step) sits off its front: where its time goes.

Runs the tilted-wall scene (:mod:`dd_contact.paper.tradeoff.tilted`) at 40 x 10 x 2 and
20 x 5 x 1 hexahedra, each at dt = 100, 50 and 25 us, each setting three times, interleaved,
each run in its own process with one BLAS thread; for each run its CPU seconds of set-up
(scene, assembly, first factorisation) and of stepping, its steps, contact iterations
(solves: one per step plus one per repeated solve), contact state changes, decompositions
and substitutions (``TransientProblem.work_summary``) and its error. Writes
``benchmarks/results/tradeoff_tilted_steps.json`` (every run, the medians, the load
average).

Usage: python benchmarks/tradeoff_tilted_steps.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from pinned import pinned_record

OUT = Path(__file__).parent / "results" / "tradeoff_tilted_steps.json"
SETTINGS = [(e, dt) for e in ((40, 10, 2), (20, 5, 1)) for dt in (1e-4, 5e-5, 2.5e-5)]


def one(elements: tuple[int, ...], dt: float) -> dict:
    """One run in this process: set-up and stepping CPU seconds, its counts, its error."""
    from mpi4py import MPI

    from dd_contact.paper.models import parallelepiped
    from dd_contact.paper.tradeoff import scene
    from dd_contact.paper.tradeoff.design import defaults
    from dd_contact.paper.tradeoff.tilted import PERIOD, REFERENCE, windows
    from dd_contact.problem import TransientProblem

    base = defaults(scene("tilted-wall").knobs)
    start = time.process_time()
    model = parallelepiped(elements, split=tuple(base["split"]), period=PERIOD, comm=MPI.COMM_SELF)
    steps = round(PERIOD / dt)
    problem = TransientProblem(model, dt, track_energy=False, expected_steps=steps)
    problem.advance()
    setup = time.process_time() - start
    for _ in range(steps - 1):
        problem.advance()
    stepping = time.process_time() - start - setup
    forces = np.array([np.linalg.norm(r["force"]["end"]) for r in problem.history])
    exact = np.asarray(REFERENCE["windows"])
    work = problem.work_summary()
    return {
        "elements": elements, "dt": dt, "setup_cpu": setup, "stepping_cpu": stepping,
        "cpu": setup + stepping, "steps": steps,
        "solves": int(sum(r["iterations"] for r in problem.history)),
        "changes": int(problem.changes["gamma"]),
        "decompositions": int(sum(b.get("decompositions", 0) for b in work.values())),
        "substitutions": int(sum(b.get("substitutions", 0) for b in work.values())),
        "error": float(np.linalg.norm(windows(dt, forces) - exact) / np.linalg.norm(exact)),
    }  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        elements = tuple(int(n) for n in args.one[0].split("x"))
        print(json.dumps(one(elements, float(args.one[1]))))
        return
    doc: dict = {"load_average_before": os.getloadavg(), "runs": []}
    for _ in range(args.repeats):
        for elements, dt in SETTINGS:
            label = "x".join(map(str, elements))
            command = [sys.executable, "-W", "ignore", __file__, "--one", label, repr(dt)]
            doc["runs"].append(pinned_record(command))
            print(doc["runs"][-1], flush=True)
    doc["load_average_after"] = os.getloadavg()
    doc["medians"] = []
    for elements, dt in SETTINGS:
        mine = [r for r in doc["runs"] if tuple(r["elements"]) == elements and r["dt"] == dt]
        doc["medians"].append({
            **{k: mine[0][k] for k in ("elements", "dt", "steps", "solves", "changes",
                                       "decompositions", "substitutions", "error")},
            **{k: float(np.median([r[k] for r in mine])) for k in
               ("setup_cpu", "stepping_cpu", "cpu")},
        })  # fmt: skip
    OUT.write_text(json.dumps(doc, indent=1))
    for m in doc["medians"]:
        print(m)


if __name__ == "__main__":
    main()
