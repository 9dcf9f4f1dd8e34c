"""decompose + auto against the hand-built decompositions of the parallelepiped (issue 26).

The bar of ``benchmarks/decomposition_speed.py`` (1 mm hexahedra, 120 x 18 x 6 by default:
49k dofs) moves at 1 m/s onto a wall tilted by 5e-4 rad while 20 MPa (ramped over 10 us)
push its far end; 8 steps of 1 us. Hand-built: ``dd_contact.paper.examples.parallelepiped``
for each named algorithm in its layout (FULL on one mesh with contact on the end face, w-v-u
and v-w-u cut 5:5 with matching interface and contact meshes, w-u one mesh with a contact
interface) and auto on the w-v-u scene. Decomposed: the same bar as one mesh,
``dd_contact.decompose`` with the end face as candidate (default ``parts="auto"``: the end in
a small part), run with ``algorithm="auto"`` (and w-v-u), auto told the run's length and
1.25 changes a step (as ``benchmarks/auto_choice.py``); and decomposed into two parts by
bisection (5:5, as the hand-built w-v-u scene) with w-v-u. Each run is its own process with
BLAS on one thread, the cases interleaved; the whole run (scene, set-up, steps) is timed,
wall and CPU (and the kernel's part of the CPU), with its parts (scene, set-up) and peak
memory; medians of ``--repeats``; the machine's load average before and after each round.

Writes benchmarks/results/decompose_vs_hand.json; ``decomposed_over_best_hand_built`` (the
medians' ratio, wall) is the issue's target (<= 1.15); ``..._cpu`` the same by CPU time.

Run: python benchmarks/decompose_vs_hand.py [--elements 120 18 6] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import resource
import statistics
import time
import warnings
from pathlib import Path

DT, STEPS, SPEED, TILT, PRESSURE, RAMP, H = 1e-6, 8, 1.0, 5e-4, 2.0e7, 1e-5, 1e-3


def _decomposed(elements, parts="auto"):
    from mpi4py import MPI

    import numpy as np

    import dd_contact as dc
    from dd_contact import meshes
    from dd_contact.paper.models.common import STEEL

    length = elements[0] * H
    bar = meshes.box(MPI.COMM_SELF, [0, 0, 0], [n * H for n in elements], elements)
    wall = dc.Plane([0.0, 0.0, 0.0], [np.cos(TILT), np.sin(TILT), 0.0])
    end = dc.ContactCandidate(lambda x: np.isclose(x[0], 0.0), wall, name="end", contact_kappa=1.0)
    scene = dc.decompose(bar, STEEL, parts, contacts=[end], margin=1e-3, comm=MPI.COMM_SELF)
    for sub in scene.subdomains:
        sub.velocity.interpolate(lambda x: np.vstack([-SPEED + 0 * x[0], 0 * x[0], 0 * x[0]]))
    scene.add_traction(
        lambda x: np.isclose(x[0], length), lambda t: [-PRESSURE * min(t / RAMP, 1.0), 0.0, 0.0]
    )
    return scene


def worker(kind, algorithm, elements, queue):
    """One whole run in this process: ``kind`` is "hand" or "decomposed"."""
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    from mpi4py import MPI

    import dd_contact as dc
    from dd_contact.paper.examples import parallelepiped

    start, cpu = time.perf_counter(), time.process_time()
    kernel = resource.getrusage(resource.RUSAGE_SELF).ru_stime  # of it, in the kernel
    if kind == "hand":
        layout = "w-v-u" if algorithm == "auto" else algorithm  # auto: on the w-v-u scene
        scene = parallelepiped(layout, tuple(elements), comm=MPI.COMM_SELF)
    else:  # "decomposed": the auto cut; "decomposed 5:5": two parts by bisection
        scene = _decomposed(elements, 2 if kind == "decomposed 5:5" else "auto")
    scene_seconds, scene_cpu = time.perf_counter() - start, time.process_time() - cpu
    expected = {"expected_steps": STEPS, "expected_changes": 1.25 * STEPS}
    options = expected if algorithm == "auto" else {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with dc.TransientProblem(
            scene, DT, algorithm=algorithm, track_energy=False, **options
        ) as problem:
            setup_seconds = time.perf_counter() - start - scene_seconds
            setup_cpu = time.process_time() - cpu - scene_cpu
            problem.run(STEPS)
            chosen, changes = problem.algorithm, problem.changes["gamma"]
            work = {b: w["decompositions"] for b, w in problem.work_summary().items()}
    queue.put(
        {
            "kind": kind,
            "algorithm": algorithm,
            "chosen": chosen,
            "changes": changes,
            "whole_run_seconds": time.perf_counter() - start,
            "cpu_seconds": time.process_time() - cpu,
            "scene_seconds": scene_seconds,
            "setup_seconds": setup_seconds,
            "scene_cpu_seconds": scene_cpu,
            "setup_cpu_seconds": setup_cpu,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "kernel_cpu_seconds": resource.getrusage(resource.RUSAGE_SELF).ru_stime - kernel,
            "parts": len(scene.subdomains),
            "interface_dofs": 0
            if scene.interface is None
            else 3 * len(scene.interface.mesh.geometry.x),
            "decompositions": work,
        }
    )


def run(kind, algorithm, elements):
    queue = multiprocessing.get_context("spawn").Queue()
    process = multiprocessing.get_context("spawn").Process(
        target=worker, args=(kind, algorithm, elements, queue)
    )
    process.start()
    process.join()
    if process.exitcode != 0:
        raise RuntimeError(f"the run {kind} {algorithm} failed (exit code {process.exitcode})")
    return queue.get()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs=3, default=[120, 18, 6])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    hand = ("FULL", "w-v-u", "w-u", "v-w-u", "auto")
    cases = [("hand", a) for a in hand] + [("decomposed", "auto"), ("decomposed", "w-v-u")]
    cases.append(("decomposed 5:5", "w-v-u"))  # where the auto cut's time goes
    runs, load = [], [os.getloadavg()]
    for _ in range(args.repeats):
        for kind, algorithm in cases:
            runs.append(run(kind, algorithm, args.elements))
            r = runs[-1]
            print(
                f"{kind:10s} {algorithm:6s} -> {r['chosen']:6s} {r['whole_run_seconds']:7.2f} s"
                f" (CPU {r['cpu_seconds']:6.2f} s, scene {r['scene_seconds']:5.2f} s, "
                f"set-up {r['setup_seconds']:5.2f} s)"
            )
        load.append(os.getloadavg())
    median = {}
    for kind, algorithm in cases:
        mine = [r for r in runs if (r["kind"], r["algorithm"]) == (kind, algorithm)]
        keys = ("whole_run_seconds", "cpu_seconds", "scene_seconds", "setup_seconds")
        keys += ("scene_cpu_seconds", "setup_cpu_seconds", "kernel_cpu_seconds", "peak_rss_mb")
        median[f"{kind} {algorithm}"] = {k: statistics.median(r[k] for r in mine) for k in keys}
    ratios = {}
    for measure in ("whole_run_seconds", "cpu_seconds"):
        hand_best = min(v[measure] for k, v in median.items() if k.startswith("hand"))
        ratios[measure] = median["decomposed auto"][measure] / hand_best
    print(
        f"decomposed auto / best hand-built (medians): wall {ratios['whole_run_seconds']:.3f},"
        f" CPU {ratios['cpu_seconds']:.3f}"
    )
    out = {
        "elements": args.elements,
        "steps": STEPS,
        "repeats": args.repeats,
        "runs": runs,
        "median": median,
        "decomposed_over_best_hand_built": ratios["whole_run_seconds"],
        "decomposed_over_best_hand_built_cpu": ratios["cpu_seconds"],
        "load_average": load,
        "cores": os.cpu_count(),
    }
    path = Path(__file__).parent / "results" / "decompose_vs_hand.json"
    path.write_text(json.dumps(out, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
