"""Penalty extremes: every algorithm against the penalty-free reference, kappa = 1e0 ... 1e14.

Runs :func:`dd_contact.paper.verify.extremes` (every case, every algorithm that fits its scene,
every decade of the swept tie penalty) and writes

* ``benchmarks/results/penalty_extremes_<label>.json``: one record per (case, algorithm,
  kappa) with the error, its tolerance and whether it passed, plus the largest kappa each
  algorithm passes per case family;
* ``benchmarks/results/penalty_extremes_<label>.png``: error vs kappa (log-log), one panel per
  case family, one line per algorithm (the worst case of the family), and the tolerance.

``--label before`` is the data of the code before the extremes are stabilised (kept for
comparison); ``--label after`` the same sweep after. See docs/accuracy.md.

Usage: python benchmarks/penalty_extremes.py [--label before|after]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dd_contact.paper import verify
from dd_contact.solvers.schedule import ALGORITHMS

RESULTS = Path(__file__).parent / "results"

#: Where a failed solve (no error to show) is drawn on the chart.
FAILED_AT = 10.0


def _commit() -> str:
    try:
        return subprocess.run(
            ["git", "-C", str(Path(__file__).parent), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def largest_passing(records: list[dict]) -> dict[str, dict[str, dict]]:
    """Per case family and algorithm: the largest kappa at which every case passes.

    ``largest``: the largest such kappa; ``failed_below``: kappas below it at which some case
    failed (the range is not contiguous then).
    """
    out: dict[str, dict[str, dict]] = {}
    for family in dict.fromkeys(r["family"] for r in records):
        out[family] = {}
        for algorithm in ALGORITHMS:
            mine = [r for r in records if r["family"] == family and r["algorithm"] == algorithm]
            if not mine:
                continue
            kappas = sorted({r["kappa"] for r in mine})
            ok = [k for k in kappas if all(r["passed"] for r in mine if r["kappa"] == k)]
            largest = max(ok) if ok else None
            below = [k for k in kappas if largest is not None and k < largest and k not in ok]
            out[family][algorithm] = {"largest": largest, "failed_below": below}
    return out


def chart(records: list[dict], label: str, path: Path) -> None:
    """Error vs kappa: one panel per family, one line per algorithm (worst case)."""
    families = list(dict.fromkeys(r["family"] for r in records))
    fig, axes = plt.subplots(1, len(families), figsize=(4.2 * len(families), 4.0), sharey=True)
    axes = [axes] if len(families) == 1 else list(axes)
    colours = dict(zip(ALGORITHMS, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, family in zip(axes, families):
        mine = [r for r in records if r["family"] == family]
        cases = len({r["case"] for r in mine})
        for algorithm in ALGORITHMS:
            rows = [r for r in mine if r["algorithm"] == algorithm]
            if not rows:
                continue
            kappas = sorted({r["kappa"] for r in rows})
            worst = []
            for k in kappas:
                errors = [r["error"] for r in rows if r["kappa"] == k]
                worst.append(FAILED_AT if None in errors else max(errors))
            ax.loglog(kappas, worst, "o-", ms=3, color=colours[algorithm], label=algorithm)
            failed = [(k, e) for k, e in zip(kappas, worst) if e == FAILED_AT]
            if failed:
                ax.loglog(*zip(*failed), "x", ms=8, color=colours[algorithm])
        tolerance = sorted({(r["kappa"], r["tolerance"]) for r in mine})
        ax.loglog(*zip(*tolerance), "k--", lw=1, label="tolerance")
        ax.set_title(f"{family} ({cases} cases)")
        ax.set_xlabel("swept tie penalty kappa")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    axes[0].set_ylabel("worst error / load (stress, contact force)")
    fig.suptitle(f"Penalty extremes ({label}): error against the penalty-free reference")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", choices=("before", "after"), default="before")
    parser.add_argument("--case", action="append", help="run only this case (repeatable)")
    args = parser.parse_args()

    start = time.perf_counter()
    records = verify.extremes(cases=args.case)
    runtime = time.perf_counter() - start
    rows = [
        {
            "case": r.case,
            "family": r.family,
            "algorithm": r.algorithm,
            "kappa": r.kappa,
            "error": _finite(r.rel_error),
            "stress_error": _finite(r.stress_error),
            "force_error": _finite(r.force_error),
            "tolerance": r.tolerance,
            "passed": r.passed,
            "note": r.note,
        }
        for r in records
    ]
    summary = largest_passing(rows)
    result = {
        "label": args.label,
        "commit": _commit(),
        "dd_contact": str(Path(verify.__file__).parents[1]),
        "runtime_s": round(runtime, 1),
        "solves": len(rows),
        "kappas": list(verify.EXTREME_KAPPAS),
        "moderate_kappa": verify.MODERATE_KAPPA,
        "tolerance_floor": verify.PENALTY_FLOOR,
        "distortion": verify.DISTORTION,
        "largest_passing": summary,
        "records": rows,
    }
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / f"penalty_extremes_{args.label}.json"
    # One record per line: the file stays readable and diffs stay small.
    body = json.dumps({k: v for k, v in result.items() if k != "records"}, indent=1)[:-2]
    lines = ",\n  ".join(json.dumps(r) for r in rows)
    out.write_text(f'{body},\n "records": [\n  {lines}\n ]\n}}\n')
    chart(rows, args.label, RESULTS / f"penalty_extremes_{args.label}.png")
    print(f"{len(rows)} solves in {runtime:.1f} s; {sum(r['passed'] for r in rows)} passed")
    for family, algorithms in summary.items():
        for algorithm, s in algorithms.items():
            largest = "none" if s["largest"] is None else f"{s['largest']:.0e}"
            below = ", ".join(f"{k:.0e}" for k in s["failed_below"])
            print(f"{family:24s} {algorithm:6s} largest passing kappa {largest}", end="")
            print(f" (fails below it at {below})" if below else "")
    print(f"wrote {out} and {out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
