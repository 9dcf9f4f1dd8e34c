"""At which resolution the bar meets issue 25's 0.1 % "reference" target (duration, plateau).

Two readings of the contact duration on the same runs: ``duration``, when the contact force
last falls through half its plateau, interpolated between steps (the middle of the release
ramp the mesh spreads over several elements: what a user reads off the force history), and
``parting``, when the end face's gap opens (the ramp's end: at one wave time a step, 2 L / c
plus one step up to n = 160 and two at n = 320 and 500). Runs
:func:`dd_contact.paper.verify.bar_impact` (split, the trade scene's settings) at each n and
preset, interleaved, one process, one BLAS thread; writes
``benchmarks/results/tradeoff_bar_duration.json`` (both readings' and the plateau's errors,
CPU seconds, steps, the load average) after each run.

Usage: OMP_NUM_THREADS=1 python benchmarks/tradeoff_bar_duration.py [--n 40 80 160 320]
    [--accuracy balanced reference]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from dd_contact.paper.tradeoff import scene
from dd_contact.paper.tradeoff.design import defaults

OUT = Path(__file__).parent / "results" / "tradeoff_bar_duration.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, nargs="+", default=[40, 80, 160, 320])
    parser.add_argument("--accuracy", nargs="+", default=["balanced", "reference"])
    args = parser.parse_args()
    trade = scene("bar-impact")
    doc: dict = {"runs": []}
    for n in args.n:
        for preset in args.accuracy:
            settings = {**defaults(trade.knobs), "n": n, "accuracy": preset}
            if preset != "balanced":  # the step and the mass are the preset's
                settings.update(cfl=None, mass=None)
            load, cpu = os.getloadavg()[0], time.process_time()
            result = trade.measure(settings)
            doc["runs"].append({
                "n": n, "accuracy": preset, "error": result["error"],
                "duration": result["parts"]["duration"],
                "parting": result["parts"]["parting"],
                "plateau_force": result["parts"]["plateau_force"],
                "steps": result["parts"]["steps"], "cpu_seconds": time.process_time() - cpu,
                "load_average": [load, os.getloadavg()[0]],
            })  # fmt: skip
            OUT.write_text(json.dumps(doc, indent=1))
            print(doc["runs"][-1], flush=True)


if __name__ == "__main__":
    main()
