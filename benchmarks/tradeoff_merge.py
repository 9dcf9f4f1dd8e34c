"""One study's JSON from studies run side by side on one scene.

Under a load average of 15 a pin-joint run took 3 minutes of wall time for 14 s of CPU
time; studies in parallel (a second on the knobs the first reaches last, more processes
for combined moves) measured more runs in the same hour. This merges the others' runs
into the first's JSON: a run already measured (the same settings) is left out, another
study's default becomes the default's repeat (the timing's noise), failed runs are kept;
then ``tradeoff.py --charts`` computes the fronts, verdicts and chart again (the pin
joint's errors scored again against its reference).

Usage: python benchmarks/tradeoff_merge.py FIRST.json OTHER.json [OTHER.json ...]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from dd_contact.paper.tradeoff.design import settings_key


def merge(first: dict, second: dict) -> dict:
    """``first`` with the runs of ``second`` it does not hold (a failed run kept)."""
    seen = {settings_key(r["settings"]) for r in first["runs"] if r.get("error") is not None}
    added = 0
    for r in second["runs"]:
        if r.get("error") is None and not r.get("failed"):
            continue
        if r["phase"] == "default":
            r = {**r, "phase": "repeat", "changed": "default, repeated", "default": False}
        elif settings_key(r["settings"]) in seen:
            continue
        first["runs"].append(r)
        seen.add(settings_key(r["settings"]))
        added += 1
    first.setdefault("merged_from", []).append({
        "runs": len(second["runs"]), "added": added,
        "elapsed_seconds": second.get("elapsed_seconds"), "machine": second.get("machine"),
    })  # fmt: skip
    return first


def main(argv: list[str]) -> None:
    first = json.loads(Path(argv[0]).read_text())
    for other in argv[1:]:
        first = merge(first, json.loads(Path(other).read_text()))
    Path(argv[0]).write_text(json.dumps(first, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
