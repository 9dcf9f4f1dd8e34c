"""Reduced subdomains (``Subdomain.reduce``): a step's time against FULL's, and the trade.

**Speed** (``--part speed``): the pressed bar of ``step_profile.py`` (moving 100x slower than
the speed benchmark's, so most steps change nothing), each case in its own process with
every BLAS pinned to one thread: FULL, w-u, and w-u and w-v-u with every subdomain reduced
to ``--modes`` fixed-interface modes. After the set-up and ``--warm`` steps, ``--steps``
steps are timed one by one (``track_energy=False``); only steps without a contact state
change count. Reported: set-up seconds (assembly, reduction, factorisations), the median
quiet step (wall and CPU), the peak resident memory (``ru_maxrss``, MiB), the reduced sizes.

The iterative peers (``CG+Jacobi``, ``CG+GAMG``: FULL's matrix solved by warm-started CG,
``iterative_peer.py``) run the same bar as FULL, and every case's step is also given as a
ratio to theirs. Each case runs ``--repeats`` times, the cases interleaved (all once, then
again); reported are the medians of the runs' medians, the largest peak, the load average
before each run, and each peer's displacements against the direct FULL's (the largest
relative difference over the timed steps).

**Peer accuracy** (``--part peer-accuracy``): the peers' displacements against the direct
FULL's over ``--steps`` steps of the ``--trade-elements`` bar pressed at full speed (its
contact growing), per CG tolerance; writes peer_accuracy.json (how RTOL was chosen).

**Trade** (``--part trade``): the bar striking its wall (no load, contact kappa 1), w-u,
unreduced and reduced with each of ``--trade-modes``: the contact-force history's largest
error relative to the unreduced run's peak, and a chart
(``benchmarks/results/reduced_trade.png``).

**Paper trade** (``--part paper-trade``): the paper's bar on its wall (w-u, dt 1e-4, as
``paper_scale.py``) reduced with each of ``--trade-modes`` and ``--trade-tolerances`` (the
modes' eigensolver tolerance): the force history's largest error over the unreduced peak,
the set-up's CPU seconds and the modes' solved columns (reduced_paper_trade_<cells>.json).

Writes benchmarks/results/reduced_speed_<nx>x<ny>x<nz>.json and reduced_trade.json.

Run: python benchmarks/reduced_speed.py [--elements 120 18 6] [--modes 20] [--steps 9]
     [--repeats 3] [--cases FULL "w-u reduced" CG+GAMG] [--part speed peer-accuracy trade]
"""

from __future__ import annotations

import argparse
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

sys.path.insert(0, str(Path(__file__).parent))  # iterative_peer, a worker's import

HERE = Path(__file__).parent / "results"
#: (label, algorithm, reduced); the peers are FULL solved by CG (iterative_peer.py)
CASES = [("FULL", "FULL", False), ("w-u", "w-u", False), ("w-u reduced", "w-u", True)]
CASES += [("w-v-u reduced", "w-v-u", True), ("CG+Jacobi", "FULL", False)]
CASES += [("CG+GAMG", "FULL", False)]


def speed_worker(args) -> dict:
    import contextlib

    from mpi4py import MPI

    import iterative_peer
    import numpy as np

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped

    label = args.worker
    _, algorithm, reduced = next(c for c in CASES if c[0] == label)
    start, cpu_start = time.perf_counter(), time.process_time()
    scene = parallelepiped(algorithm, tuple(args.elements), speed=args.speed, comm=MPI.COMM_SELF)
    if reduced:
        for sub in scene.subdomains:
            sub.reduce(modes=args.modes)
    solver = (
        iterative_peer.peer(label, scene, args.rtol or None)
        if label in iterative_peer.PEERS
        else contextlib.nullcontext()
    )
    with solver:
        problem = dd.TransientProblem(scene, args.dt, algorithm=algorithm, track_energy=False)
    problem.start()
    for _ in range(args.warm):
        problem.advance()
    setup, setup_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    wall, cpu, fields = [], [], []
    for _ in range(args.steps):
        t0, c0 = time.perf_counter(), time.process_time()
        record = problem.advance()
        if not record["changes"]:
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        if algorithm == "FULL" and args.dump:  # FULL's and the peers' u, for their accuracy
            fields.append(np.concatenate(list(problem.solver.finish().values())))
    if fields:
        np.save(Path(args.dump) / f"{label}.npy", np.array(fields))
    sizes = {b: int(n) for b, n in problem.model.system.sizes.items() if b.startswith("u:")}
    out = {
        "setup_seconds": setup,
        "setup_cpu_seconds": setup_cpu,
        "cg_iterations": getattr(problem.solver, "iterations", None),
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


def paper_trade(elements, modes_list, steps, tolerances=(None,)) -> dict:
    """The paper's bar (models.parallelepiped, shaken on its wall; w-u, dt 1e-4 as
    paper_scale.py), reduced with each of ``modes_list`` (and each of the modes'
    ``tolerances``; None: the package's default) against unreduced: the largest error of the
    contact-force history (its x component) over the unreduced run's peak, the set-up's CPU
    seconds and the columns the modes' solves took."""
    from mpi4py import MPI

    import numpy as np

    import dd_contact as dd
    from dd_contact.paper import models

    def run(modes, tolerance=None):
        scene = models.parallelepiped(tuple(elements), algorithm="w-u", comm=MPI.COMM_SELF)
        options = {} if tolerance is None else {"tolerance": tolerance}
        for sub in scene.subdomains if modes is not None else ():
            sub.reduce(modes=modes, **options)
        c0 = time.process_time()
        problem = dd.TransientProblem(scene, 1e-4, "w-u", track_energy=False)
        setup = time.process_time() - c0
        c0 = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", dd.CoarseTimeStepWarning)
            history = problem.run(steps, progress=False, summary=False)
        seconds = time.process_time() - c0
        columns = sum(r.nrhs for r in problem.work.records if r.what == "modes")
        problem.close()
        record = {"cpu_seconds": seconds, "setup_cpu_seconds": setup, "mode_columns": columns}
        record["changes"] = sum(r["changes"] for r in history)
        return np.array([r["force"]["end"][0] for r in history]), record

    reference, record = run(None)
    out = {"elements": list(elements), "dt": 1e-4, "steps": steps, "changes": record["changes"]}
    out |= {"unreduced_cpu_seconds": record["cpu_seconds"], "runs": {}}
    out |= {"force_unreduced": reference.tolist()}
    peak = np.abs(reference).max()
    for m in modes_list:
        for tolerance in tolerances:
            force, record = run(m, tolerance)
            error = float(np.abs(force - reference).max() / peak)
            key = str(m) if tolerance is None else f"{m} tol={tolerance:g}"
            out["runs"][key] = {"error": error, **record, "force": force.tolist()}
            print(f"paper's bar {elements}, modes {key}: force history error {error:.3g} of peak")
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


def speed(args) -> None:
    """Every case ``--repeats`` times, interleaved (case after case, then again); medians."""
    import iterative_peer
    import numpy as np

    nx, ny, nz = args.elements
    runs: dict[str, list[dict]] = {label: [] for label in args.cases}
    loads = []
    with tempfile.TemporaryDirectory() as dump:
        for repeat in range(args.repeats):
            for label in args.cases:
                command = [sys.executable, __file__, "--worker", label, "--elements"]
                command += [str(n) for n in args.elements]
                command += ["--steps", str(args.steps), "--warm", str(args.warm)]
                command += ["--dt", str(args.dt), "--speed", str(args.speed)]
                command += ["--modes", str(args.modes), "--rtol", str(args.rtol)]
                command += ["--dump", dump] * (repeat == 0)
                loads.append(os.getloadavg()[0])
                done = subprocess.run(
                    command, env={**os.environ, **PINNED}, capture_output=True, text=True
                )
                if done.returncode:
                    raise RuntimeError(f"{label}: {done.stderr[-2000:]}")
                lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
                runs[label].append(json.loads(lines[-1]))
                r = runs[label][-1]
                print(label, repeat, {k: r[k] for k in ("setup_seconds", "step_cpu_seconds")})
        reference = Path(dump) / "FULL.npy"
        accuracy = {}
        if reference.exists():
            full = np.load(reference)
            for label in args.cases:
                if label != "FULL" and (Path(dump) / f"{label}.npy").exists():
                    x = np.load(Path(dump) / f"{label}.npy")
                    gap = np.linalg.norm(x - full, axis=1) / np.linalg.norm(full, axis=1)
                    accuracy[label] = float(gap.max())
    results = {label: _medians(r) for label, r in runs.items()}
    for label, gap in accuracy.items():
        results[label]["u_difference_vs_full"] = gap  # max over steps of |u - u_FULL| / |u_FULL|
    for label, r in results.items():
        for base in ("FULL", *PEERS_OF):
            b = results.get(base, {})
            if b.get("step_cpu_seconds") and r["step_cpu_seconds"] and base != label:
                r[f"cpu_speedup_vs_{base}"] = b["step_cpu_seconds"] / r["step_cpu_seconds"]
                r[f"wall_speedup_vs_{base}"] = b["step_seconds"] / r["step_seconds"]
    rtol = args.rtol or iterative_peer.RTOL
    settings = {"elements": args.elements, "modes": args.modes, "dt": args.dt, "rtol": rtol}
    settings |= {"repeats": args.repeats, "load_average": [round(x, 2) for x in loads]}
    out = Path(args.out or HERE / f"reduced_speed_{nx}x{ny}x{nz}.json")
    out.write_text(json.dumps({**settings, "results": results}, indent=1))
    print(f"wrote {out}")


#: The peers every ratio is also given against.
PEERS_OF = ("CG+Jacobi", "CG+GAMG")


def _medians(runs: list[dict]) -> dict:
    """One case's repeats: the medians of their medians, the largest peak memory."""
    out = dict(runs[0])
    for key in ("setup_seconds", "setup_cpu_seconds", "step_seconds", "step_cpu_seconds"):
        values = [r[key] for r in runs if r.get(key) is not None]
        out[key] = statistics.median(values) if values else None
        out[f"{key}_runs"] = [round(v, 5) for v in values]
    out["peak_memory_mib"] = max(r["peak_memory_mib"] for r in runs)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", type=int, nargs=3, default=[120, 18, 6])
    parser.add_argument("--dt", type=float, default=1e-6)
    parser.add_argument("--speed", type=float, default=0.01)
    parser.add_argument("--modes", type=int, default=20)
    parser.add_argument("--warm", type=int, default=2)
    parser.add_argument("--steps", type=int, default=9)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rtol", type=float, default=0.0, help="the peers' (0: their RTOL)")
    parser.add_argument("--part", nargs="+", default=["speed", "trade"])
    parser.add_argument("--cases", nargs="+", default=[c[0] for c in CASES])
    parser.add_argument("--out", help="the speed or paper-trade part's JSON (default by the cells)")
    parser.add_argument("--trade-elements", type=int, nargs=3, default=[40, 8, 4])
    parser.add_argument("--trade-modes", type=int, nargs="+", default=[5, 10, 20, 40, 80, 160])
    parser.add_argument("--trade-steps", type=int, default=60)
    parser.add_argument(
        "--trade-tolerances", type=float, nargs="+", help="paper-trade: the modes' tolerances"
    )
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--dump", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(speed_worker(args)))
        return
    if "speed" in args.part:
        speed(args)
    if "peer-accuracy" in args.part:
        peer_accuracy(args)
    if "paper-trade" in args.part:
        tolerances = args.trade_tolerances or [None]
        data = paper_trade(args.trade_elements, args.trade_modes, args.trade_steps, tolerances)
        nx, ny, nz = args.trade_elements
        out = Path(args.out) if args.out else HERE / f"reduced_paper_trade_{nx}x{ny}x{nz}.json"
        out.write_text(json.dumps(data, indent=1))
    if "trade" in args.part:
        data = trade(tuple(args.trade_elements), args.trade_modes, args.trade_steps, 2e-7)
        (HERE / "reduced_trade.json").write_text(json.dumps(data, indent=1))
        chart(data, HERE / "reduced_trade.png")
        print(f"wrote {HERE / 'reduced_trade.json'} and reduced_trade.png")


def peer_accuracy(args) -> None:
    """The peers' displacement against the direct FULL's over a run, per tolerance.

    The bar of ``--trade-elements`` pressed on its wall at the speed benchmark's speed (its
    contact grows every step), FULL direct and each peer at 1e-9 ... 1e-15, one process.
    The direct solve's own accuracy is its distance from the tightest CG's.
    """
    import contextlib

    from mpi4py import MPI

    import iterative_peer
    import numpy as np

    import dd_contact as dd
    from dd_contact.paper.examples import parallelepiped

    def run(label, rtol):
        scene = parallelepiped("FULL", tuple(args.trade_elements), comm=MPI.COMM_SELF)
        with iterative_peer.peer(label, scene, rtol) if label else contextlib.nullcontext():
            problem = dd.TransientProblem(scene, args.dt, "FULL", track_energy=False)
        fields, changes = [], 0
        for _ in range(args.steps):
            changes += problem.advance()["changes"]
            fields.append(np.concatenate(list(problem.solver.finish().values())))
        iterations = getattr(problem.solver, "iterations", [])
        problem.close()
        return np.array(fields), changes, iterations

    full, changes, _ = run(None, None)
    out = {"elements": args.trade_elements, "dt": args.dt, "steps": args.steps}
    out |= {"changes": changes, "peers": {}}
    for label in iterative_peer.PEERS:
        for rtol in (1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14, 1e-15):
            try:
                x, _, iterations = run(label, rtol)
            except dd.InaccurateSolutionError as error:  # the residual check refused it
                out["peers"][f"{label} {rtol:g}"] = {"refused": str(error)[:200]}
                continue
            gap = np.linalg.norm(x - full, axis=1) / np.linalg.norm(full, axis=1)
            out["peers"][f"{label} {rtol:g}"] = {
                "u_difference_vs_full": float(gap.max()),
                "median_iterations": float(np.median(iterations)),
            }
            print(label, rtol, out["peers"][f"{label} {rtol:g}"])
    (HERE / "peer_accuracy.json").write_text(json.dumps(out, indent=1))
    print(f"wrote {HERE / 'peer_accuracy.json'}")


if __name__ == "__main__":
    main()
