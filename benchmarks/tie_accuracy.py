"""Accuracy of the penalty tie over the penalty range and under mesh refinement.

Writes benchmarks/results/tie_accuracy.json:
* patch test (non-matching hexahedra, quadrilateral or triangular interface): worst stress
  error relative to the traction for kappa = 1e2 ... 1e12;
* bent bar, matching meshes: tip-deflection difference from one conforming mesh vs kappa;
* bent bar, non-matching meshes: the same difference vs refinement (kappa = 1e7).

Usage: python benchmarks/tie_accuracy.py
"""

import json
from pathlib import Path

import numpy as np

from dd_contact.paper import verify

KAPPAS = [1e2, 1e4, 1e6, 1e8, 1e10, 1e12]


def main():
    result = {"patch": {}, "bent_bar_kappa": [], "bent_bar_refinement": []}
    for cell in ("quadrilateral", "triangle"):
        result["patch"][cell] = [
            {"kappa": k, "max_rel_stress_error": verify.patch_test(k, cell)} for k in KAPPAS
        ]
    for kappa in KAPPAS:
        tied, single = verify.bent_bar(1, kappa, matching=True)
        result["bent_bar_kappa"].append({"kappa": kappa, "rel_diff": abs(tied / single - 1)})
    for r in (1, 2, 3, 4):
        tied, single = verify.bent_bar(r, 1e7, matching=False)
        result["bent_bar_refinement"].append(
            {"refinement": r, "h": 0.5 / r, "rel_diff": abs(tied / single - 1)}
        )
    ref = result["bent_bar_refinement"]
    result["bent_bar_mesh_rate"] = float(
        np.polyfit(np.log([e["h"] for e in ref]), np.log([e["rel_diff"] for e in ref]), 1)[0]
    )
    kap = result["bent_bar_kappa"][:3]
    result["bent_bar_kappa_rate"] = float(
        np.polyfit(np.log10([e["kappa"] for e in kap]), np.log10([e["rel_diff"] for e in kap]), 1)[
            0
        ]
    )
    out = Path(__file__).parent / "results" / "tie_accuracy.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
