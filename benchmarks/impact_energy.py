"""Impact: energy, rebound, duration and contact force of the bar, for each time-stepping option.

Runs :func:`dd_contact.paper.verify.bar_impact` (an elastic bar at 0.01 c onto a rigid wall, the
1-D wave solution: contact for 2L/c at the force rho c v0 A, rebound at -v0, energy kept)
with the default contact penalty over CFL 0.1 ... 1 and 40 ... 160 elements, for

* ``classic``: the paper's trapezoidal contact (``energy_safe_contact=False``), consistent mass;
* the energy-safe steps (the default) with consistent, lumped or averaged mass, and the trapezoidal
  rule or generalized-alpha (rho_infinity 0.8, the default, and 0, the most damping);

and writes

* ``benchmarks/results/impact_energy.json``: one record per run (option, elements, CFL,
  energy after / before, rebound / v0, duration / (2L/c), peak and plateau contact force /
  (rho c v0 A), contact state changes, seconds), and the force histories of the chart;
* ``benchmarks/results/impact_energy.png``: energy ratio and rebound vs CFL;
* ``benchmarks/results/impact_force.png``: contact force vs time against the closed form.

See docs/contact.md, "Impact". Usage: python benchmarks/impact_energy.py [--charts]
(``--charts``: redraw the charts from the JSON of the last run).
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dd_contact.paper import verify
from dd_contact.paper.verify.bar import BAR_IMPACT

RESULTS = Path(__file__).parent / "results"
CFLS = (0.1, 0.25, 0.5, 1.0)
ELEMENTS = (40, 80, 160)
#: name -> the options of verify.bar_impact
OPTIONS = {
    "classic": {"energy_safe_contact": False},
    "consistent, trapezoidal": {},
    "lumped, trapezoidal": {"mass": "lumped"},
    "averaged, trapezoidal": {"mass": "averaged"},
    "consistent, gen-alpha 0.8": {"scheme": "generalized-alpha", "rho_infinity": 0.8},
    "lumped, gen-alpha 0.8": {"mass": "lumped", "scheme": "generalized-alpha", "rho_infinity": 0.8},
    "lumped, gen-alpha 0": {"mass": "lumped", "scheme": "generalized-alpha", "rho_infinity": 0.0},
}
#: the runs whose force history is charted
FORCE_CHART = {"elements": 80, "cfl": 0.5}


def run() -> tuple[list[dict], dict[str, dict]]:
    records, histories = [], {}
    for option, settings in OPTIONS.items():
        for n in ELEMENTS:
            for cfl in CFLS:
                start = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # the classic rule's EnergyGrowthWarning
                    r = verify.bar_impact(n=n, cfl=cfl, comm=MPI.COMM_SELF, **settings)
                records.append(
                    {
                        "option": option,
                        "elements": n,
                        "cfl": cfl,
                        "energy_ratio": r["energy_ratio"],
                        "rebound": r["rebound"],
                        "duration_ratio": r["duration"] / r["duration_ref"],
                        "peak_force_ratio": r["peak_force"] / r["force_ref"],
                        "plateau_force_ratio": r["plateau_force"] / r["force_ref"],
                        "changes": r["changes"],
                        "seconds": time.perf_counter() - start,
                    }
                )
                print(json.dumps(records[-1]), flush=True)
                if n == FORCE_CHART["elements"] and cfl == FORCE_CHART["cfl"]:
                    dt = cfl * BAR_IMPACT["length"] / n
                    histories[option] = {
                        "t": (dt * np.arange(1, len(r["forces"]) + 1)).tolist(),
                        "force_ratio": (np.array(r["forces"]) / r["force_ref"]).tolist(),
                    }
    return records, histories


def energy_chart(records: list[dict], path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    colours = dict(zip(OPTIONS, plt.cm.tab10.colors, strict=False))
    markers = dict(zip(ELEMENTS, "os^", strict=False))
    for option in OPTIONS:
        for n in ELEMENTS:
            rows = [r for r in records if r["option"] == option and r["elements"] == n]
            cfl = [r["cfl"] for r in rows]
            style = {"color": colours[option], "marker": markers[n], "ls": "--" if n > 40 else "-"}
            label = f"{option}, {n}"
            axes[0].plot(cfl, [r["energy_ratio"] for r in rows], label=label, **style)
            axes[1].plot(cfl, [r["rebound"] for r in rows], label=label, **style)
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
        ylim=(0.9, 1.3),
    )
    axes[1].legend(fontsize=6, ncol=2)
    fig.savefig(path, dpi=120)


def force_chart(histories: dict[str, dict], path: Path) -> None:
    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    contact = 2.0 * BAR_IMPACT["length"]  # 2L/c, c = 1
    ax.plot([0, 0, contact, contact, 1.5 * contact], [0, 1, 1, 0, 0], "k", lw=2, label="exact")
    for option, h in histories.items():
        thin = {"lw": 0.6, "alpha": 0.4} if option == "classic" else {"lw": 1.2}
        ax.plot(h["t"], h["force_ratio"], label=option, **thin)
    ax.set(
        xlabel="time [L / c]",
        ylabel="contact force / (rho c v0 A) [-]",
        title=f"Bar impact: contact force, {FORCE_CHART['elements']} elements, "
        f"CFL {FORCE_CHART['cfl']}",
        xlim=(0, 1.5 * contact),
        ylim=(0, 2.0),  # the classic rule's spikes reach 15
    )
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=120)


def main() -> None:
    RESULTS.mkdir(exist_ok=True)
    if "--charts" in sys.argv:  # redraw from the JSON of the last run
        payload = json.loads((RESULTS / "impact_energy.json").read_text())
        records, histories = payload["records"], payload["force_histories"]
    else:
        records, histories = run()
        payload = {"records": records, "force_histories": histories}
        (RESULTS / "impact_energy.json").write_text(json.dumps(payload, indent=1))
    energy_chart(records, RESULTS / "impact_energy.png")
    force_chart(histories, RESULTS / "impact_force.png")
    print("wrote", RESULTS / "impact_energy.json", "impact_energy.png", "impact_force.png")


if __name__ == "__main__":
    main()
