"""Condensing a subdomain: MUMPS's Schur complement against multi-RHS substitutions.

For the first subdomain of the split parallelepiped (``dd_contact.paper.examples``; it carries the
interface and the contact interface, so D_V + D_W coupling columns), forms
``Z = C^T K^-1 C`` both ways, with every BLAS pinned to one thread:

* ``"multi-rhs"``: factorise K, then one substitution per coupling column (MUMPS
  multi-RHS, 256 at a time), as the paper counts it;
* ``"schur"``: factorise ``[[K, C], [C^T, 0]]`` with the last block as MUMPS's Schur block;
  the same factor then serves the u_hat and u solves.

Writes benchmarks/results/condensation.json: seconds of each (median of ``--repeats``),
the ratio, and the largest difference between the two Z.

Run: python benchmarks/condensation.py [--elements 250 36 10] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

os.environ.update({"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})

from mpi4py import MPI

import numpy as np

from dd_contact.assembly import assemble
from dd_contact.paper.examples import parallelepiped
from dd_contact.solvers import WorkLog
from dd_contact.solvers.subdomains import SubdomainCondensation
from dd_contact.timestepping import Newmark

HERE = Path(__file__).parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[250, 36, 10])
    parser.add_argument("--dt", type=float, default=1e-6)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(HERE / "condensation.json"))
    args = parser.parse_args()
    scene = parallelepiped("v-w-u", tuple(args.elements), comm=MPI.COMM_SELF)
    system = assemble(scene).effective(Newmark(args.dt).mass_coefficient)
    block = f"u:{scene.subdomains[0].name}"
    seconds: dict[str, list[float]] = {"multi-rhs": [], "schur": []}
    Z = {}
    for _ in range(args.repeats):
        for mode in seconds:
            sub = SubdomainCondensation(block, system, [], WorkLog(), mode)
            start = time.perf_counter()
            sub.factorise()
            seconds[mode].append(time.perf_counter() - start)
            Z[mode] = sub.Z
            columns = sub.C.shape[1]
            sub.destroy()
    median = {mode: statistics.median(s) for mode, s in seconds.items()}
    result = {
        "elements": args.elements,
        "subdomain_dofs": system.sizes[block],
        "coupling_columns": columns,
        "seconds": seconds,
        "median_seconds": median,
        "multi_rhs_over_schur": median["multi-rhs"] / median["schur"],
        "max_relative_difference": float(
            np.abs(Z["schur"] - Z["multi-rhs"]).max() / np.abs(Z["multi-rhs"]).max()
        ),
        "note": "factorisation plus condensation; BLAS pinned to one thread",
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1))
    print(json.dumps({k: v for k, v in result.items() if k != "seconds"}, indent=1))


if __name__ == "__main__":
    main()
