"""The paper's cost ordering on the multi-pin joint: which algorithm is cheapest per contact
change when 2 holes are in contact, and when all 10.

Kim, Ryu and Shin (method.md 7.2) found w-v-u / w-u cheapest with 2 holes in contact and
v-w-u with all 10. As in their count (docs/cost.md, "holes in contact"), only the holes in
contact carry a contact interface: the variant "2 holes" has contact interfaces on pin 2's
two hole walls (upper and lower plate), "all 10" on every wall. Both plates are pulled
(models.pin_joint's default load path), so every contact interface bears. Every algorithm
that fits (FULL, v-w-u, w-v-u; w-u needs a model without an interface) runs each variant
``--repeats`` times from a fresh scene, the repeats interleaved. From each run: the time
per step without a contact change (median of those steps) and per contact change (the
steps with changes, less that per-step time, per change); reported are the medians over
the repeats, beside the operation-count model's GFLOPs per step and per change
(dd_contact.paper.flops, the same scene and changes).

    python benchmarks/pin_joint_ordering.py                       # 6,4,2,12: 5-13 min here
    python benchmarks/pin_joint_ordering.py --scale small --repeats 1  # ~1 min
    python benchmarks/pin_joint_ordering.py --scale 8,8,4,36 --repeats 2  # 88,710 dofs: 13 min

Writes benchmarks/results/pin_joint_ordering.json (the default scale; another scale's file
is named after it, e.g. pin_joint_ordering_8,8,4,36.json) and prints a table.
"""

import argparse
import dataclasses
import json
import platform
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import numpy as np

from dd_contact.errors import ContactCycleWarning
from dd_contact.paper import compare, models

ALGORITHMS = ("FULL", "v-w-u", "w-v-u")
DT, PERIOD, LOAD, CLEARANCE = 4e-5, 2e-3, 20e3, 0.05e-3  # as demos/demo_pin_joint.py
DEFAULT_SCALE = "6,4,2,12"
VARIANTS = {"2 holes": [2], "all 10": [0, 1, 2, 3, 4]}  # pins with contact interfaces


def result_name(scale: str) -> str:
    """The JSON file of a run at ``scale``."""
    suffix = "" if scale == DEFAULT_SCALE else f"_{scale}"
    return f"pin_joint_ordering{suffix}.json"


def layout_of(scale: str):
    if scale in models.PIN_JOINT_SCALES:
        return models.pin_joint_layout(scale)
    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    return dataclasses.replace(models.pin_joint_layout("small"), **counts)


def measure(run: compare.Run) -> dict:
    """Time per step without changes and per contact change of one run [s]."""
    changes = np.array([r["changes"] for r in run.history])
    quiet = run.step_seconds[changes == 0]
    busy = run.step_seconds[changes > 0]
    per_step = float(np.median(quiet)) if quiet.size else float("nan")
    extra = float(busy.sum() - per_step * busy.size)
    return {
        "seconds": run.seconds,
        "per_step": per_step,
        "per_change": extra / changes.sum() if changes.sum() else float("nan"),
        "changes": int(changes.sum()),
    }


def model_costs(scene, steps: int, changes: dict) -> dict:
    """The operation-count model's GFLOPs: in all, per step, per contact change."""
    quiet = {name: 0 for name in changes}
    total = compare.model_gflops(scene, steps, changes)
    no_change = compare.model_gflops(scene, steps, quiet)
    one_step = compare.model_gflops(scene, 1, quiet)
    return {
        a: {
            "total": total[a],
            "per_step": (no_change[a] - one_step[a]) / max(steps - 1, 1),
            "per_change": (total[a] - no_change[a]) / max(changes["gamma"], 1),
        }
        for a in ALGORITHMS
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scale", default=DEFAULT_SCALE, help="small, paper or c,r,t,grip rows")
    parser.add_argument("--steps", type=int, default=24, help="7 quiet steps, then impacts")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    layout = layout_of(args.scale)
    warnings.simplefilter("ignore", ContactCycleWarning)
    start = time.perf_counter()
    results = {}
    for variant, pins in VARIANTS.items():

        def joint(pins=pins):
            return models.pin_joint(
                layout, clearance=CLEARANCE, load=LOAD, period=PERIOD, contact_pins=pins
            )

        # Repeats interleaved (FULL, v-w-u, w-v-u, FULL, ...): a load that drifts on this
        # shared machine then falls on every algorithm alike.
        runs = {algorithm: [] for algorithm in ALGORITHMS}
        for _ in range(args.repeats):
            for algorithm in ALGORITHMS:
                runs[algorithm].append(
                    compare.run_algorithm(joint, algorithm, DT, args.steps, variant)
                )
        full_changes = runs["FULL"][0].changes
        rows = {}
        for algorithm in ALGORITHMS:
            measured = [measure(r) for r in runs[algorithm]]
            rows[algorithm] = {
                key: float(np.median([m[key] for m in measured]))
                for key in ("seconds", "per_step", "per_change")
            }
            rows[algorithm]["changes"] = [m["changes"] for m in measured]
            rows[algorithm]["runs_per_change"] = [m["per_change"] for m in measured]
            rows[algorithm]["factorisations"] = runs[algorithm][0].factorisations
            rows[algorithm]["substitutions"] = runs[algorithm][0].substitutions
        scene = joint()
        model = model_costs(scene, args.steps, full_changes)
        for algorithm in ALGORITHMS:
            rows[algorithm]["model_gflops"] = model[algorithm]
        orders = ALGORITHMS[1:]
        results[variant] = {
            "contact_interfaces": [c.name for c in scene.contacts],
            "contact_dofs": sum(c.num_dofs for c in scene.contacts),
            "interface_dofs": scene.interface.num_dofs,
            "dofs": sum(s.num_dofs for s in scene.subdomains),
            "full_changes": dict(full_changes),
            "cheapest_order_measured": min(orders, key=lambda a: rows[a]["per_change"]),
            "cheapest_order_model": min(orders, key=lambda a: model[a]["per_change"]),
            **rows,
        }
    if MPI.COMM_WORLD.rank == 0:
        report = {
            "scale": args.scale,
            "steps": args.steps,
            "dt": DT,
            "repeats": args.repeats,
            "ranks": MPI.COMM_WORLD.size,
            "machine": platform.node(),
            "seconds": time.perf_counter() - start,
            "variants": results,
            "paper": "w-v-u/w-u cheapest with 2 holes in contact, v-w-u with all 10",
        }
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / result_name(args.scale)).write_text(json.dumps(report, indent=1))
        print(f"pin joint {args.scale}, {args.steps} steps, medians of {args.repeats}")
        print(
            f"{'variant':<9}{'algorithm':<10}{'changes':>8}{'per change [ms]':>17}"
            f"{'per step [ms]':>15}{'model GFLOP/change':>20}{'model GFLOP/step':>18}"
        )
        for variant, rows in results.items():
            for algorithm in ALGORITHMS:
                r = rows[algorithm]
                print(
                    f"{variant:<9}{algorithm:<10}{r['changes'][0]:>8}"
                    f"{1e3 * r['per_change']:>17.1f}{1e3 * r['per_step']:>15.1f}"
                    f"{r['model_gflops']['per_change']:>20.3g}"
                    f"{r['model_gflops']['per_step']:>18.3g}"
                )
            print(
                f"  {variant}: cheapest order per change, measured "
                f"{rows['cheapest_order_measured']}, model {rows['cheapest_order_model']}"
            )
        print(f"wall time {report['seconds']:.0f} s")


if __name__ == "__main__":
    main()
