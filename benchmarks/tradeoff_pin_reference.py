"""The reference of the trade-study scene ``pin-joint`` and its own error (Richardson).

Runs the pin joint (:mod:`dd_contact.paper.tradeoff.pin`) at cells (3, 2, 1, 4) and
dt = 4 us, (6, 4, 2, 8) at 2 us and (12, 8, 4, 16) at 1 us (every cell count and the step
halved together), the rest at the scene's defaults; writes
``benchmarks/results/tradeoff_pin-joint_reference.json`` after each run (its forces,
windows, CPU seconds, the load average; the Richardson estimate at the end) and prints the
finest run's windows, the numbers ``pin.REFERENCE`` holds.

Usage: python benchmarks/tradeoff_pin_reference.py
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from dd_contact.paper.tradeoff import scene
from dd_contact.paper.tradeoff.design import defaults
from dd_contact.paper.tradeoff.pin import WINDOW, pin_forces
from dd_contact.paper.tradeoff.tilted import richardson, windows

LEVELS = (((3, 2, 1, 4), 4e-6), ((6, 4, 2, 8), 2e-6), ((12, 8, 4, 16), 1e-6))
OUT = Path(__file__).parent / "results" / "tradeoff_pin-joint_reference.json"


def main() -> None:
    base = defaults(scene("pin-joint").knobs)
    doc: dict = {"load_average_before": os.getloadavg(), "window": WINDOW, "runs": []}
    for elements, dt in LEVELS:
        cpu, wall = time.process_time(), time.perf_counter()
        step, forces, changes = pin_forces({**base, "elements": list(elements), "dt": dt})
        doc["runs"].append({
            "elements": elements, "dt": step, "changes": changes,
            "cpu_seconds": time.process_time() - cpu, "seconds": time.perf_counter() - wall,
            "load_average": os.getloadavg(), "forces": forces.tolist(),
            "windows": windows(step, forces, WINDOW).tolist(),
        })  # fmt: skip
        OUT.write_text(json.dumps(doc, indent=1))
        print(elements, dt, f"{time.process_time() - cpu:.1f} s CPU", flush=True)
    runs = [(r["dt"], np.asarray(r["forces"])) for r in doc["runs"]]
    doc["richardson"] = richardson(runs, WINDOW)
    doc["load_average_after"] = os.getloadavg()
    OUT.write_text(json.dumps(doc, indent=1))
    print(doc["richardson"])


if __name__ == "__main__":
    main()
