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
median. ``study_cpu_seconds_means`` takes means instead of medians, the run's dearest
step (the zone's first settle) paid once and every other step at the others' mean.

``m=320 (stop 39)`` is the same run on the merged tree of stop 39
(``paper_scale_reduced320_stop39.json``): the block eigensolver, the interior held lighter,
the settles corrected for their active points and the changes corrected point by point in
one pass, all measured together; it replaces the estimates that scaled the stop-38 run by
each branch's 1/16 ratios.

``m=320 (stop 40)`` (``paper_scale_reduced320_walls.json``) is main of stop 39 with the
reduced wall's directions read off M_r instead of solved column by column (1,683 fewer
substitutions of the interior factor); ``m=320 (stop 40, merged)``
(``paper_scale_reduced320_merge40.json``) the merged tree of stop 40 (the eigensolver's
one-pass orthogonalisation and first flips eliminated in the solve too). The verdict is
this run's.

``same_machine`` (``SAME_MACHINE``: ``paper_scale_stop42_same_machine.json``, and
``paper_scale_stop43_same_machine.json`` with stop 43's set-up and quiet step, and
``paper_scale_stop44_same_machine.json`` with stop 44's refined one-pass solve, and
``paper_scale_stop45_same_machine.json`` with stop 45's Schur-block reduction, and
``paper_scale_stop46_same_machine.json`` with the modes found to the tolerances 0.5, 0.1
and the default, ``paper_scale_stop47_same_machine.json`` with stop 47's reduction, each
run's key in ``SAME_MACHINE``), per stop:
the m = 320 run, FULL and the unreduced w-u at 1/4 in one invocation on one otherwise idle
machine (load about 1), each its own process, compared by CPU time: the percentage of FULL
without a prediction or another machine's rates, the peak memory against w-u's and, where
the runs recorded their contact forces, the reduced force history's error over the peak.

``paper_size`` (``PAPER_SIZE``, stop 48: ``paper_scale_stop48_same_machine.json``): the
m = 320 run at the paper's size, its interior's factor out of core (12 GB on disk),
against FULL, which does not fit in 24 GiB (29 GiB extrapolated): FULL's run at 1/4 in the same
file, carried to the paper's size by the power laws ``paper_scale.py`` fits through MUMPS's
analyses of FULL (set-up and change with the factor's flops, a step with its entries).

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
#: Per stop: its file and, where it is not SAME_RUNS' "reduced", its reduced run's key (the
#: label names the modes' tolerance).
SAME_MACHINE: dict[str, tuple[str, str | None]] = {
    "stop 42": ("paper_scale_stop42_same_machine.json", None),
    "stop 43": ("paper_scale_stop43_same_machine.json", None),
    "stop 44": ("paper_scale_stop44_same_machine.json", None),
    "stop 45": ("paper_scale_stop45_same_machine.json", None),
}


def _m320(file: str, tag: str = "", options: str = " tol=0.5") -> tuple[str, str]:
    """A stop's entry: its file and its m = 320 run at 1/4 (``tag``: the scale's suffix,
    +2, +3, +ooc; ``options``: the label's after ``m=320``, "" for the default tolerance)."""
    return file, f"parallelepiped|1/4{tag}|w-u reduced m=320{options}|run"


# stop 46: the modes to 0.5 (the block Krylov space, unrestarted), to 0.1 and to the default;
# the three again (tag +2, the default first) and 0.5 and the default a third time (+3);
# FULL's and w-u's runs are the first invocation's
_STOP46 = "paper_scale_stop46_same_machine.json"
SAME_MACHINE |= {
    "stop 46": _m320(_STOP46),
    "stop 46, tol 0.1": _m320(_STOP46, options=" tol=0.1"),
    "stop 46, default tolerance": _m320(_STOP46, options=""),
    "stop 46, second run": _m320(_STOP46, "+2"),
    "stop 46, tol 0.1, second run": _m320(_STOP46, "+2", " tol=0.1"),
    "stop 46, default tolerance, second run": _m320(_STOP46, "+2", ""),
    "stop 46, third run": _m320(_STOP46, "+3"),
    "stop 46, default tolerance, third run": _m320(_STOP46, "+3", ""),
}
# stop 47: the reduction without fresh pages per block and the modes' Krylov relation; the
# modes to 0.5 three times (the first invocation with FULL and w-u, then +2 and +3), the
# default once, and the modes to 0.5 with the interior's factor out of core: by the
# problem's PETSc options (+ooc), then by reduce(out_of_core=True) (label " ooc")
_STOP47 = "paper_scale_stop47_same_machine.json"
SAME_MACHINE |= {
    "stop 47": _m320(_STOP47),
    "stop 47, second run": _m320(_STOP47, "+2"),
    "stop 47, third run": _m320(_STOP47, "+3"),
    "stop 47, default tolerance": _m320(_STOP47, options=""),
    "stop 47, interior out of core": _m320(_STOP47, "+ooc"),
    "stop 47, reduce(out_of_core=True)": _m320(_STOP47, options=" tol=0.5 ooc"),
}
# stop 48: reduce(out_of_core=True) in passes of 128 columns and Krylov blocks of 32 (three
# runs: the first beside FULL, w-u and CG+GAMG, then +2 and +3), the modes to 0.5 in core
# once; the paper's size below (PAPER_SIZE)
_STOP48 = "paper_scale_stop48_same_machine.json"
SAME_MACHINE |= {
    "stop 48": _m320(_STOP48),
    "stop 48, reduce(out_of_core=True)": _m320(_STOP48, options=" tol=0.5 ooc"),
    "stop 48, reduce(out_of_core=True), second run": _m320(_STOP48, "+2", " tol=0.5 ooc"),
    "stop 48, reduce(out_of_core=True), third run": _m320(_STOP48, "+3", " tol=0.5 ooc"),
}
#: Per stop: its file and its reduced run at the paper's size (out of core); FULL does not fit
#: at that size, so its run at 1/4 in the same file is carried there as ``paper_scale.py``
#: carries it (MUMPS's analyses: set-up and change with the factor's flops, a step with its
#: entries). No unreduced run there yet: the force history is compared at 1/4 only.
PAPER_SIZE: dict[str, tuple[str, str]] = {
    "stop 48": (_STOP48, "parallelepiped|paper|w-u reduced m=320 tol=0.5 ooc|run"),
}
SAME_RUNS = {
    "reduced": "parallelepiped|1/4|w-u reduced m=320|run",
    "FULL": "parallelepiped|1/4|FULL|run",
    "w-u": "parallelepiped|1/4|w-u|run",
    "CG+GAMG": "parallelepiped|1/4|CG+GAMG|run",
}
CELLS = {"1/16": 25_000, "1/4": 100_000, "paper": 400_000}


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
        # means, the dearest step (the zone's first settle) paid once: no median's luck
        "dearest_step": max(base),
        "step_mean_but_dearest": statistics.mean(sorted(base)[:-1] or base),
        "change_mean": statistics.mean(change),
        "peak_rss_gib": max(run["peak_rss_gib"]),
        "load_average_mean": run.get("load_average_mean"),
    }


def finished(run: dict) -> dict:
    """A run as :func:`rates` reads it. A run stopped by hand after some steps (the peer at
    stop 48: minutes a step) counts the steps it finished (``steps_done``) and no build, which
    it did not record (in its favour: its first solve is its set-up)."""
    if "steps" in run or "steps_done" not in run:
        return run
    return run | {
        "steps": run["steps_done"],
        "build_cpu_seconds": 0.0,
        "peak_rss_gib": [run["peak_tree_rss_gib"]],
    }


def history_error(reduced: dict, unreduced: dict) -> float | None:
    """The largest difference of the contact force (x) over the unreduced run's peak, step
    by step, where both runs recorded it (``paper_scale.py`` since stop 46)."""
    if "force" not in unreduced["steps"][0] or "force" not in reduced["steps"][0]:
        return None
    steps = min(len(reduced["steps"]), len(unreduced["steps"]))
    x = [np.array([s["force"]["end"][0] for s in r["steps"][:steps]]) for r in (reduced, unreduced)]
    return float(np.abs(x[0] - x[1]).max() / np.abs(x[1]).max())


def whole(r: dict) -> float:
    """The study's seconds from a run's rates."""
    return r["setup"] + STEPS * r["step"] + CHANGES * r["change"]


def whole_means(r: dict) -> float:
    """The study's seconds from means, the run's dearest step paid once."""
    return (
        r["setup"]
        + r["dearest_step"]
        + STEPS * r["step_mean_but_dearest"]
        + CHANGES * r["change_mean"]
    )


def runs_of(name: str) -> dict:
    """The runs of a results file (none if it is not there)."""
    path = HERE / name
    return json.loads(path.read_text())["runs"] if path.exists() else {}


def run_of(name: str, key: str) -> dict | None:
    return runs_of(name).get(key)


def _paper_size(law: dict) -> dict:
    """Per stop of PAPER_SIZE: the reduced study at the paper's size against FULL's run at 1/4
    carried there by the analyses' power laws (``law``: paper_scale.py's extrapolation)."""
    grown = CELLS["paper"] / CELLS["1/4"]
    growth = {
        "setup": grown ** law["exponent_flops"],
        "step": grown ** law["exponent_entries"],
        "change": grown ** law["exponent_flops"],
    }
    out = {}
    for stop, (name, reduced_run) in PAPER_SIZE.items():
        same = runs_of(name)
        if reduced_run not in same or SAME_RUNS["FULL"] not in same:
            continue
        reduced, quarter = rates(same[reduced_run]), rates(same[SAME_RUNS["FULL"]])
        full = {k: quarter[k] * growth[k] for k in KEYS}
        entry = out[stop] = {
            "file": name,
            "reduced": reduced,
            "FULL, 1/4": quarter,
            "FULL, paper (extrapolated)": full,
            "growth": growth,
            "study_cpu_seconds": {"reduced": float(whole(reduced)), "FULL": float(whole(full))},
            "percent_of_FULL": float(100.0 * whole(reduced) / whole(full)),
            "percent_of_FULL_means": float(100.0 * whole_means(reduced) / whole(full)),
        }
        print("paper size", stop, {k: v for k, v in entry.items() if not isinstance(v, dict)})
    return out


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
        ("m=320 (stop 39)", "1/4"): run_of(  # the merged tree of stop 39, measured directly
            "paper_scale_reduced320_stop39.json",
            "parallelepiped|1/4|w-u reduced m=320|run",
        ),
        ("m=320 (stop 40)", "1/4"): run_of(  # main of stop 39 with the walls' directions
            # read off M_r (no solve per wall column), measured directly
            "paper_scale_reduced320_walls.json",
            "parallelepiped|1/4|w-u reduced m=320|run",
        ),
        ("m=320 (stop 40, merged)", "1/4"): run_of(  # with the eigensolver's one-pass
            # orthogonalisation and the first flips eliminated in the solve
            "paper_scale_reduced320_merge40.json",
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
    for m320 in ("m=320", "m=320 (stop 39)", "m=320 (stop 40)", "m=320 (stop 40, merged)"):
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
            entry["study_cpu_seconds_means"] = float(whole_means(r))
        for ref in (
            ("measured wall", "predicted") if size == "1/4" else ("extrapolated wall", "predicted")
        ):
            entry[f"percent_of_FULL_{ref}"] = float(100.0 * t / whole(full[f"{ref}, {size}"]))
            for kind in ("mean_steps", "means"):
                if f"study_cpu_seconds_{kind}" in entry:
                    entry[f"percent_of_FULL_{ref}_{kind}"] = float(
                        100.0 * entry[f"study_cpu_seconds_{kind}"] / whole(full[f"{ref}, {size}"])
                    )
        for peer in ("CG+GAMG", "CG+Jacobi"):
            p = next((v for k, v in measured.items() if k.startswith(peer) and (size in k)), None)
            if p is not None and not label.startswith("CG+"):
                entry[f"{peer}_over_this"] = float(whole(p) / t)
        out["study_seconds"][label] = entry
        print(label, {k: round(v, 4) for k, v in entry.items()})
    out["same_machine"] = {}
    for stop, (name, reduced_run) in SAME_MACHINE.items():
        same = runs_of(name)
        keys = SAME_RUNS | {"reduced": reduced_run or SAME_RUNS["reduced"]}
        parts = {label: rates(finished(same[key])) for label, key in keys.items() if key in same}
        if {"reduced", "FULL"} <= parts.keys():
            full_cpu, reduced = whole(parts["FULL"]), parts["reduced"]
            entry = out["same_machine"][stop] = {
                "file": name,
                "runs": parts,
                "study_cpu_seconds": {k: float(whole(r)) for k, r in parts.items()},
                "percent_of_FULL": float(100.0 * whole(reduced) / full_cpu),
                "percent_of_FULL_means": float(100.0 * whole_means(reduced) / full_cpu),
            }
            if "CG+GAMG" in parts:  # the iterative peer, run beside them
                entry["CG+GAMG_over_this"] = float(whole(parts["CG+GAMG"]) / whole(reduced))
            if "w-u" in parts:
                entry["peak_rss_gib_over_w-u"] = float(
                    reduced["peak_rss_gib"] / parts["w-u"]["peak_rss_gib"]
                )
                error = history_error(same[keys["reduced"]], same[keys["w-u"]])
                if error is not None:
                    entry["force_history_error_over_peak"] = error
            print("same machine", stop, {k: v for k, v in entry.items() if k != "runs"})
    out["paper_size"] = _paper_size(s["parallelepiped|paper|FULL (extrapolated)"])
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
