"""``dd-contact tradeoff SCENE [--budget SECONDS] [--json FILE] [--plot FILE]``."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from dd_contact.paper.tradeoff.scenes import SCENES, scene
from dd_contact.paper.tradeoff.study import run_study

__all__ = ["add_command"]


def _positive_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text}")
    return value


def _path_problem(option: str, path: str) -> str | None:
    """What is wrong with an output path (None: nothing)."""
    directory = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        return f"{option} {path} is a directory; give a file name"
    if not os.path.isdir(directory):
        return f"{option} {path}: directory {directory} does not exist"
    if not os.access(directory, os.W_OK):
        return f"{option} {path}: directory {directory} is not writable"
    return None


def _process_age() -> float:
    """Seconds since this process started (its imports too); 0 where /proc is not there."""
    try:
        start_ticks = float(open("/proc/self/stat").read().rsplit(")", 1)[1].split()[19])
        uptime = float(open("/proc/uptime").read().split()[0])
    except (OSError, IndexError, ValueError):
        return 0.0
    return max(0.0, uptime - start_ticks / os.sysconf("SC_CLK_TCK"))


def _study_budget(budget: float | None) -> float | None:
    """The study's share of ``--budget``, so that the whole command ends within it.

    The budget less the process's age so far (its imports) and a reserve for the chart (5 %,
    at most 15 s): under a load average of 17 those took 11 s beyond the study.
    """
    if budget is None:
        return None
    return budget - _process_age() - min(0.05 * budget, 15.0)


def _tradeoff(args: argparse.Namespace) -> int:
    if args.comm.size > 1:
        if args.comm.rank == 0:
            print(
                "dd-contact tradeoff: error: run it on one rank (each run starts a process "
                "of its own); drop mpiexec",
                file=sys.stderr,
            )
        return 2
    json_path = args.json or f"tradeoff_{args.scene}.json"
    plot_path = args.plot or f"tradeoff_{args.scene}.png"
    for option, path in (("--json", json_path), ("--plot", plot_path)):
        problem = _path_problem(option, path)
        if problem is not None:
            print(f"dd-contact tradeoff: error: {problem}", file=sys.stderr)
            return 2
    budget = _study_budget(args.budget)
    doc = run_study(scene(args.scene), budget, json_path, plot_path, combined_limit=args.combined)
    verdict = doc["default_verdict"]
    front = " | ".join(doc["runs"][i]["changed"] for i in doc["front"])
    print(f"front ({len(doc['front'])} of {len(doc['runs'])} runs): {front}")
    if verdict.get("good") is not None:
        where = "on the front" if verdict["on_front"] else "off the front"
        ratio = verdict["time_ratio"]
        print(f"the default is {where}: {ratio:.2f}x the front's time at its error")
    if doc["stopped"]:
        print(f"stopped by the budget of {args.budget:g} s")
    print(f"wrote {json_path} and {plot_path}")
    return 0


def add_command(sub: Any) -> None:
    """Add ``tradeoff`` to the ``dd-contact`` sub-commands ``sub``."""
    parser = sub.add_parser(
        "tradeoff",
        help="measure a scene's speed/accuracy trade: a Pareto front of its settings",
        description="Run a designed set of settings on a scene (the default, each knob alone, "
        "then combined moves along the front), each in its own process; measure each run's "
        "error against the scene's reference, its wall time, CPU time and peak memory; write "
        "JSON after every run and a Pareto chart at the end (docs/tradeoff.md).",
    )
    parser.add_argument("scene", choices=sorted(SCENES), help="the scene")
    parser.add_argument(
        "--budget",
        type=_positive_seconds,
        default=None,
        metavar="SECONDS",
        help="stop after this many seconds (the JSON and chart are still written)",
    )
    parser.add_argument("--json", metavar="FILE", help="default: tradeoff_SCENE.json")
    parser.add_argument("--plot", metavar="FILE", help="default: tradeoff_SCENE.png")
    parser.add_argument(
        "--combined",
        type=int,
        default=16,
        metavar="N",
        help="most combined runs after the one-knob runs (default 16)",
    )
    parser.set_defaults(run=_tradeoff)
