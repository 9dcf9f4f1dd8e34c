"""Hertz contact on refining meshes, for both contact schemes (nodes, quadrature points).

Writes benchmarks/results/hertz_convergence.json (and a PNG chart of the errors): for each
mesh size near the pole, the contact radius and peak pressure relative to Hertz's closed form
evaluated with the computed force, the iterations and the wall time.

Run: python benchmarks/hertz_convergence.py [--sizes 0.03 0.02 ...]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

from dd_contact.paper.verify import hertz

HERE = Path(__file__).parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", type=float, nargs="+", default=[0.04, 0.03, 0.02, 0.015, 0.01])
    parser.add_argument("--out", default=str(HERE / "hertz_convergence.json"))
    args = parser.parse_args()
    rows = []
    for points in ("nodes", "quadrature"):
        for h in args.sizes:
            start = time.perf_counter()
            r = hertz(h, points=points, grading=0.1)  # the mesh its JSON was measured on
            seconds = time.perf_counter() - start
            row = {
                "points": points,
                "h_contact": h,
                "dofs": r["dofs"],
                "a_rel_error": r["a"] / r["a_ref"] - 1.0,
                "a_edge_rel_error": r["a_edge"] / r["a_ref"] - 1.0,
                "p_max_rel_error": r["p_max"] / r["p0_ref"] - 1.0,
                "a_over_h": r["a_ref"] / h,
                "iterations": r["iterations"],
                "changes": r["gamma"],
                "seconds": seconds,
            }
            rows.append(row)
            if MPI.COMM_WORLD.rank == 0:
                print(json.dumps(row))
    if MPI.COMM_WORLD.rank == 0:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps({"case": "hertz", "rows": rows}, indent=2))
        _chart(rows, Path(args.out).with_suffix(".png"))


def _chart(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for points, marker in (("nodes", "o"), ("quadrature", "s")):
        sel = [r for r in rows if r["points"] == points]
        h = [r["h_contact"] for r in sel]
        ax.loglog(h, [abs(r["a_rel_error"]) for r in sel], marker + "-", label=f"a, {points}")
        ax.loglog(h, [abs(r["p_max_rel_error"]) for r in sel], marker + "--", label=f"p0, {points}")
    ax.set_xlabel("mesh size near the contact h / R")
    ax.set_ylabel("|relative error| vs Hertz")
    ax.set_title("Hertz: hemisphere on a rigid plane")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
