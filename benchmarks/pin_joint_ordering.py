"""The paper's cost ordering on the multi-pin joint: which algorithm is cheapest per contact
change and per step when 2 pins are struck, and when all 5.

Kim, Ryu and Shin (method.md 7.2) found w-v-u / w-u cheapest with 2 holes in contact and
v-w-u with all 10. Here the pins are rigid and fixed, so only the upper plate's 5 hole walls
can take load (the lower plate is clamped and nothing pushes it onto its pins): the variants
are the upper plate striking 2 pins (the other 3 with 1 mm clearance) and all 5 (0.05 mm
each). Every algorithm that fits (FULL, v-w-u, w-v-u) runs each variant ``--repeats`` times
from a fresh scene; reported are medians of the total time, of the time per contact change
(steps with changes minus steps without, per change) and per step without changes, beside
the operation-count model's GFLOPs (dd_contact.flops).

    python benchmarks/pin_joint_ordering.py --scale 8,8,4,36 --steps 30   # 88,710 dofs
    python benchmarks/pin_joint_ordering.py --scale small --steps 30      # 10,674 dofs

Writes benchmarks/results/pin_joint_ordering_<scale>.json and prints a table.
"""

import argparse
import dataclasses
import json
import platform
import warnings
from pathlib import Path

from mpi4py import MPI

import numpy as np

from dd_contact import compare, models
from dd_contact.errors import ContactCycleWarning

ALGORITHMS = ("FULL", "v-w-u", "w-v-u")
DT, PERIOD, LOAD = 4e-5, 2e-3, 20e3  # as demos/demo_pin_joint.py
VARIANTS = {  # clearance of each pin [m]
    "2 pins": (1e-3, 0.05e-3, 1e-3, 0.05e-3, 1e-3),
    "5 pins": (0.05e-3,) * 5,
}


def layout_of(scale: str):
    if scale in models.PIN_JOINT_SCALES:
        return models.pin_joint_layout(scale)
    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    return dataclasses.replace(models.pin_joint_layout("small"), **counts)


def measure(run: compare.Run) -> dict:
    changes = np.array([r["changes"] for r in run.history])
    quiet = run.step_seconds[changes == 0]
    busy = run.step_seconds[changes > 0]
    per_step = float(np.median(quiet)) if quiet.size else float("nan")
    extra = float(busy.sum() - per_step * busy.size) if busy.size else 0.0
    return {
        "seconds": run.seconds,
        "per_step": per_step,
        "per_change": extra / changes.sum() if changes.sum() else float("nan"),
        "changes": int(changes.sum()),
        "walls_in_contact": sorted(n for n, k in run.changes.items() if n != "gamma" and k),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scale", default="small", help="small, paper or c,r,t,grip rows")
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    layout = layout_of(args.scale)
    warnings.simplefilter("ignore", ContactCycleWarning)
    results = {}
    for variant, clearance in VARIANTS.items():

        def joint(clearance=clearance):
            return models.pin_joint(layout, clearance=clearance, load=LOAD, period=PERIOD)

        rows = {}
        for algorithm in ALGORITHMS:
            runs = [
                compare.run_algorithm(joint, algorithm, DT, args.steps, variant)
                for _ in range(args.repeats)
            ]
            measured = [measure(r) for r in runs]
            rows[algorithm] = {
                key: float(np.median([m[key] for m in measured]))
                for key in ("seconds", "per_step", "per_change")
            }
            rows[algorithm]["changes"] = measured[0]["changes"]
            rows[algorithm]["walls_in_contact"] = measured[0]["walls_in_contact"]
            rows[algorithm]["runs_seconds"] = [m["seconds"] for m in measured]
            full_changes = runs[0].changes
        scene = joint()
        gflops = compare.model_gflops(scene, args.steps, full_changes)
        for algorithm in ALGORITHMS:
            rows[algorithm]["model_gflops"] = gflops[algorithm]
        dofs = sum(s.num_dofs for s in scene.subdomains)
        cheapest = min(ALGORITHMS, key=lambda a: rows[a]["seconds"])
        results[variant] = {"clearance": clearance, "dofs": dofs, "cheapest": cheapest, **rows}
    if MPI.COMM_WORLD.rank == 0:
        report = {
            "scale": args.scale,
            "steps": args.steps,
            "dt": DT,
            "repeats": args.repeats,
            "ranks": MPI.COMM_WORLD.size,
            "machine": platform.node(),
            "variants": results,
            "paper": "w-v-u/w-u cheapest with 2 holes in contact, v-w-u with all 10",
        }
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        name = args.scale.replace(",", "-")
        (out / f"pin_joint_ordering_{name}.json").write_text(json.dumps(report, indent=1))
        print(f"pin joint {args.scale}, {args.steps} steps, medians of {args.repeats}")
        print(
            f"{'variant':<8}{'algorithm':<8}{'changes':>8}{'time [s]':>10}{'per step [ms]':>15}"
            f"{'per change [ms]':>17}{'model GFLOP':>13}"
        )
        for variant, rows in results.items():
            for algorithm in ALGORITHMS:
                r = rows[algorithm]
                print(
                    f"{variant:<8}{algorithm:<8}{r['changes']:>8}{r['seconds']:>10.2f}"
                    f"{1e3 * r['per_step']:>15.1f}{1e3 * r['per_change']:>17.1f}"
                    f"{r['model_gflops']:>13.3g}"
                )
            print(
                f"  {variant}: cheapest measured {rows['cheapest']}, walls in contact "
                f"{rows['FULL']['walls_in_contact']}"
            )


if __name__ == "__main__":
    main()
