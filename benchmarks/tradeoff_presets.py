"""The accuracy presets measured on the trade-study scenes (docs/tradeoff.md, "Presets").

For each scene runs ``accuracy="fast" | "balanced" | "reference"`` at the scene's default
mesh, each ``--repeats`` times, interleaved (fast, balanced, reference, fast, ...), each run
in its own process (:func:`dd_contact.paper.tradeoff.study.run_in_process`); then, once
each, the same presets on the meshes a user would pick for the targets (``MESHES``). Writes
``benchmarks/results/tradeoff_presets.json``: every run (its settings, error, error parts,
wall and CPU seconds, peak memory), the medians per preset, their time and error factors
over "balanced", and the machine's load average (``uptime``) before and after.

Usage: python benchmarks/tradeoff_presets.py [--repeats 3] [--scenes hertz bar-impact]
[--no-meshes]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
from pathlib import Path

from dd_contact.accuracy import ACCURACY_PRESETS
from dd_contact.paper.tradeoff import scene
from dd_contact.paper.tradeoff.design import defaults
from dd_contact.paper.tradeoff.study import run_in_process

RESULTS = Path(__file__).parent / "results"

#: What a preset needs to act in each scene (the bar's step and mass left to it).
NEEDS = {"hertz": {}, "bar-impact": {"cfl": None, "mass": None}}

#: Other meshes per scene and preset (``{preset: [changes, ...]}``): hertz's builder takes
#: the preset (``accuracy.mesh_size``: fast at h_contact = 0.02 is h = 0.04 R); the bar's
#: coarser meshes (the cheapest run within 5 %: n = 20 at one wave time), the finer one the
#: reference target needs.
MESHES = {
    "hertz": {"fast": [{"h_contact": 0.02}]},
    "bar-impact": {
        "fast": [{"n": 20}],
        "balanced": [{"n": 20}, {"n": 160}],
        "reference": [{"n": 160}],
    },
}


def _run(name: str, preset: str, changes: dict) -> dict:
    settings = {**defaults(scene(name).knobs), **NEEDS[name], "accuracy": preset, **changes}
    result = run_in_process(name, settings, None)
    print(f"{name} {preset} {changes}: {result.get('error')} {result.get('cpu_seconds')}")
    return {"preset": preset, "changes": changes, "settings": settings, **result}


def _medians(runs: list[dict]) -> dict:
    out: dict = {}
    for preset in ACCURACY_PRESETS:
        mine = [r for r in runs if r["preset"] == preset and not r["changes"] and "error" in r]
        out[preset] = {
            key: statistics.median(r[key] for r in mine)
            for key in ("error", "seconds", "cpu_seconds", "peak_mib")
        }
        out[preset]["runs"] = len(mine)
    for preset in ACCURACY_PRESETS:
        for key in ("error", "seconds", "cpu_seconds"):
            out[preset][f"{key}_factor"] = out[preset][key] / out["balanced"][key]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenes", nargs="+", default=list(NEEDS), choices=list(NEEDS))
    parser.add_argument("--no-meshes", action="store_true", help="the default meshes only")
    args = parser.parse_args()
    doc: dict = {"load_average_before": os.getloadavg(), "cpus": os.cpu_count(), "scenes": {}}
    for name in args.scenes:
        runs = [_run(name, p, {}) for _ in range(args.repeats) for p in ACCURACY_PRESETS]
        if not args.no_meshes:
            for preset, moves in MESHES[name].items():
                runs += [_run(name, preset, changes) for changes in moves]
        doc["scenes"][name] = {"runs": runs, "medians": _medians(runs)}
    doc["load_average_after"] = os.getloadavg()
    out = RESULTS / "tradeoff_presets.json"
    out.write_text(json.dumps(doc, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
