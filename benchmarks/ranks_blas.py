"""Two ranks against one, with the environment as a user has it (no thread variables set).

Each rank's numpy/scipy OpenBLAS starts one thread per core; two ranks on a 2-core machine
then run four spinning BLAS threads. ``dd_contact`` limits each rank's BLAS threads to its
share of the node's cores (``parallel.share_cores``). This script times a w-v-u step of the
bar (``paper.examples.parallelepiped``) on 1 and 2 ranks, medians of the steps after the
first, with the package at ``--package`` (another checkout to compare), and writes JSON.

Run: python benchmarks/ranks_blas.py [--elements 80 16 6] [--steps 8] [--package DIR]
     [--out benchmarks/results/ranks_blas.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).parent / "results"
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def worker(args) -> None:
    """One run on every rank of ``mpiexec``; rank 0 prints its JSON line."""
    from mpi4py import MPI

    from threadpoolctl import threadpool_info

    import dd_contact as dd

    if (Path(dd.__file__).parent / "paper").is_dir():
        from dd_contact.paper.examples import parallelepiped
    else:  # a checkout before the paper's sub-package
        from dd_contact.examples import parallelepiped  # type: ignore[no-redef]

    comm = MPI.COMM_WORLD
    scene = parallelepiped("w-v-u", tuple(args.elements), comm=comm)
    problem = dd.TransientProblem(scene, 1e-6, algorithm="w-v-u", track_energy=False)
    problem.advance()  # the first step factorises
    seconds = []
    for _ in range(args.steps):
        comm.Barrier()
        start = time.perf_counter()
        problem.advance()
        seconds.append(comm.allreduce(time.perf_counter() - start, op=MPI.MAX))
    if comm.rank == 0:
        seconds.sort()
        blas = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        print(json.dumps({"median_step_s": seconds[len(seconds) // 2], "blas_threads": blas}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[80, 16, 6])
    parser.add_argument("--steps", type=int, default=8)
    parser.add_argument("--package", default=str(Path(__file__).resolve().parents[1]))
    parser.add_argument("--out", default=str(HERE / "ranks_blas.json"))
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    env["PYTHONPATH"] = args.package
    mpiexec = Path(sys.executable).with_name("mpiexec")
    out = {"elements": args.elements, "package": args.package, "note": "no thread variables set"}
    for ranks in (1, 2):
        command = [str(mpiexec), "-n", str(ranks), sys.executable, __file__, "--worker"]
        command += ["--elements", *map(str, args.elements), "--steps", str(args.steps)]
        done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
        out[f"ranks_{ranks}"] = json.loads(done.stdout.strip().splitlines()[-1])
        print(ranks, out[f"ranks_{ranks}"], flush=True)
    out["two_over_one"] = out["ranks_2"]["median_step_s"] / out["ranks_1"]["median_step_s"]
    Path(args.out).write_text(json.dumps(out, indent=1))
    print(f"2 ranks / 1 rank per step: {out['two_over_one']:.2f}")


if __name__ == "__main__":
    main()
