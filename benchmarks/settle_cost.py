"""What a release step's settle costs in the paper's study with the subdomain reduced.

Runs the paper's bar (``models.parallelepiped``, w-u, dt 1e-4, as ``paper_scale.py``)
with its subdomain reduced to ``--modes`` modes for ``--steps`` steps, in this process
(BLAS pinned to one thread by the caller: ``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``),
and times every settle (:func:`dd_contact.settle.in_equilibrium`, a release step's massless
dofs put in equilibrium) apart from the step around it. Profiles the first settle and the
others (cProfile, their top functions by own time). Records per step its seconds and CPU,
whether it settled, its contact force and active points, and the peak RSS; the final state
goes to an ``.npz`` next to the JSON, for comparing two trees' answers (``--compare``).

Run: OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/settle_cost.py
     --scale 1/16 --modes 160 --label branch --out benchmarks/results/settle_cost_16_160.json
     python benchmarks/settle_cost.py --compare A.json B.json
     python benchmarks/settle_cost.py --merge A.json B.json ... --out merged.json --note ...

The recorded results (``settle_cost_*.json``) merge runs of main before this branch and of
the branch, interleaved, each in its own process; ``answers_against_*`` gives the largest
differences of the contact-force history and of the final state from the first run.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import pstats
import resource
import statistics
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent / "results"
PROFILED = 3  # later settles profiled (cProfile's overhead is in their times)


def _bar_scale(scale: str) -> tuple[int, int, int]:
    """A fraction of the paper's cells, nz kept (as ``paper_scale.py``)."""
    num, _, den = scale.partition("/")
    fraction = float(num) / float(den or 1)
    return (round(400 * fraction**0.5), round(100 * fraction**0.5), 10)


def _top(profile: cProfile.Profile, count: int = 18) -> list[str]:
    out = io.StringIO()
    pstats.Stats(profile, stream=out).sort_stats("tottime").print_stats(count)
    return [line for line in out.getvalue().splitlines() if line.strip()][-count - 1 :]


def run(args) -> dict:
    """One run: the steps, each settle timed and profiled."""
    import dd_contact as dc
    from dd_contact import impact
    from dd_contact.paper import models

    start, cpu0 = time.perf_counter(), time.process_time()
    scene = models.parallelepiped(_bar_scale(args.scale), algorithm="w-u")
    for sub in scene.subdomains:
        sub.reduce(modes=args.modes)
    problem = dc.TransientProblem(scene, 1e-4, algorithm="w-u", track_energy=False)
    build = {"seconds": time.perf_counter() - start, "cpu": time.process_time() - cpu0}
    settles: list[dict] = []
    first, later = cProfile.Profile(), cProfile.Profile()
    original = impact.in_equilibrium
    against = _module(args.against) if args.against else None

    def timed(*a, **k):
        # profiled: the first settle and the next PROFILED (the others timed without it)
        profile = first if not settles else later if len(settles) <= PROFILED else None
        if against is not None and len(settles) % 2:  # the other tree's first every other time
            other = _other(against, a)
        t0, c0 = time.perf_counter(), time.process_time()
        if profile is not None:
            profile.enable()
        out = original(*a, **k)
        if profile is not None:
            profile.disable()
        settles.append({"seconds": time.perf_counter() - t0, "cpu": time.process_time() - c0})
        if against is not None:
            other = other if len(settles) % 2 == 0 else _other(against, a)
            settles[-1].update(other[1])
            settles[-1]["against_difference"] = max(
                float(np.abs(out[b] - other[0][b]).max() / max(np.abs(out[b]).max(), 1e-300))
                for b in out
            )
        return out

    impact.in_equilibrium = timed
    iterations: list[float] = []  # CPU of each contact iteration (paper_scale.py's probe)
    solve_once = problem.iteration._solve_once

    def iteration(*a):
        c0 = time.process_time()
        out = solve_once(*a)
        iterations.append(time.process_time() - c0)
        return out

    problem.iteration._solve_once = iteration
    steps = []
    for _ in range(args.steps):
        before = len(settles)
        iterations.clear()
        t0, c0 = time.perf_counter(), time.process_time()
        record = problem.advance()
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
        # the other tree's settles (--against) are not this tree's step
        seconds -= sum(s.get("against_seconds", 0.0) for s in settles[before:])
        cpu -= sum(s.get("against_cpu", 0.0) for s in settles[before:])
        steps.append(
            {
                "seconds": seconds,
                "cpu": cpu,
                "changes": int(record["changes"]),
                "settles": len(settles) - before,
                "settle_cpu": sum(s["cpu"] for s in settles[before:]),
                # without the change iterations (after the first): paper_scale.py's step
                "base_cpu": cpu - sum(iterations[1:]),
                "force": [float(f) for f in np.ravel(record["force"]["end"])],
                "active": int(record["active"]["end"]),
            }
        )
    state = problem.analysis.state_now()
    np.savez(Path(args.out).with_suffix(".npz"), **{str(k): v for k, v in state.items()})
    problem.close()
    return {
        "label": args.label,
        "scale": args.scale,
        "modes": args.modes,
        "build": build,
        "steps": steps,
        "settles": settles,
        "summary": summary(steps, settles),
        "peak_rss_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0**2,
        "profile_first": _top(first),
        "profile_others": _top(later),
    }


def _module(path: str):
    """Another tree's ``settle.py`` as a module of its own (``--against``)."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("settle_against", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["settle_against"] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def _other(module, a: tuple) -> tuple[dict, dict]:
    """The other tree's settle of the same arguments (its own kept parts), timed."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = module.in_equilibrium(*a[:8])  # without this tree's Settles
    return out, {
        "against_seconds": time.perf_counter() - t0,
        "against_cpu": time.process_time() - c0,
    }


def summary(steps: list[dict], settles: list[dict]) -> dict:
    """Mean step, quiet and release steps (medians, CPU), first and later settles.

    The later settles' median is of those not profiled.
    """
    later = steps[1:]  # the first step carries the first factorisations
    quiet = [s["cpu"] for s in later if not s["changes"]]
    release = [s["cpu"] for s in later if s["settles"]]
    base = [s["base_cpu"] for s in later if s["settles"]]
    against = {}
    if settles and "against_cpu" in settles[0]:
        against = {
            "against_first_settle_cpu": settles[0]["against_cpu"],
            "against_later_settle_cpu_median": statistics.median(
                s["against_cpu"] for s in settles[1 + PROFILED :] or settles[1:]
            ),
            "against_largest_difference": max(s["against_difference"] for s in settles),
        }
    return against | {
        "mean_step_cpu": statistics.mean(s["cpu"] for s in later),
        "mean_base_cpu": statistics.mean(s["base_cpu"] for s in later),
        "quiet_step_cpu_median": statistics.median(quiet) if quiet else None,
        "release_step_cpu_median": statistics.median(release) if release else None,
        "release_base_cpu_median": statistics.median(base) if base else None,
        "release_steps": len(release),
        "first_settle_cpu": settles[0]["cpu"] if settles else None,
        "later_settle_cpu_median": (
            statistics.median(s["cpu"] for s in settles[1 + PROFILED :] or settles[1:])
            if len(settles) > 1
            else None
        ),
        "settles": len(settles),
    }


def compare(a: Path, b: Path) -> dict:
    """Largest differences of two runs' force histories and final states, relative."""
    ra, rb = json.loads(a.read_text()), json.loads(b.read_text())
    fa = np.array([s["force"] for s in ra["steps"]])
    fb = np.array([s["force"] for s in rb["steps"]])
    xa, xb = np.load(a.with_suffix(".npz")), np.load(b.with_suffix(".npz"))
    return {
        "force": float(np.abs(fa - fb).max() / max(np.abs(fa).max(), 1e-300)),
        "active_equal": [s["active"] for s in ra["steps"]] == [s["active"] for s in rb["steps"]],
        "state": {
            k: float(np.abs(xa[k] - xb[k]).max() / max(np.abs(xa[k]).max(), 1e-300)) for k in xa
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scale", default="1/16")
    parser.add_argument("--modes", type=int, default=160)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--label", default="")
    parser.add_argument("--out", default=str(HERE / "settle_cost.json"))
    parser.add_argument("--against", help="another tree's settle.py, run on each settle too")
    parser.add_argument("--compare", nargs=2, type=Path, help="two runs' answers")
    parser.add_argument("--merge", nargs="+", type=Path, help="runs into --out, compared")
    parser.add_argument("--note", default="")
    args = parser.parse_args()
    if args.compare:
        print(json.dumps(compare(*args.compare), indent=1))
        return
    if args.merge:
        runs = {path.stem: json.loads(path.read_text()) for path in args.merge}
        first = args.merge[0]
        merged = {
            "note": args.note,
            "runs": runs,
            "summary": {
                k: r["summary"] | {"peak_rss_gib": r["peak_rss_gib"]} for k, r in runs.items()
            },
            "answers_against_" + first.stem: {p.stem: compare(first, p) for p in args.merge[1:]},
        }
        Path(args.out).write_text(json.dumps(merged, indent=1) + "\n")
        return
    record = run(args)
    Path(args.out).write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record["summary"], indent=1))


if __name__ == "__main__":
    main()
