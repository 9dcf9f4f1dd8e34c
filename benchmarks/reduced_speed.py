"""Reduced subdomains (``Subdomain.reduce``): a step's time against FULL's, and the trade.

**Speed** (``--part speed``): the pressed bar of ``step_profile.py`` (moving 100x slower than
the speed benchmark's, so most steps change nothing), each case in its own process with
every BLAS pinned to one thread: FULL, w-u, and w-u and w-v-u with every subdomain reduced
to ``--modes`` fixed-interface modes. After the set-up and ``--warm`` steps, ``--steps``
steps are timed one by one (``track_energy=False``); only steps without a contact state
change count. Reported: set-up seconds (assembly, reduction, factorisations), the median
quiet step (wall and CPU), the peak resident memory (``ru_maxrss``, MiB), the reduced sizes.

**Trade** (``--part trade``): the bar striking its wall (no load, contact kappa 1), w-u,
unreduced and reduced with each of ``--trade-modes``: the contact-force history's largest
error relative to the unreduced run's peak, and a chart
(``benchmarks/results/reduced_trade.png``).

Writes benchmarks/results/reduced_speed_<nx>x<ny>x<nz>.json and reduced_trade.json.

Run: python benchmarks/reduced_speed.py [--elements 120 18 6] [--modes 20] [--steps 9]
     [--part speed trade]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

HERE = Path(__file__).parent / "results"
PINNED = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "BLIS_NUM_THREADS": "1",
}
#: (label, algorithm, reduced)
CASES = [("FULL", "FULL", False), ("w-u", "w-u", False), ("w-u reduced", "w-u", True)]
CASES += [("w-v-u reduced", "w-v-u", True)]


def speed_worker(args) -> dict:
    from mpi4py import MPI

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped

    label = args.worker
    _, algorithm, reduced = next(c for c in CASES if c[0] == label)
    start = time.perf_counter()
    scene = parallelepiped(algorithm, tuple(args.elements), speed=args.speed, comm=MPI.COMM_SELF)
    if reduced:
        for sub in scene.subdomains:
            sub.reduce(modes=args.modes)
    problem = dd.TransientProblem(scene, args.dt, algorithm=algorithm, track_energy=False)
    problem.start()
    for _ in range(args.warm):
        problem.advance()
    setup = time.perf_counter() - start
    wall, cpu = [], []
    for _ in range(args.steps):
        t0, c0 = time.perf_counter(), time.process_time()
        record = problem.advance()
        if not record["changes"]:
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    sizes = {b: int(n) for b, n in problem.model.system.sizes.items() if b.startswith("u:")}
    out = {
        "setup_seconds": setup,
        "step_seconds": statistics.median(wall) if wall else None,
        "step_cpu_seconds": statistics.median(cpu) if cpu else None,
        "quiet_steps": len(wall),
        "steps_wall": [round(w, 5) for w in wall],
        "peak_memory_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "subdomain_sizes": sizes,
        "dofs": sum(s.num_dofs for s in scene.subdomains),
    }
    problem.close()
    return out


def trade(elements, modes_list, steps, dt) -> dict:
    from mpi4py import MPI

    import numpy as np

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped

    def run(modes):
        scene = parallelepiped("w-u", elements, pressure=0.0, contact_kappa=1.0, comm=MPI.COMM_SELF)
        if modes is not None:
            for sub in scene.subdomains:
                sub.reduce(modes=modes)
        problem = dd.TransientProblem(scene, dt, "w-u", track_energy=False)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", dd.CoarseTimeStepWarning)
            history = problem.run(steps, progress=False, summary=False)
        seconds = time.perf_counter() - t0
        problem.close()
        return np.array([r["force"]["end"][0] for r in history]), seconds

    reference, seconds = run(None)
    out = {"elements": list(elements), "dt": dt, "steps": steps, "unreduced_seconds": seconds}
    out["force_unreduced"] = reference.tolist()
    peak = np.abs(reference).max()
    out["runs"] = {}
    for m in modes_list:
        force, seconds = run(m)
        error = float(np.abs(force - reference).max() / peak)
        out["runs"][str(m)] = {"error": error, "seconds": seconds, "force": force.tolist()}
        print(f"modes {m}: force history error {error:.3g} (of the peak), {seconds:.2f} s")
    return out


def chart(data: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    t = [data["dt"] * (k + 1) * 1e6 for k in range(data["steps"])]
    left.plot(t, data["force_unreduced"], "k-", lw=2, label="unreduced")
    for m, run in data["runs"].items():
        left.plot(t, run["force"], lw=1, label=f"m = {m}")
    left.set_xlabel("t [us]")
    left.set_ylabel("contact force [N]")
    left.legend(fontsize=7)
    modes = [int(m) for m in data["runs"]]
    right.loglog(modes, [r["error"] for r in data["runs"].values()], "o-")
    right.set_xlabel("fixed-interface modes m")
    right.set_ylabel("force history error / peak")
    right.grid(True, which="both", alpha=0.3)
    nx, ny, nz = data["elements"]
    fig.suptitle(f"bar {nx}x{ny}x{nz} striking its wall, w-u: reduced against unreduced")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[120, 18, 6])
    parser.add_argument("--dt", type=float, default=1e-6)
    parser.add_argument("--speed", type=float, default=0.01)
    parser.add_argument("--modes", type=int, default=20)
    parser.add_argument("--warm", type=int, default=2)
    parser.add_argument("--steps", type=int, default=9)
    parser.add_argument("--part", nargs="+", default=["speed", "trade"])
    parser.add_argument("--cases", nargs="+", default=[c[0] for c in CASES])
    parser.add_argument("--trade-elements", type=int, nargs=3, default=[40, 8, 4])
    parser.add_argument("--trade-modes", type=int, nargs="+", default=[5, 10, 20, 40, 80, 160])
    parser.add_argument("--trade-steps", type=int, default=60)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(speed_worker(args)))
        return
    if "speed" in args.part:
        nx, ny, nz = args.elements
        results = {}
        for label in args.cases:
            command = [sys.executable, __file__, "--worker", label, "--elements"]
            command += [str(n) for n in args.elements]
            command += ["--steps", str(args.steps), "--warm", str(args.warm)]
            command += [
                "--dt",
                str(args.dt),
                "--speed",
                str(args.speed),
                "--modes",
                str(args.modes),
            ]
            done = subprocess.run(
                command, env={**os.environ, **PINNED}, capture_output=True, text=True, check=True
            )
            results[label] = json.loads(done.stdout.splitlines()[-1])
            r = results[label]
            print(label, {k: r[k] for k in ("setup_seconds", "step_seconds", "peak_memory_mib")})
        full = results.get("FULL", {}).get("step_seconds")
        for r in results.values():
            if full and r["step_seconds"]:
                r["speedup_vs_full"] = full / r["step_seconds"]
        settings = {"elements": args.elements, "modes": args.modes, "dt": args.dt}
        out = HERE / f"reduced_speed_{nx}x{ny}x{nz}.json"
        out.write_text(json.dumps({**settings, "results": results}, indent=1))
        print(f"wrote {out}")
    if "trade" in args.part:
        data = trade(tuple(args.trade_elements), args.trade_modes, args.trade_steps, 2e-7)
        (HERE / "reduced_trade.json").write_text(json.dumps(data, indent=1))
        chart(data, HERE / "reduced_trade.png")
        print(f"wrote {HERE / 'reduced_trade.json'} and reduced_trade.png")


if __name__ == "__main__":
    main()
