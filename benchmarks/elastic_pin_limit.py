"""The joint with elastic pins tends to the rigid-pin joint as the pins' stiffness grows.

``models.pin_joint(pins="elastic")`` (each pin a steel subdomain held at its ends, in a
contact pair with each of its hole walls) against ``pins="rigid"`` (the paper's
cylinders), both without clearance, pulled statically to the load's peak
(``elastic_pins.towards_rigid``): per E_pin = 210 GPa x 1, 10, 100, each pin's force on the
upper plate and the upper grip end's displacement, relative to the rigid model's; at
several mesh scales, since what is left at E_pin -> infinity is the difference of two
contact discretisations (a pair between faceted surfaces, the wall against a true
cylinder), which shrinks with the mesh.

    python benchmarks/elastic_pin_limit.py      # 3 scales, ~2 min

Writes benchmarks/results/elastic_pin_limit.json and prints a table.
"""

import argparse
import dataclasses
import json
import os
import time
from pathlib import Path

os.environ.update({"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})

from mpi4py import MPI

from dd_contact.paper import models
from dd_contact.paper.models.elastic_pins import towards_rigid

SCALES = ("3,2,1,4", "4,3,2,12", "6,4,2,12")


def layout_of(scale: str):
    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    return dataclasses.replace(models.pin_joint_layout("small"), **counts)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scales", nargs="+", default=list(SCALES), help="c,r,t,grip counts")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    start = time.perf_counter()
    results = {}
    for scale in args.scales:
        tic = time.perf_counter()
        results[scale] = towards_rigid(layout_of(scale), comm=MPI.COMM_SELF)
        results[scale]["seconds"] = time.perf_counter() - tic
    report = {"scales": results, "seconds": time.perf_counter() - start}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "elastic_pin_limit.json").write_text(json.dumps(report, indent=1))
    print(f"{'scale':<10}{'E_pin / 210 GPa':>16}{'pin forces':>12}{'grip end u':>12}")
    for scale, r in results.items():
        for row in r["rows"]:
            print(
                f"{scale:<10}{row['factor']:>16g}{100 * row['force_difference']:>11.2f}%"
                f"{100 * row['u_difference']:>+11.2f}%"
            )


if __name__ == "__main__":
    main()
