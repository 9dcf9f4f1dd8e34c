"""The reference of the trade-study scene ``tilted-wall`` and its own error (Richardson).

Runs the parallelepiped on the tilted wall (:mod:`dd_contact.paper.tradeoff.tilted`) at
(20, 5, 1) hexahedra and dt = 100 us, (40, 10, 2) at 50 us and (80, 20, 4) at 25 us (mesh and
step halved together), the rest at the scene's defaults; writes
``benchmarks/results/tradeoff_tilted-wall_reference.json`` (each run's forces, windows, CPU
seconds, the Richardson estimate) and prints the finest run's windows, the numbers
``tilted.REFERENCE`` holds.

Usage: python benchmarks/tradeoff_tilted_reference.py
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from dd_contact.paper.tradeoff import scene
from dd_contact.paper.tradeoff.design import defaults
from dd_contact.paper.tradeoff.tilted import richardson, wall_forces, windows

LEVELS = (((20, 5, 1), 1e-4), ((40, 10, 2), 5e-5), ((80, 20, 4), 2.5e-5))
OUT = Path(__file__).parent / "results" / "tradeoff_tilted-wall_reference.json"


def main() -> None:
    base = defaults(scene("tilted-wall").knobs)
    doc: dict = {"load_average_before": os.getloadavg(), "runs": []}
    for elements, dt in LEVELS:
        cpu = time.process_time()
        step, forces, changes = wall_forces({**base, "elements": list(elements), "dt": dt})
        doc["runs"].append({
            "elements": elements, "dt": step, "changes": changes,
            "cpu_seconds": time.process_time() - cpu, "forces": forces.tolist(),
            "windows": windows(step, forces).tolist(),
        })  # fmt: skip
        print(elements, dt, f"{time.process_time() - cpu:.1f} s CPU", flush=True)
    runs = [(r["dt"], np.asarray(r["forces"])) for r in doc["runs"]]
    doc["richardson"] = richardson(runs)
    doc["load_average_after"] = os.getloadavg()
    OUT.write_text(json.dumps(doc, indent=1))
    print(doc["richardson"])
    print("windows:", [round(w, 3) for w in doc["runs"][-1]["windows"]])


if __name__ == "__main__":
    main()
