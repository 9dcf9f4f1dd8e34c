"""The cut decompose makes by default against a 5:5 cut and no cut, on a bar hitting a wall.

A steel bar of ``elements`` hexahedra (0.5 mm cells) moves at 1 m/s onto a rigid wall 10 um
from its end, as one mesh; ``dd_contact.decompose`` cuts it three ways: ``"auto"`` (the
contact end in a small part: the paper's 1:9 on the default bar), two parts by bisection
(5:5), and one part. Each runs the same steps with w-v-u (w-u for one part) and FULL, in one
process, BLAS pinned to one thread. Per run: the whole-run seconds (decompose, set-up,
every step), the contact changes and the decompositions per block.

Writes benchmarks/results/decompose_cut.json.

Run: python benchmarks/decompose_cut.py [--elements 80 10 4] [--steps 30]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import numpy as np
import threadpoolctl

import dd_contact as dc
from dd_contact import meshes

STEEL = dc.Material(E=210e9, nu=0.3, rho=7850.0)
H = 0.5e-3  # cell size (m)


def run(elements, parts, algorithm, steps):
    """Whole-run seconds, contact changes and work of one decomposition and algorithm."""
    start = time.perf_counter()
    size = np.array(elements) * H
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], size, elements)
    wall = dc.Plane([-1e-5, 0, 0], [1, 0, 0])
    end = dc.ContactCandidate(lambda x: np.isclose(x[0], 0.0), wall, name="end")
    scene = dc.decompose(bar, STEEL, parts=parts, contacts=[end], margin=1e-3, comm=MPI.COMM_SELF)
    for sub in scene.subdomains:
        sub.velocity.interpolate(lambda x: np.vstack([-np.ones(x.shape[1]), 0 * x[0], 0 * x[0]]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with dc.TransientProblem(scene, dt=2e-6, algorithm=algorithm) as problem:
            problem.run(steps)
            work = {b: w["decompositions"] for b, w in problem.work_summary().items()}
            changes = problem.changes["end"]
    return {
        "parts": [len(c) for c in scene.decomposition.cells.values()],
        "cut": scene.decomposition.description,
        "algorithm": algorithm,
        "whole_run_seconds": time.perf_counter() - start,
        "changes": changes,
        "decompositions": work,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs=3, default=[80, 10, 4])
    parser.add_argument("--steps", type=int, default=30)
    args = parser.parse_args()
    cases = [("auto", "w-v-u"), (2, "w-v-u"), (1, "w-u"), (1, "FULL")]
    with threadpoolctl.threadpool_limits(limits=1, user_api="blas"):
        runs = [run(args.elements, parts, algorithm, args.steps) for parts, algorithm in cases]
    for r in runs:
        print(f"{r['cut']:45s} {r['algorithm']:6s} {r['whole_run_seconds']:7.2f} s", r["changes"])
    best = min(r["whole_run_seconds"] for r in runs)
    result = {"elements": args.elements, "steps": args.steps, "runs": runs, "best": best}
    path = Path(__file__).parent / "results" / "decompose_cut.json"
    path.write_text(json.dumps(result, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
