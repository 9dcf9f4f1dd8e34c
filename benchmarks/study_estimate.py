"""The paper's study (Table 3: 10,000 steps, 20,000 contact changes) with reduced subdomains.

Reads the runs of ``paper_scale.py`` (the paper's bar shaken on its wall, dt 1e-4, one
process each, one BLAS thread) and estimates the whole study as that script does,
``set-up + 10,000 steps + 20,000 changes`` from the measured set-up, step and change
times, for ``w-u`` with its subdomain reduced, against FULL and the iterative peers.

The machine was shared (load average 12-17 during these runs, 4-7 during FULL's), so:

* the reduced runs and the peers are compared by **CPU time** (each process's own);
* FULL's own runs recorded wall time only; it is given two ways: its measured wall time
  (load 6.5; inflates FULL, flatters the ratio) and MUMPS's analysis priced by this
  machine's measured rates (``dd_contact.timing``, ``FULL|analysis``'s prediction: an
  unloaded, CPU-like time; the verdict uses this one).
* A reduced run's quiet step is the median over the steps whose load was projected without
  a substitution: the runs predate ``LOAD_SPAN_FLOOR`` (docs/solvers.md), before which 15 of
  20 steps at 342k dofs also paid one substitution of the interior factor (0.43 s).

At the paper's size: the reduced run by a power law in the cells through its runs at 1/16
and 1/4, FULL as ``paper_scale.py`` extrapolates it, the peer linear in the cells.

Branch study re-measured m = 20 at 1/4 with its cuts to the step and the change
(``paper_scale_reduced20_study.json``). The m = 320 run at 1/4 was measured directly on the
merged tree of stop 38 (``paper_scale_reduced320.json``, load 2.4); at the paper's size it is
carried with m = 160's exponents in the cells. The estimate before it is kept in the JSON
as ``before``; ``study_cpu_seconds_mean_steps`` counts every step at the run's mean step
(the settles of the steps with changes in, and the zone's first settle), not its quiet
median.

Branch settle cut the release steps' settles (``benchmarks/settle_cost.py``); ``m=320
(settle, estimated)`` is the direct run with those steps' settles scaled by the
ratios measured at 1/16 (:func:`_settled`): the mean-step variant is the one it changes.

``m=320 (block eigensolver)``: the same run with its set-up measured again with the block
eigensolver (``benchmarks/reduction_setup.py`` at 1/4, the phases up to the solver,
``reduction_setup_eigen_1-4.json``; the steps and changes do not depend on how the modes were
found), carried to the paper's size as m = 320 is. Without that run, ``m=320 (block
eigensolver, scaled)``: the set-up with its modes' phase cut by the ratio the two
eigensolvers measured at 1/16 (``reduction_setup_eigen.json``, :func:`block_setup_scaled`).

Writes benchmarks/results/paper_study_estimate.json.

Run: python benchmarks/study_estimate.py
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent / "results"
STEPS, CHANGES = 10_000, 20_000  # Table 3 (dd_contact.paper.flops.paper.PAPER_BAR)
KEYS = ("setup", "step", "change")
CELLS = {"1/16": 25_000, "1/4": 100_000, "paper": 400_000}
#: Branch settle's run at 1/16, m = 320 (benchmarks/settle_cost.py --against, merged): each
#: settle by the branch and by main on the same arguments; the run's key there.
SETTLE_RUN, SETTLE_BRANCH = "settle_cost_1-16_m320.json", "branch_16_320"


def rates(run: dict) -> dict:
    """CPU set-up, median quiet step (no substitution) and median change of a run."""
    steps = run["steps"]
    change = [t for s in steps for t in s["iterations_cpu"][1:]]
    base = [s["cpu_seconds"] - sum(s["iterations_cpu"][1:]) for s in steps[1:]]
    first = min(base)
    clean = [b for b in base if b < 3.0 * first]  # the steps without a projection's solve
    return {
        "setup": run["build_cpu_seconds"] + steps[0]["iterations_cpu"][0],
        "step": statistics.median(clean),
        # the steps with changes too: their decisions and settles (not the changes' solves)
        "step_mean": statistics.mean(clean + [b for b in base if b >= 3.0 * first]),
        "step_all": statistics.median(base),
        "clean_steps": len(clean),
        "change": statistics.median(change),
        "peak_rss_gib": max(run["peak_rss_gib"]),
        "load_average_mean": run.get("load_average_mean"),
    }


def whole(r: dict) -> float:
    """The study's seconds from a run's rates."""
    return r["setup"] + STEPS * r["step"] + CHANGES * r["change"]


def run_of(name: str, key: str) -> dict | None:
    path = HERE / name
    if not path.exists():
        return None
    return json.loads(path.read_text())["runs"].get(key)


def _build(record: dict) -> float:
    """A ``reduction_setup.py`` run's build: its phases' CPU seconds up to the steps."""
    return sum(p["cpu_seconds"] for p in record["phases"] if "steps" not in p["phase"])


def _modes_phase(record: dict) -> float:
    return next(p["cpu_seconds"] for p in record["phases"] if "modes (" in p["phase"])


def block_setup_scaled(direct: dict | None) -> dict | None:
    """The m = 320 run at 1/4, its modes' phase cut as the block eigensolver cut it at 1/16.

    The modes' phase is taken to be the same share of the build at 1/4 as at 1/16 (75 % at
    1/16 with SLEPc, as estimated at 1/4 from its solves), and cut by the ratio measured at
    1/16 (medians of the interleaved runs, ``reduction_setup_eigen.json``).
    """
    path = HERE / "reduction_setup_eigen.json"
    if direct is None or not path.exists():
        return None
    runs = json.loads(path.read_text())["runs"]
    slepc, block = (
        runs.get("blockeig|1/16|m=320|after|slepc"),
        runs.get("blockeig|1/16|m=320|after|block"),
    )
    if not (slepc and block):
        return None
    share = statistics.median(_modes_phase(r) / _build(r) for r in slepc)
    ratio = statistics.median(map(_modes_phase, block)) / statistics.median(
        map(_modes_phase, slepc)
    )
    cut = direct["build_cpu_seconds"] * share * (1.0 - ratio)
    return {**direct, "setup": direct["setup"] - cut, "modes_share": share, "modes_ratio": ratio}


def block_setup(direct: dict | None) -> dict | None:
    """The m = 320 run at 1/4 with its set-up measured with the block eigensolver."""
    path = HERE / "reduction_setup_eigen_1-4.json"
    if direct is None or not path.exists():
        return None
    runs = [r for k, v in json.loads(path.read_text())["runs"].items() for r in v if "1/4" in k]
    if not runs:
        return None
    build = [_build(r) for r in runs]
    first = direct["setup"] - direct["build_cpu_seconds"]  # the first step's solve, as rates()
    peak = max(r["peak_mb"] for r in runs) * 1e6 / 2**30  # VmHWM's kB as MB
    return {
        **direct,
        "setup": statistics.median(build) + first,
        "setup_slepc": direct["setup"],
        "peak_rss_gib": max(direct["peak_rss_gib"], peak),
    }


def _scaled_by_study(measured: dict) -> None:
    """m = 320 with its step and change scaled as the m = 20 run's were by branch study.

    The m = 320 run at 1/4 did not finish (killed at 14.9 GiB, the machine shared); its
    set-up is kept as estimated, its step and change taken down by the ratio the same
    m = 20 run measured before and after (the work cut is per step, not per mode).
    """
    before, after = measured.get("m=20, 1/4"), measured.get("m=20 (study), 1/4")
    if not (before and after):
        return
    ratio = {k: after[k] / before[k] for k in ("step", "change")} | {"setup": 1.0}
    for size in ("1/4 (linear in m)", "paper (extrapolated)"):
        if f"m=320, {size}" in measured:
            m320 = measured[f"m=320, {size}"]
            measured[f"m=320 (study), {size}"] = {k: m320[k] * ratio[k] for k in KEYS}


def _settled(measured: dict, run: dict | None) -> None:
    """m = 320 at 1/4 with its release steps' settles cut as branch settle measured them.

    An estimate: the 1/4 run could not be repeated on the branch (the shared machine's
    memory slots, load 12). The direct run's steps above three times its quietest (the
    steps that settled) keep its quiet median, and their excess over it is scaled by the
    ratio the same settles took at 1/16 with m = 320, each settle by the branch and by
    main on the same arguments (``settle_cost.py --against``, ``SETTLE_RUN``): the zone's
    first settle (the first such step) by the first settles' ratio, the others by the
    later settles' medians'. At the paper's size m = 160's exponents carry it.
    """
    path = HERE / SETTLE_RUN
    direct = measured.get("m=320, 1/4")
    if not (path.exists() and direct and run):
        return
    cut = json.loads(path.read_text())["summary"][SETTLE_BRANCH]
    first_ratio = cut["first_settle_cpu"] / cut["against_first_settle_cpu"]
    later_ratio = cut["later_settle_cpu_median"] / cut["against_later_settle_cpu_median"]
    steps = run["steps"]
    base = [s["cpu_seconds"] - sum(s["iterations_cpu"][1:]) for s in steps[1:]]
    quiet = min(base)
    settled = [b for b in base if b >= 3.0 * quiet]
    step = direct["step"]
    scaled = [
        step + (b - step) * (first_ratio if i == 0 else later_ratio) for i, b in enumerate(settled)
    ]
    estimate = direct | {
        "step_mean": statistics.mean([b for b in base if b < 3.0 * quiet] + scaled),
        "settle_ratios": {"first": first_ratio, "later": later_ratio},
    }
    measured["m=320 (settle, estimated), 1/4"] = estimate
    paper = measured.get("m=160, paper (extrapolated)")
    if paper:
        grow = {k: (CELLS["paper"] / CELLS["1/4"]) ** paper[f"exponent_{k}"] for k in KEYS}
        grow["step_mean"] = grow["step"]
        measured["m=320 (settle, estimated), paper (extrapolated)"] = {
            k: estimate[k] * grow[k] for k in grow
        }


def main() -> None:
    base = json.loads((HERE / "paper_scale.json").read_text())
    s = base["summary"]
    full = {
        "measured wall, 1/4": {
            "setup": s["parallelepiped|1/4|FULL"]["setup_seconds"],
            "step": s["parallelepiped|1/4|FULL"]["seconds_per_step"],
            "change": s["parallelepiped|1/4|FULL"]["seconds_per_change"],
        },
        "predicted, 1/4": base["runs"]["parallelepiped|1/4|FULL|analysis"]["predicted_seconds"],
        "extrapolated wall, paper": {
            "setup": s["parallelepiped|paper|FULL (extrapolated)"]["setup_seconds"],
            "step": s["parallelepiped|paper|FULL (extrapolated)"]["seconds_per_step"],
            "change": s["parallelepiped|paper|FULL (extrapolated)"]["seconds_per_change"],
        },
    }
    # FULL predicted at the paper's size: the quarter's prediction carried as the wall is
    full["predicted, paper"] = {
        k: full["predicted, 1/4"][k]
        * full["extrapolated wall, paper"][k]
        / full["measured wall, 1/4"][k]
        for k in ("setup", "step", "change")
    }
    runs = {
        ("m=160", "1/16"): run_of(
            "paper_scale_reduced16.json", "parallelepiped|1/16|w-u reduced m=160|run"
        ),
        ("m=160", "1/4"): run_of(
            "paper_scale_reduced160.json", "parallelepiped|1/4|w-u reduced m=160|run"
        ),
        ("m=320", "1/4"): run_of(  # measured directly (branch study: a wall's changes
            # point by point; before, m = 320 was carried from m = 20 and 160, linear in m)
            "paper_scale_reduced320.json",
            "parallelepiped|1/4|w-u reduced m=320|run",
        ),
        ("m=20 (study)", "1/4"): run_of(  # branch study's code, the same run as m=20's
            "paper_scale_reduced20_study.json", "parallelepiped|1/4|w-u reduced m=20|run"
        ),
        ("m=20", "1/4"): run_of(
            "paper_scale_reduced.json", "parallelepiped|1/4|w-u reduced m=20|run"
        ),
        ("m=20 (LOAD_SPAN_FLOOR)", "1/4"): run_of(
            "paper_scale_reduced_span.json", "parallelepiped|1/4+span|w-u reduced m=20|run"
        ),
        ("CG+GAMG", "1/4"): run_of("paper_scale_peers.json", "parallelepiped|1/4|CG+GAMG|run"),
        ("CG+Jacobi", "1/4"): run_of("paper_scale_jacobi.json", "parallelepiped|1/4|CG+Jacobi|run"),
    }
    measured = {f"{a}, {b}": rates(r) for (a, b), r in runs.items() if r and "steps" in r}
    if "m=320, 1/4" in measured:
        measured["m=320, 1/4"]["build_cpu_seconds"] = runs[("m=320", "1/4")]["build_cpu_seconds"]
    block = block_setup(measured.get("m=320, 1/4"))
    if block is not None:
        measured["m=320 (block eigensolver), 1/4"] = block
    scaled = block_setup_scaled(measured.get("m=320, 1/4"))
    if scaled is not None:
        measured["m=320 (block eigensolver, scaled), 1/4"] = scaled
    out: dict = {"full": full, "measured": measured, "study_seconds": {}, "verdict": {}}
    small, quarter = measured.get("m=160, 1/16"), measured.get("m=160, 1/4")
    if small and quarter:  # a power law in the cells through 1/16 and 1/4
        paper = {}
        for k in ("setup", "step", "change", "peak_rss_gib"):
            slope = np.log(quarter[k] / small[k]) / np.log(CELLS["1/4"] / CELLS["1/16"])
            paper[k] = float(quarter[k] * (CELLS["paper"] / CELLS["1/4"]) ** slope)
            paper[f"exponent_{k}"] = float(slope)
        measured["m=160, paper (extrapolated)"] = paper
    low, high = measured.get("m=20, 1/4"), measured.get("m=160, 1/4")
    for m320 in ("m=320", "m=320 (block eigensolver)", "m=320 (block eigensolver, scaled)"):
        direct = measured.get(f"{m320}, 1/4")
        if direct and "m=160, paper (extrapolated)" in measured:  # m = 160's exponents
            paper = measured["m=160, paper (extrapolated)"]
            measured[f"{m320}, paper (extrapolated)"] = {
                k: direct[k] * (CELLS["paper"] / CELLS["1/4"]) ** paper[f"exponent_{k}"]
                for k in KEYS
            }
    if not measured.get("m=320, 1/4") and low and high:  # m = 320 linear in m
        grown = {k: high[k] + (high[k] - low[k]) * (320 - 160) / (160 - 20) for k in KEYS}
        measured["m=320, 1/4 (linear in m)"] = grown
        if "m=160, paper (extrapolated)" in measured:
            paper = measured["m=160, paper (extrapolated)"]
            measured["m=320, paper (extrapolated)"] = {
                k: paper[k] * grown[k] / high[k] for k in KEYS
            }
    _scaled_by_study(measured)
    _settled(measured, runs[("m=320", "1/4")])
    for label in [k for k in measured if k.startswith("CG+")]:
        peer = measured[label]
        measured[label.replace("1/4", "paper (linear in the cells)")] = {
            k: peer[k] * (4.0 if k in ("setup", "step", "change") else 1.0)
            for k in ("setup", "step", "change")
        }
    for label, r in measured.items():
        if "1/16" in label:  # no FULL nor peer there: the extrapolation's lower point only
            continue
        size = "paper" if "paper" in label else "1/4"
        t = float(whole(r))
        entry = {"study_cpu_seconds": t}
        if "step_mean" in r:  # every step at its mean (the changing steps' overhead in)
            entry["study_cpu_seconds_mean_steps"] = float(t + STEPS * (r["step_mean"] - r["step"]))
        for ref in (
            ("measured wall", "predicted") if size == "1/4" else ("extrapolated wall", "predicted")
        ):
            entry[f"percent_of_FULL_{ref}"] = float(100.0 * t / whole(full[f"{ref}, {size}"]))
            if "study_cpu_seconds_mean_steps" in entry:
                mean = entry["study_cpu_seconds_mean_steps"]
                entry[f"percent_of_FULL_{ref}_mean_steps"] = float(
                    100.0 * mean / whole(full[f"{ref}, {size}"])
                )
        for peer in ("CG+GAMG", "CG+Jacobi"):
            p = next((v for k, v in measured.items() if k.startswith(peer) and (size in k)), None)
            if p is not None and not label.startswith("CG+"):
                entry[f"{peer}_over_this"] = float(whole(p) / t)
        out["study_seconds"][label] = entry
        print(label, {k: round(v, 4) for k, v in entry.items()})
    target = HERE / "paper_study_estimate.json"
    if target.exists():  # the estimate before the last re-measurement, kept as "before"
        old = json.loads(target.read_text())
        out["before"] = old.get("before") or {
            "note": "stop 35: m = 320 linear in m from the m = 20 and m = 160 runs",
            "measured": old["measured"],
            "study_seconds": old["study_seconds"],
        }
    target.write_text(json.dumps(out, indent=1))
    print(f"wrote {HERE / 'paper_study_estimate.json'}")


if __name__ == "__main__":
    main()
