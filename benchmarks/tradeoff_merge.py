"""One study's JSON from two run side by side on one scene (``--only`` knobs in the second).

Under a load average of 15 a pin-joint run took 3 minutes of wall time for 14 s of CPU
time; two studies in parallel (the second on the knobs the first reaches last) measured
twice the runs in the same hour. This merges the second's runs into the first's JSON: a run
already measured (the same settings) is left out, the second's default becomes the
default's repeat (the timing's noise), and the fronts, verdicts and chart are computed
again (``tradeoff.py --charts`` does that too, with the pin joint's errors scored again).

Usage: python benchmarks/tradeoff_merge.py FIRST.json SECOND.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from dd_contact.paper.tradeoff.design import settings_key


def merge(first: dict, second: dict) -> dict:
    """``first`` with the runs of ``second`` it does not hold."""
    seen = {settings_key(r["settings"]) for r in first["runs"] if r.get("error") is not None}
    added = 0
    for r in second["runs"]:
        if r.get("error") is None:
            continue
        if r["phase"] == "default":
            r = {**r, "phase": "repeat", "changed": "default, repeated", "default": False}
        elif settings_key(r["settings"]) in seen:
            continue
        first["runs"].append(r)
        added += 1
    first["merged_from"] = {"second_study_runs": len(second["runs"]), "added": added,
                            "second_elapsed_seconds": second["elapsed_seconds"],
                            "second_machine": second["machine"]}  # fmt: skip
    first["stopped"] = first["stopped"] or second["stopped"]
    return first


def main(argv: list[str]) -> None:
    first, second = (json.loads(Path(p).read_text()) for p in argv)
    Path(argv[0]).write_text(json.dumps(merge(first, second), indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
