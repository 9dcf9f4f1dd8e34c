"""Where the time of a "fast" and a "balanced" run goes: set-up or solving (issue 25's 5x).

Runs the trade scenes' default settings of ``bar-impact`` (n = 40 and n = 10, each at the
presets "fast" and "balanced": their step and mass) and ``hertz`` (h = 0.015 R, the
default, and 0.03 R: the static preset sets nothing), each setting three times,
interleaved, each run in its own process with one BLAS thread, and splits each run's CPU
seconds into: the mesh and the scene (bar: ``_impact_bar``; hertz: ``meshes.hemisphere``
with gmsh), the problem's set-up (``TransientProblem`` / ``StaticProblem``: assembly), the
first step or the static solve's first solve (the first factorisation), and the rest of the
stepping or the contact iterations. Writes ``benchmarks/results/tradeoff_setup.json`` (every
run, the medians, the load average).

Usage: python benchmarks/tradeoff_setup.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from pinned import pinned_record

OUT = Path(__file__).parent / "results" / "tradeoff_setup.json"
SETTINGS = [("bar-impact", n, p) for n in (40, 10) for p in ("balanced", "fast")] + [
    ("hertz", h, "balanced") for h in (0.015, 0.03)
]


def _timed(spent: dict, name: str, function):
    """``function`` with its CPU seconds added to ``spent[name]`` (nested calls excluded)."""

    def wrapper(*args, **kwargs):
        start = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent[name] += time.process_time() - start

    return wrapper


def one(name: str, size: float, preset: str) -> dict:
    """One run in this process: its CPU seconds by phase and its error."""
    import dd_contact.paper.verify.bar as bar
    import dd_contact.paper.verify.models as models
    from dd_contact.paper.tradeoff import scene
    from dd_contact.paper.tradeoff.design import defaults
    from dd_contact.problem import StaticProblem, TransientProblem

    spent: dict[str, float] = defaultdict(float)
    bar._impact_bar = _timed(spent, "mesh and scene", bar._impact_bar)
    models.meshes.hemisphere = _timed(spent, "mesh and scene", models.meshes.hemisphere)
    for cls in (TransientProblem, StaticProblem):
        cls.__init__ = _timed(spent, "problem set-up", cls.__init__)
    first = {"done": False}
    advance, solve_at = TransientProblem._advance, StaticProblem._solve_at

    def stepped(self, *args, **kwargs):
        phase = "stepping" if first["done"] else "first step"
        first["done"] = True
        return _timed(spent, phase, advance)(self, *args, **kwargs)

    TransientProblem._advance = stepped
    StaticProblem._solve_at = _timed(spent, "solve", solve_at)
    trade = scene(name)
    settings = defaults(trade.knobs)
    if name == "bar-impact":
        settings.update(n=int(size), accuracy=preset, cfl=None, mass=None)
    else:
        settings.update(h_contact=size)
    start = time.process_time()
    result = trade.measure(settings)
    total = time.process_time() - start
    return {"scene": name, "size": size, "accuracy": preset, "cpu": total,
            "error": result["error"], **dict(spent),
            "other": total - sum(spent.values())}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one(args.one[0], float(args.one[1]), args.one[2])))
        return
    doc: dict = {"load_average_before": os.getloadavg(), "runs": []}
    for _ in range(args.repeats):
        for name, size, preset in SETTINGS:
            command = [sys.executable, "-W", "ignore", __file__, "--one", name, repr(size), preset]
            doc["runs"].append(pinned_record(command))
            print(doc["runs"][-1], flush=True)
    doc["load_average_after"] = os.getloadavg()
    doc["medians"] = []
    for name, size, preset in SETTINGS:
        mine = [r for r in doc["runs"] if (r["scene"], r["size"], r["accuracy"]) ==
                (name, size, preset)]  # fmt: skip
        keys = {k for r in mine for k, v in r.items() if isinstance(v, float)}
        doc["medians"].append({"scene": name, "size": size, "accuracy": preset,
                               **{k: float(np.median([r.get(k, 0.0) for r in mine]))
                                  for k in sorted(keys)}})  # fmt: skip
    OUT.write_text(json.dumps(doc, indent=1))
    for m in doc["medians"]:
        print(m)


if __name__ == "__main__":
    main()
