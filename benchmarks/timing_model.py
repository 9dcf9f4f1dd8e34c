"""Predicted against measured time for every algorithm (dd_contact.timing, issue 5 section 2).

The measurements are runs of ``decomposition_speed.py`` (the parallelepiped pressed on a
tilted wall; each run its own process, BLAS on one thread). For each of their algorithms this
script builds the same scene, lets MUMPS analyse the matrices the algorithm factorises (no
factorisation), plans its operations and prices them with this machine's rates, calibrated
on cube meshes, never on these scenes (``dd_contact.timing.machine_rates``, one thread).

Compared, per run, then as the median over runs:

* ``total``: the whole time stepping (every step, first one included: set-up
  factorisations, substitutions and contact changes) against the prediction for the run's
  number of steps and contact changes;
* the parts: per contact change and per step without change (medians, as
  decomposition_speed.py derives them), and the linear algebra the work log timed.

The criterion is |predicted / measured - 1| <= 0.3 on the total, for every algorithm.
Writes benchmarks/results/timing_model.json and timing_model.png.

It also puts the measurements on the paper's step study (``dd-contact flops --sweep``) for
the measured bar: the time of N_TS steps with gamma = 2 N_TS changes, composed of the
measured medians (first iteration with the set-up, step without change, contact change),
relative to FULL's, at N_TS = 1 ... 10,000. Written to benchmarks/results/sweep_<case>/
(charts and JSON) and measured_points_<case>.json (the ``--measured`` file of the CLI).

Run: python benchmarks/timing_model.py [--measured FILE ...] [--recalibrate]
To measure anew: python benchmarks/decomposition_speed.py --elements 120 18 6 --steps 8
--full-steps 4 --out benchmarks/results/timing_runs_120x18x6.json (and likewise 250 36 10).
"""

from __future__ import annotations

import os

# One BLAS thread, as in the measured runs (set before numpy is imported).
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from decomposition_speed import derived  # noqa: E402

HERE = Path(__file__).parent / "results"
MEASURED = [HERE / "timing_runs_120x18x6.json", HERE / "timing_runs_250x36x10.json"]
TOLERANCE = 0.3


def plan_of(algorithm: str, elements: list[int], dt: float):
    """What one algorithm factorises and solves on the benchmark scene (analysis only)."""
    from mpi4py import MPI

    import dd_contact as dd
    from dd_contact import timing
    from dd_contact.paper.examples import parallelepiped
    from dd_contact.solvers import analysed

    scene = parallelepiped(algorithm, tuple(elements), comm=MPI.COMM_SELF)
    problem = dd.TransientProblem(scene, dt, algorithm=algorithm, track_energy=False)
    contacts = [z.region for z in problem.zones]
    full = algorithm == "FULL"
    structure = analysed.scene_structure(
        MPI.COMM_SELF, problem.solver.system, contacts, full=full, orders=not full
    )
    problem.solver.destroy()
    return timing.plan(structure, algorithm)


def compare(runs: list[dict], plan, rates) -> dict:
    """Predicted against measured for the runs of one algorithm."""
    from dd_contact import timing

    rows = []
    for run in runs:
        n_steps, gamma = len(run["steps"]), run["changes"]
        p = timing.predict(plan, rates, n_steps, gamma)
        measured = sum(s["seconds"] for s in run["steps"])
        linear_algebra = sum(
            b["seconds_decomposition"]
            + b["seconds_substitution"]
            + b["seconds_schur"]
            + b.get("seconds_product", 0.0)
            for name, b in run["work"].items()
            if not name.startswith("mass:")  # the initial acceleration: before the steps
        )
        d = derived(run)
        rows.append(
            {
                "steps": n_steps,
                "changes": gamma,
                "measured_total": measured,
                "predicted_total": p.total,
                "ratio_total": p.total / measured,
                "measured_linear_algebra": linear_algebra,
                "ratio_linear_algebra": p.total / linear_algebra,
                "measured_per_change": d["seconds_per_change"],
                "predicted_per_change": p.change,
                "measured_per_step_base": d["seconds_per_step_base"],
                "predicted_per_step": p.step,
                "predicted_setup": p.setup,
            }
        )
    out = {"runs": rows}
    for key in rows[0]:
        values = [r[key] for r in rows if r[key] is not None]
        out[f"median_{key}"] = statistics.median(values) if values else None
    ratio = out["median_ratio_total"]
    out["within_tolerance"] = abs(ratio - 1.0) <= TOLERANCE
    return out


def measured_points(runs: dict[str, list[dict]]) -> dict:
    """``{"bar_steps": {algorithm: [[N_TS, percent of FULL], ...]}}`` from measured medians."""
    medians = {}
    for algorithm, rs in runs.items():
        ds = [derived(r) for r in rs]
        changes = [d["seconds_per_change"] for d in ds if d["seconds_per_change"] is not None]
        medians[algorithm] = (
            statistics.median(r["steps"][0]["iterations"][0] for r in rs),
            statistics.median(d["seconds_per_step_base"] for d in ds),
            statistics.median(changes),
        )

    def seconds(algorithm: str, n_steps: int) -> float:
        first, step, change = medians[algorithm]
        return first + (n_steps - 1) * step + 2 * n_steps * change

    steps = (1, 10, 100, 1000, 10000)
    return {
        "bar_steps": {
            a: [[n, 100.0 * seconds(a, n) / seconds("FULL", n)] for n in steps] for a in medians
        }
    }


def chart(results: dict, path: Path) -> None:
    """Predicted against measured (totals and parts), log-log, with the +-30% band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    markers = {"total": "o", "per_change": "s", "per_step": "^"}
    colours = dict(zip(["FULL", "v-w-u", "w-v-u", "w-u", "v-u"], plt.cm.tab10.colors))
    low, high = 1e9, 0.0
    for case, algorithms in results["cases"].items():
        for algorithm, r in algorithms.items():
            pairs = {
                "total": (r["median_measured_total"], r["median_predicted_total"]),
                "per_change": (r["median_measured_per_change"], r["median_predicted_per_change"]),
                "per_step": (r["median_measured_per_step_base"], r["median_predicted_per_step"]),
            }
            for part, (m, p) in pairs.items():
                if not m or not p:
                    continue
                ax.loglog(m, p, markers[part], color=colours[algorithm], alpha=0.85)
                low, high = min(low, m, p), max(high, m, p)
    x = [low / 2, high * 2]
    ax.plot(x, x, "k-", lw=0.8)
    ax.fill_between(x, [v * 0.7 for v in x], [v * 1.3 for v in x], color="0.85", label="+-30%")
    for algorithm, c in colours.items():
        ax.plot([], [], "o", color=c, label=algorithm)
    for part, m in markers.items():
        ax.plot([], [], m, color="0.4", label=part.replace("_", " "))
    ax.set_xlabel("measured [s]")
    ax.set_ylabel("predicted [s]")
    ax.set_title("dd_contact.timing: predicted vs measured\n(" + ", ".join(results["cases"]) + ")")
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--measured", nargs="+", type=Path, default=MEASURED)
    parser.add_argument("--recalibrate", action="store_true")
    parser.add_argument("--out", type=Path, default=HERE / "timing_model.json")
    args = parser.parse_args()
    from dd_contact import timing

    rates = timing.machine_rates(recalibrate=args.recalibrate)
    results = {"tolerance": TOLERANCE, "rates": rates.to_dict(), "cases": {}}
    for file in args.measured:
        if not file.exists():
            print(f"skipped {file}: not measured (see this script's docstring)")
            continue
        data = json.loads(file.read_text())
        case = "x".join(map(str, data["elements"]))
        results["cases"][case] = {}
        for algorithm, runs in data["runs"].items():
            plan = plan_of(algorithm, data["elements"], data["dt"])
            r = compare(runs, plan, rates)
            results["cases"][case][algorithm] = r
            print(
                f"{case} {algorithm:>6}: measured {r['median_measured_total']:9.3f} s, "
                f"predicted {r['median_predicted_total']:9.3f} s, ratio "
                f"{r['median_ratio_total']:.3f} ({'ok' if r['within_tolerance'] else 'OUT'}); "
                f"per change {r['median_measured_per_change'] or 0:.4g} / "
                f"{r['median_predicted_per_change']:.4g} s, per step "
                f"{r['median_measured_per_step_base']:.4g} / "
                f"{r['median_predicted_per_step']:.4g} s",
                flush=True,
            )
        if "FULL" in data["runs"]:
            sweep_on_measured_bar(data, case, args.out.parent)
    args.out.write_text(json.dumps(results, indent=1))
    chart(results, args.out.with_suffix(".png"))


def sweep_on_measured_bar(data: dict, case: str, directory: Path) -> None:
    """The paper's studies for the measured bar, with the measured points on the step study."""
    from dd_contact.paper import flops

    points = measured_points(data["runs"])
    (directory / f"measured_points_{case}.json").write_text(json.dumps(points, indent=1))
    nx, ny, nz = data["elements"]
    studies = flops.parallelepiped_studies(
        elements=(nx, ny, nz), split=(1, 1), interface=(ny, nz), contact=(ny, nz)
    )
    flops.write_studies(studies, directory / f"sweep_{case}", points)


if __name__ == "__main__":
    main()
