"""A benchmark's worker process watched from the parent: its memory, the load, its record.

The worker prints its JSON record on stdout and its progress lines on stderr (the log);
the parent samples the resident memory of the worker's process tree and the machine's load
average twice a second and kills the worker above a memory limit.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import threading
import time
from pathlib import Path


def tree_rss_gib(pid: int) -> float:
    """Resident memory of a process and all its descendants [GiB] (from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            children.setdefault(int(fields[1]), []).append(int(entry))
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        todo += children.get(p, [])
        try:
            for line in Path(f"/proc/{p}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
        except OSError:
            continue
    return total / 1024.0**2


def timed_run(command: list[str], env: dict, limit_gib: float, log: Path) -> dict:
    """:func:`watched`'s record with its samples' summary and the run's wall time."""
    started = time.perf_counter()
    record, samples = watched(command, env, limit_gib, log)
    record.update(samples, wall_seconds=time.perf_counter() - started)
    return record


def watched(command: list[str], env: dict, limit_gib: float, log: Path) -> tuple[dict, dict]:
    """Run a worker, sampling its tree's memory and the load average; kill it above the limit.

    Returns the worker's JSON record (or ``{"failed": reason}``) and the samples' summary.
    """
    peak, loads, killed = [0.0], [], []
    with open(log, "w") as err:
        process = subprocess.Popen(
            command, env=env, stdout=subprocess.PIPE, stderr=err, text=True, start_new_session=True
        )

        def watch():
            while process.poll() is None:
                rss = tree_rss_gib(process.pid)
                peak[0] = max(peak[0], rss)
                loads.append(os.getloadavg()[0])
                if rss > limit_gib and not killed:
                    killed.append(rss)
                    os.killpg(process.pid, 9)  # our own worker's process group
                time.sleep(0.5)

        watcher = threading.Thread(target=watch, daemon=True)
        watcher.start()
        stdout, _ = process.communicate()
        watcher.join()
    samples = {
        "peak_tree_rss_gib": peak[0],
        "load_average_mean": statistics.fmean(loads) if loads else None,
        "load_average_max": max(loads) if loads else None,
    }
    if killed:
        reason = f"killed above the memory limit ({killed[0]:.1f} GiB)"
        return {"failed": reason, "steps_done": steps_logged(log)}, samples
    lines = [line for line in stdout.splitlines() if line.startswith("{")]
    if process.returncode != 0 or not lines:
        tail = log.read_text().splitlines()[-5:]
        reason = f"exit code {process.returncode}: {' | '.join(tail)}"
        return {"failed": reason, "steps_done": steps_logged(log)}, samples
    return json.loads(lines[-1]), samples


def steps_logged(log: Path) -> list[dict]:
    """The steps a worker finished before it stopped (its progress lines on stderr)."""
    steps = []
    for line in log.read_text().splitlines():
        if line.startswith('{"progress"'):
            steps.append(json.loads(line)["progress"])
    return steps
