"""The paper's efficiency studies with the operation-count model (method.md 6-7, docs/cost.md).

Writes to benchmarks/results/:
* flops_study.json: the Table-2 reports of the bar (400 x 100 x 10, split 5:5, N_TS = 10,000,
  gamma = 20,000) and of the multi-pin joint (all 10 and 2 holes in contact), the pin joint's
  mesh counts, and every study's numbers;
* flops_<study>.png and flops_<study>.json for the studies bar_steps, bar_split, bar_changes,
  bar_contact_elements, pin_steps and pin_holes.

Measured points (later) go in a JSON file {study: {algorithm: [[x, percent_of_full], ...]}}
passed as the first argument; they are drawn as markers on the charts.

Usage: python benchmarks/flops_study.py [measured.json]
"""

import dataclasses
import json
import sys
from pathlib import Path

from dd_contact.paper import flops

RESULTS = Path(__file__).resolve().parent / "results"


def main(measured=None):
    bar = flops.parallelepiped_sizes()
    layout = flops.PinJointLayout()
    studies = flops.parallelepiped_studies() + flops.pin_joint_studies(layout=layout)
    written = flops.write_studies(studies, RESULTS, measured)
    result = {
        "model": "paper's FLOPs model, f1-f4 kernels (method.md section 6, docs/cost.md)",
        "parallelepiped": {
            "scene": flops.scene_to_dict(bar, "400 x 100 x 10 bar, split 5:5"),
            "reports": flops.to_json_dict(flops.compare(bar)),
        },
        "pin_joint": {
            "layout": dataclasses.asdict(layout),
            "mesh": flops.pin_joint_mesh_counts(layout),
            "reports_10_holes": flops.to_json_dict(flops.compare(flops.pin_joint_sizes(10))),
            "reports_2_holes": flops.to_json_dict(flops.compare(flops.pin_joint_sizes(2))),
        },
        "studies": {s.name: s.to_json_dict() for s in studies},
    }
    out = RESULTS / "flops_study.json"
    out.write_text(json.dumps(result, indent=1) + "\n")
    for name, reports in (
        ("bar", result["parallelepiped"]["reports"]),
        ("pin joint, 10 holes", result["pin_joint"]["reports_10_holes"]),
        ("pin joint, 2 holes", result["pin_joint"]["reports_2_holes"]),
    ):
        pct = ", ".join(f"{a} {r['percent_of_full']:.4g} %" for a, r in reports.items())
        print(f"{name}: {pct}")
    print(f"wrote {out} and {len(written)} chart files to {RESULTS}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
