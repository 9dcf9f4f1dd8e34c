"""A trade study: run a scene's design, each run in its own process, and write what it measured.

:func:`run_study` runs the default, every knob alone, then combined moves along the front
(:mod:`.design`), each run in a worker process (:mod:`.worker`: its peak memory is its own).
After every run the JSON is rewritten whole (atomically), so a study that is killed keeps
what it measured; SIGTERM and a ``budget`` stop it gracefully (a run still going when the
budget runs out is stopped and recorded as such) and it still writes the JSON and the chart.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import dd_contact
from dd_contact.paper.tradeoff.design import (
    Run,
    combined_design,
    default_verdict,
    first_design,
    pareto_front,
)
from dd_contact.paper.tradeoff.scenes import TradeScene

__all__ = ["BudgetExceeded", "Runner", "refresh", "run_in_process", "run_study"]

#: ``(scene name, settings, timeout seconds or None) -> measured dict`` (see :mod:`.worker`).
Runner = Callable[[str, dict[str, Any], float | None], dict[str, Any]]

#: Environment variables of an MPI launcher a worker must not inherit (it runs alone).
_LAUNCHER_PREFIXES = ("PMI_", "PMIX_", "OMPI_", "HYDRA_", "HYDI_", "MPIR_", "I_MPI_")


#: The default's extra runs, off the front, and their labels.
_EXTRA = {"warm-up": "default, warm-up", "repeat": "default, repeated"}


class BudgetExceeded(Exception):
    """A run was stopped because the study's budget ran out."""


class _Terminated(Exception):
    """The study got SIGTERM."""


def _raise_terminated(signum: int, frame: Any) -> None:
    raise _Terminated


def _catch_sigterm() -> Any:
    """Turn SIGTERM into :class:`_Terminated` (main thread only); the previous handler."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


def _worker_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(_LAUNCHER_PREFIXES)}
    root = str(Path(dd_contact.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
    return env


def run_in_process(scene: str, settings: dict[str, Any], timeout: float | None) -> dict[str, Any]:
    """One run in a worker process; ``failed`` (the end of its stderr) if it did not finish.

    Adds ``process_seconds``: the worker's whole life (interpreter start and imports too).
    Raises :class:`BudgetExceeded` (the worker killed) past ``timeout`` seconds.
    """
    with tempfile.TemporaryDirectory(prefix="dd_contact_tradeoff_") as tmp:
        job, out = Path(tmp, "job.json"), Path(tmp, "out.json")
        job.write_text(json.dumps({"scene": scene, "settings": settings}))
        command = [sys.executable, "-m", "dd_contact.paper.tradeoff.worker", str(job), str(out)]
        start = time.perf_counter()
        proc = subprocess.Popen(
            command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=_worker_env(), text=True
        )
        try:
            _, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()  # the worker this call started
            proc.communicate()
            raise BudgetExceeded from None
        except BaseException:  # the study is stopped: so is its worker
            proc.kill()
            proc.communicate()
            raise
        if proc.returncode != 0 or not out.exists():
            tail = " | ".join(err.strip().splitlines()[-3:])
            return {"failed": f"exit {proc.returncode}: {tail}"}
        result = json.loads(out.read_text())
    result["process_seconds"] = time.perf_counter() - start
    return result


def _knobs_json(scene: TradeScene) -> list[dict]:
    return [
        {
            "name": k.name,
            "default": k.default,
            "kind": k.kind,
            "what": k.what,
            "levels": [{"value": lv.value, "needs": lv.needs} for lv in k.levels],
        }
        for k in scene.knobs
    ]


class _Study:
    """The records of a study and its JSON file."""

    def __init__(self, scene: TradeScene, budget: float | None, json_path: Path | None):
        self.scene, self.budget, self.json_path = scene, budget, json_path
        self.started = time.perf_counter()
        self.records: list[dict] = []
        self.stopped: str | None = None
        self.load = [os.getloadavg()[0]]

    def remaining(self) -> float | None:
        if self.budget is None:
            return None
        return self.budget - (time.perf_counter() - self.started)

    def record(self, run: Run, result: dict[str, Any]) -> dict:
        rec: dict[str, Any] = {
            "settings": run.settings,
            "changed": _EXTRA.get(run.phase, run.changed),
            "changes": run.changes,
            "phase": run.phase,
            "kind": run.kind,
            "default": run.phase == "default",
            "error": None,
            "seconds": None,
            "cpu_seconds": None,
            "peak_mib": None,
            **result,
        }
        self.records.append(rec)
        return rec

    def measured(self) -> list[dict]:
        """The records that compete for the front (not the default's warm-up and repeat)."""
        return [r for r in self.records if r["phase"] not in _EXTRA]

    def document(self) -> dict[str, Any]:
        points = self.measured()
        front = pareto_front(points)
        front_cpu = pareto_front(points, "cpu_seconds")
        default = next((r for r in points if r["default"] and r["error"] is not None), None)
        for r in self.records:
            r["on_front"] = any(r is p for p in front)
            r["on_front_cpu"] = any(r is p for p in front_cpu)
            if default is not None and r["error"] is not None and r is not default:
                r["time_factor"] = r["seconds"] / default["seconds"]
                r["cpu_factor"] = r["cpu_seconds"] / default["cpu_seconds"]
                r["error_factor"] = r["error"] / default["error"] if default["error"] else None
        return {
            "scene": self.scene.name,
            "error_measure": self.scene.error,
            "reference": self.scene.reference,
            "knobs": _knobs_json(self.scene),
            "budget_seconds": self.budget,
            "elapsed_seconds": time.perf_counter() - self.started,
            "stopped": self.stopped,
            "machine": {"cpus": os.cpu_count(), "load_average_1min": self.load},
            "runs": self.records,
            "front": [self.records.index(p) for p in front],
            "front_cpu": [self.records.index(p) for p in front_cpu],
            "default_verdict": default_verdict(points),
            "default_verdict_cpu": default_verdict(points, "cpu_seconds"),
            "default_verdict_best_of_two": _best_of_two(points, self.records),
            "noise": _noise(self.records),
        }

    def write(self) -> dict[str, Any]:
        doc = self.document()
        if self.json_path is not None:
            tmp = self.json_path.with_name(self.json_path.name + ".tmp")
            tmp.write_text(json.dumps(doc, indent=1))
            os.replace(tmp, self.json_path)  # a killed study leaves the last whole file
        return doc


def _best_of_two(points: list[dict], records: list[dict]) -> dict[str, Any] | None:
    """The default's verdicts with it timed as the lesser of its run and its repeat.

    Other jobs on the machine only ever add time: the lesser of two measurements of one
    run is the nearer to its own cost.
    """
    repeat = next((r for r in records if r["phase"] == "repeat" and r["seconds"]), None)
    if repeat is None:
        return None
    timed = []
    for p in points:
        if p["phase"] == "default" and p["seconds"]:
            p = {**p, **{k: min(p[k], repeat[k]) for k in ("seconds", "cpu_seconds")}}
        timed.append(p)
    return {"wall": default_verdict(timed), "cpu": default_verdict(timed, "cpu_seconds")}


def refresh(doc: dict[str, Any], scene: TradeScene) -> dict[str, Any]:
    """``doc`` (a study's JSON) with its fronts and verdicts computed again from its runs."""
    study = _Study(scene, doc["budget_seconds"], None)
    study.records, study.stopped = doc["runs"], doc["stopped"]
    study.load = doc["machine"]["load_average_1min"]
    return {**study.document(), "elapsed_seconds": doc["elapsed_seconds"]}


def _noise(records: list[dict]) -> dict[str, Any] | None:
    """The default and its repeat: how far two measurements of one run lie apart."""
    same = [r for r in records if r["phase"] in ("default", "repeat") and r["seconds"]]
    if len(same) < 2:
        return None
    wall = [r["seconds"] for r in same]
    cpu = [r["cpu_seconds"] for r in same]
    return {
        "seconds": wall,
        "cpu_seconds": cpu,
        "wall_spread": max(wall) / min(wall) - 1.0,
        "cpu_spread": max(cpu) / min(cpu) - 1.0,
    }


def _line(study: _Study, rec: dict, count: int) -> str:
    head = f"[{count:>2}] {study.scene.name}: {rec['changed']:<44}"
    if rec.get("stopped"):
        return f"{head} stopped by the budget"
    if rec.get("failed"):
        return f"{head} FAILED {rec['failed'][:120]}"
    elapsed = time.perf_counter() - study.started
    budget = f" of {study.budget:.0f}" if study.budget is not None else ""
    return (
        f"{head} error {rec['error']:.2e}  {rec['seconds']:6.1f} s  cpu {rec['cpu_seconds']:6.1f}"
        f" s  {rec['peak_mib']:5.0f} MiB  (elapsed {elapsed:.0f} s{budget})"
    )


def _run_all(study: _Study, runs: list[Run], runner: Runner, say: Callable[[str], None]) -> bool:
    """Run ``runs`` in order; False once the budget stopped the study."""
    for run in runs:
        remaining = study.remaining()
        if remaining is not None and remaining <= 0:
            study.stopped = "budget"
            return False
        try:
            result = runner(study.scene.name, run.settings, remaining)
        except BudgetExceeded:
            result = {"stopped": "budget"}
            study.stopped = "budget"
        rec = study.record(run, result)
        study.write()
        say(_line(study, rec, len(study.records)))
        if study.stopped:
            return False
    return True


def _run_phases(study: _Study, limit: int, runner: Runner, say: Callable[[str], None]) -> bool:
    """The cheap one-knob runs, the cheap combined ones, then the costly ones of both.

    A study cut short by its budget has measured the most points; the combined runs are
    planned again once the costly one-knob runs are in (at most ``limit`` in all).
    """
    knobs = study.scene.knobs
    first = first_design(knobs)
    going = _run_all(study, [r for r in first if not r.costly], runner, say)
    if going:
        plan = combined_design(knobs, study.measured(), limit)
        going = _run_all(study, [r for r in plan if not r.costly], runner, say)
    if going:
        going = _run_all(study, [r for r in first if r.costly], runner, say)
    if going:
        done = sum(r["phase"] == "combined" for r in study.records)
        plan = combined_design(knobs, study.measured(), limit - done)
        going = _run_all(study, plan, runner, say)
    return going


def run_study(
    scene: TradeScene,
    budget: float | None = None,
    json_path: str | Path | None = None,
    plot_path: str | Path | None = None,
    combined_limit: int = 16,
    repeat_default: bool = True,
    warm_up: bool = True,
    runner: Runner = run_in_process,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Run the trade study of ``scene``; the JSON document (also written to ``json_path``).

    Args:
        scene: The scene, its knobs and reference.
        budget: Seconds the study may take (None: no limit).
        json_path: Where the JSON is written, after every run.
        plot_path: Where the Pareto chart is drawn at the end.
        combined_limit: Most combined runs after the one-knob runs.
        repeat_default: Run the default once more at the end (the noise of the timing).
        warm_up: Run the default once first, off the front: the first run of a study
            reads the libraries and compiled forms from disk (seen: 2-3x the wall time).
        runner: How one run is done (default: in a worker process).
        say: Where progress lines go.
    """
    study = _Study(scene, budget, Path(json_path) if json_path is not None else None)
    say(f"trade study of {scene.name}: error = {scene.error.split(':')[0]}")
    previous = _catch_sigterm()
    base = first_design(scene.knobs)[0].settings
    try:
        going = not warm_up or _run_all(study, [Run(base, {}, "warm-up", "warm-up")], runner, say)
        going = going and _run_phases(study, combined_limit, runner, say)
        if going and repeat_default:
            _run_all(study, [Run(dict(base), {}, "repeat", "repeat")], runner, say)
    except _Terminated:
        study.stopped = "SIGTERM"
        say("stopped by SIGTERM")
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        study.load.append(os.getloadavg()[0])
        doc = study.write()
        if plot_path is not None:
            from dd_contact.paper.tradeoff.chart import draw_front

            draw_front(doc, plot_path)
    return doc
