"""Whether a benchmark got slower from one checkout to another: CPU time, interleaved.

Runs a benchmark script (this checkout's copy) with ``PYTHONPATH`` set to each of two
checkouts in turn (A, B, A, B, ...), each run its own process tree with every BLAS on one
thread, and records per run the CPU seconds of the process and every child it waited for
(``os.wait4``: user + system), the wall seconds and the peak memory (max RSS of the
largest of those processes). Reported: the medians per checkout and their ratio (branch
over main: above 1 is slower), and the benchmark's own JSON of each checkout's last run.

    python benchmarks/surfaces_cost.py --name lowrank_change --repeats 3 \
        -- benchmarks/lowrank_change.py --scale 3,2,1,4 --trials 2 --repeats 1

The script's ``--out`` is set here (a directory, or a file with ``--out-file``): its JSON
lands in a scratch directory and is copied into this one's. Writes
benchmarks/results/<name>_surfaces.json (``--out``) after every run.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).parent
ROOT = HERE.parent


def run_once(script: list[str], checkout: str, out: Path, out_file: bool) -> dict:
    """One run of the script with ``checkout`` 's dd_contact: seconds, memory, its JSON."""
    out.mkdir(parents=True, exist_ok=True)
    target = out / "result.json" if out_file else out
    env = dict(os.environ, PYTHONPATH=checkout, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env["MKL_NUM_THREADS"] = "1"
    command = [sys.executable, *script, "--out", str(target)]
    start = time.perf_counter()
    child = subprocess.Popen(command, env=env, cwd=ROOT, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - start
    if child.returncode:
        raise SystemExit(f"{command} with {checkout}: exit code {child.returncode}")
    results = sorted(out.glob("*.json"))
    return {
        "checkout": checkout,
        "cpu_seconds": usage.ru_utime + usage.ru_stime,
        "wall_seconds": wall,
        "peak_rss_mb": usage.ru_maxrss / 1024.0,
        "load_average": os.getloadavg(),
        "result": json.loads(results[-1].read_text()) if results else None,
    }


def summary(runs: list[dict], checkouts: dict[str, str]) -> dict:
    """Medians per checkout and the branch's over main's."""
    out: dict = {}
    for label, checkout in checkouts.items():
        mine = [r for r in runs if r["checkout"] == checkout]
        if not mine:
            out[label] = {"runs": 0}
            continue
        out[label] = {
            key: statistics.median(r[key] for r in mine)
            for key in ("cpu_seconds", "wall_seconds", "peak_rss_mb")
        }
        out[label]["runs"] = len(mine)
    if all(out[label]["runs"] for label in checkouts):
        out["ratio"] = {
            key: out["branch"][key] / out["main"][key]
            for key in ("cpu_seconds", "wall_seconds", "peak_rss_mb")
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--name", required=True, help="the JSON's name: <name>_surfaces.json")
    parser.add_argument("--main", default="/work/main", help="the checkout compared against")
    parser.add_argument("--branch", default=str(ROOT), help="the checkout measured")
    parser.add_argument("--repeats", type=int, default=3, help="runs per checkout")
    parser.add_argument("--out-file", action="store_true", help="the script's --out: a file")
    parser.add_argument("--out", default=str(HERE / "results"))
    parser.add_argument("script", nargs=argparse.REMAINDER, help="-- script and its arguments")
    args = parser.parse_args()
    script = args.script[1:] if args.script[:1] == ["--"] else args.script
    checkouts = {"main": args.main, "branch": args.branch}
    path = Path(args.out) / f"{args.name}_surfaces.json"
    runs: list[dict] = []
    with tempfile.TemporaryDirectory() as scratch:
        for repeat in range(args.repeats):
            for label, checkout in checkouts.items():  # interleaved: A, B, A, B
                out = Path(scratch) / f"{label}{repeat}"
                runs.append(run_once(script, checkout, out, args.out_file))
                report = {
                    "command": script,
                    "checkouts": checkouts,
                    "blas_threads": 1,
                    "summary": summary(runs, checkouts),
                    "runs": [{k: v for k, v in r.items() if k != "result"} for r in runs],
                    "results": {
                        label: next(
                            (r["result"] for r in reversed(runs) if r["checkout"] == c), None
                        )
                        for label, c in checkouts.items()
                    },
                }
                path.write_text(json.dumps(report, indent=1))
                print(label, repeat, json.dumps(runs[-1]["cpu_seconds"]), flush=True)
    print(json.dumps(report["summary"], indent=1))


if __name__ == "__main__":
    main()
