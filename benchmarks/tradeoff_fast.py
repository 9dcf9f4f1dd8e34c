"""Can a "fast" preset be 5x faster than "balanced" on the bar at <= 5 % error? (issue 25)

Three parts, each run in this one process (one BLAS thread; the scene's forms compiled by a
warm-up run first), written to ``benchmarks/results/tradeoff_fast.json`` with the load
average:

* ``candidates``: the bar-impact trade scene (split, 4 x 4 across) at n = 40 and 20 with
  every step (1, 2, 2.5, 3, 4 wave times), scheme (trapezoidal, generalized-alpha with
  rho_inf 0.8 and 0.5) and mass (consistent, lumped, averaged): what a preset owns on the
  user's mesh (n = 40) and on one twice as coarse (n = 20, a builder taking the preset).
  Error, the duration's and plateau's errors, steps and CPU seconds of each, once (the
  errors are exact; the times are for the ranking, ``--repeats`` medians below);
* ``waste``: the default run (n = 40, balanced) before and after two cuts, each alone and
  both, ``--repeats`` times interleaved, medians of CPU seconds: the end face's per-step
  readings (``bar_impact(watch=...)``; the trade scene now runs without) and the contact
  operator's matrix reused while the active set stays (``ContactOperator.reuse``; an
  unmasked contact matrix when no surface dof is prescribed is in every variant);
* ``profile``: cProfile of one default run: the functions with the most cumulative and own
  CPU time, and what they are.

Usage: OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/tradeoff_fast.py
    [--repeats 5]
"""

from __future__ import annotations

import argparse
import cProfile
import itertools
import json
import os
import pstats
import statistics
import time
import warnings
from pathlib import Path

from dd_contact.contact import ContactOperator
from dd_contact.paper.tradeoff import scene
from dd_contact.paper.tradeoff.design import defaults
from dd_contact.paper.verify import bar_impact

OUT = Path(__file__).parent / "results" / "tradeoff_fast.json"
SCHEMES = [("trapezoidal", None), ("generalized-alpha", 0.8), ("generalized-alpha", 0.5)]
MASSES = ("consistent", "lumped", "averaged")


def _candidates() -> list[dict]:
    trade = scene("bar-impact")
    base = defaults(trade.knobs)
    trade.measure(dict(base))  # warm-up: the forms compiled, the libraries read
    runs = []
    grid = itertools.product((40, 20), (1.0, 2.0, 2.5, 3.0, 4.0), SCHEMES, MASSES)
    for n, cfl, (name, rho), mass in grid:
        settings = {**base, "n": n, "cfl": cfl, "scheme": name, "rho_infinity": rho}
        start = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the coarse-step warning above CFL 1
            result = trade.measure({**settings, "mass": mass})
        parts = result["parts"]
        runs.append({"n": n, "cfl": cfl, "scheme": name, "rho_infinity": rho, "mass": mass,
                     "error": result["error"], "duration": parts["duration"],
                     "plateau": parts["plateau_force"], "steps": parts["steps"],
                     "cpu_seconds": time.process_time() - start})  # fmt: skip
        print(runs[-1], flush=True)
    return runs


def _bar(watch: bool) -> float:
    start = time.process_time()
    bar_impact(n=40, cfl=1.0, split=True, interface_resolution=(4, 4), across=4, watch=watch)
    return time.process_time() - start


#: The cuts measured, each alone and together: (the end face's readings, the contact
#: operator's matrix reused while the active set stays).
VARIANTS = {"before": (True, False), "no watch": (False, False), "reuse": (True, True),
            "after": (False, True)}  # fmt: skip


def _waste(repeats: int) -> dict:
    times: dict[str, list[float]] = {name: [] for name in VARIANTS}
    for _ in range(repeats):
        for name, (watch, reuse) in VARIANTS.items():
            ContactOperator.reuse = reuse
            times[name].append(_bar(watch))
    ContactOperator.reuse = True
    medians = {key: statistics.median(value) for key, value in times.items()}
    return {"cpu_seconds": times, "median": medians,
            "ratio": {key: m / medians["before"] for key, m in medians.items()}}  # fmt: skip


def _profile() -> dict:
    profile = cProfile.Profile()
    profile.enable()
    _bar(False)
    profile.disable()
    stats = pstats.Stats(profile)
    rows = [
        {"function": f"{Path(file).name}:{line}({name})", "calls": calls, "own": own,
         "cumulative": cumulative}
        for (file, line, name), (_, calls, own, cumulative, _) in stats.stats.items()  # type: ignore[attr-defined]
    ]  # fmt: skip
    top = {key: sorted(rows, key=lambda r: -r[key])[:25] for key in ("cumulative", "own")}
    return {"total": stats.total_tt, **top}  # type: ignore[attr-defined]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    doc: dict = {"load_average_before": os.getloadavg()}
    doc["candidates"] = _candidates()
    doc["waste"] = _waste(args.repeats)
    doc["profile"] = _profile()
    doc["load_average_after"] = os.getloadavg()
    OUT.write_text(json.dumps(doc, indent=1))
    print(json.dumps(doc["waste"]), f"wrote {OUT}")


if __name__ == "__main__":
    main()
