"""One run of a trade study, in a process of its own (so that its peak memory is its own).

``python -m dd_contact.paper.tradeoff.worker IN OUT``: reads ``{"scene", "settings"}`` from
the JSON file IN, runs the scene's measure and writes to OUT its error and
parts with the run's wall time and CPU time (from before the scene is built to after the
error is computed: mesh generation, assembly, solves), the process's peak resident memory
(``ru_maxrss``) and its resident memory before the run (imports only).
"""

from __future__ import annotations

import json
import resource
import sys
import time
from typing import Any

__all__ = ["measure_run"]


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


def measure_run(scene_name: str, settings: dict[str, Any]) -> dict[str, Any]:
    """Run ``settings`` on the scene; its error, parts, seconds, CPU seconds and memory."""
    import dd_contact.paper.verify  # noqa: F401  (imported before the clock starts)
    from dd_contact.paper.tradeoff.scenes import scene

    chosen = scene(scene_name)
    baseline = _peak_mib()
    start, cpu = time.perf_counter(), _cpu_seconds()
    result = chosen.measure(settings)
    return {
        **result,
        "seconds": time.perf_counter() - start,
        "cpu_seconds": _cpu_seconds() - cpu,
        "peak_mib": _peak_mib(),
        "baseline_mib": baseline,
    }


def main(argv: list[str]) -> int:
    """Entry point: ``worker IN OUT``."""
    with open(argv[0]) as f:
        job = json.load(f)
    out = measure_run(job["scene"], job["settings"])
    with open(argv[1], "w") as f:
        json.dump(out, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
