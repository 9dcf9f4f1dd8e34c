"""How fine a bar reaches the 0.1 % contact duration of issue 25's "reference" target.

At one wave time per step (CFL 1) the bar's computed contact duration is 2 L / c plus one
step, h / c (n = 10 ... 160 in ``tradeoff_bar-impact.json``: +1 / (2 n) exactly), so 0.1 %
needs n >= 500. Runs :func:`dd_contact.paper.verify.bar_impact` (split, the trade scene's
settings) at the given n and presets, one process, one BLAS thread; writes
``benchmarks/results/tradeoff_bar_duration.json`` (duration and plateau errors, CPU seconds,
steps, the load average) after each run.

Usage: python benchmarks/tradeoff_bar_duration.py [--n 500 640] [--accuracy balanced]
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
    parser.add_argument("--n", type=int, nargs="+", default=[500, 640])
    parser.add_argument("--accuracy", nargs="+", default=["balanced"])
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
                "plateau_force": result["parts"]["plateau_force"],
                "steps": result["parts"]["steps"], "cpu_seconds": time.process_time() - cpu,
                "load_average": [load, os.getloadavg()[0]],
            })  # fmt: skip
            OUT.write_text(json.dumps(doc, indent=1))
            print(doc["runs"][-1], flush=True)


if __name__ == "__main__":
    main()
