"""Impact: energy, rebound and contact duration of the bar, classic and energy-safe steps.

Runs :func:`dd_contact.verify.bar_impact` (an elastic bar at 0.01 c onto a rigid wall, the
1-D wave solution: contact for 2L/c, rebound at -v0, energy kept) with the default contact
penalty, for both time-stepping rules (``energy_safe_contact=False``: the paper's classic
trapezoidal contact; ``True``: the package's default, ``dd_contact.impact``), over CFL 0.1 ... 1
and 40 ... 160 elements, and writes

* ``benchmarks/results/impact_energy.json``: one record per run (elements, CFL, rule, energy
  after / before, rebound / v0, duration / (2L/c), contact state changes, seconds);
* ``benchmarks/results/impact_energy.png``: energy ratio and rebound vs CFL, one line per rule
  and mesh.

Consistent mass only (lumped mass is not an option yet). See docs/contact.md, "Impact".

Usage: python benchmarks/impact_energy.py
"""

from __future__ import annotations

import json
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dd_contact import verify

RESULTS = Path(__file__).parent / "results"
CFLS = (0.1, 0.25, 0.5, 1.0)
ELEMENTS = (40, 80, 160)
RULES = {False: "classic", True: "energy-safe"}


def run() -> list[dict]:
    records = []
    for safe, rule in RULES.items():
        for n in ELEMENTS:
            for cfl in CFLS:
                start = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # the classic rule's EnergyGrowthWarning
                    r = verify.bar_impact(
                        n=n, cfl=cfl, energy_safe_contact=safe, comm=MPI.COMM_SELF
                    )
                records.append(
                    {
                        "rule": rule,
                        "elements": n,
                        "cfl": cfl,
                        "energy_ratio": r["energy_ratio"],
                        "rebound": r["rebound"],
                        "duration_ratio": r["duration"] / r["duration_ref"],
                        "changes": r["changes"],
                        "seconds": time.perf_counter() - start,
                    }
                )
                print(json.dumps(records[-1]), flush=True)
    return records


def chart(records: list[dict], path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    styles = {"classic": "--", "energy-safe": "-"}
    for rule in RULES.values():
        for n in ELEMENTS:
            rows = [r for r in records if r["rule"] == rule and r["elements"] == n]
            cfl = [r["cfl"] for r in rows]
            label = f"{rule}, {n} elements"
            axes[0].plot(
                cfl, [r["energy_ratio"] for r in rows], styles[rule], marker="o", label=label
            )
            axes[1].plot(cfl, [r["rebound"] for r in rows], styles[rule], marker="o", label=label)
    axes[0].set_yscale("log")
    axes[0].axhline(1.0, color="k", lw=0.8)
    axes[0].set(
        xlabel="time step [CFL = c dt / h]",
        ylabel="energy after / before [-]",
        title="Bar impact: energy (exact: 1)",
    )
    axes[1].axhline(1.0, color="k", lw=0.8)
    axes[1].set(
        xlabel="time step [CFL = c dt / h]",
        ylabel="rebound velocity / v0 [-]",
        title="Bar impact: rebound (exact: 1)",
    )
    axes[1].legend(fontsize=7)
    fig.savefig(path, dpi=120)


def main() -> None:
    RESULTS.mkdir(exist_ok=True)
    records = run()
    (RESULTS / "impact_energy.json").write_text(json.dumps({"records": records}, indent=1))
    chart(records, RESULTS / "impact_energy.png")
    print("wrote", RESULTS / "impact_energy.json", "and", RESULTS / "impact_energy.png")


if __name__ == "__main__":
    main()
