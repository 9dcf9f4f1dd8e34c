"""Memory a transient problem holds before its first factorisation (issue 14 item 2).

Builds ``models.parallelepiped`` at ``--elements`` (141 x 35 x 10 hexahedra: about 170k
dofs, 1/8 of the paper's bar) for each algorithm in its own process, the
``TransientProblem`` included, and stops before the first step (FULL's and the orders'
factorisations happen there). Per phase it records the process's resident memory kept at
the end of the phase (``VmRSS`` after ``gc.collect`` and glibc's ``malloc_trim``) and its
peak within the phase (``VmHWM``, reset at each phase's start through
``/proc/self/clear_refs``), in MB and per dof:

- ``scene``: the dolfinx meshes, function spaces and the scene's objects;
- ``assembly``: ``dd_contact.assembly.assemble`` (stiffness, mass, tie operators, zones);
- ``system``: the rest of the ``Analysis`` before the solver (effective matrix K + c M,
  lifting, contact checks);
- ``solver``: the solver's build (FULL's PETSc matrix; the orders' COO arrays, MUMPS
  instances and the dense surface base);
- ``problem``: the rest of the problem (residual check, results, load forms).

``--tracemalloc`` also lists the source lines that hold the most Python-allocated memory
(numpy arrays included; PETSc's and MUMPS's own memory is not traced) after the build.

Writes ``benchmarks/results/setup_memory.json`` under ``--label`` (``before``/``after``),
keeping the other labels in the file.

Run: python benchmarks/setup_memory.py --label after [--elements 141,35,10]
     [--algorithms FULL w-v-u] [--tracemalloc]
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import subprocess
import sys
import time
from pathlib import Path

OUT = Path(__file__).parent / "results" / "setup_memory.json"
MB = 1e6
PINNED = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _status_kb(field: str) -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"/proc/self/status has no {field}")


def _reset_peak() -> None:
    """Start a new VmHWM from the current resident size (Linux's clear_refs, value 5)."""
    with open("/proc/self/clear_refs", "w") as refs:
        refs.write("5")


class Phases:
    """Kept and peak resident memory of consecutive phases of one process."""

    def __init__(self, trim):
        self.trim, self.records, self._start = trim, [], time.perf_counter()
        self.close("start")

    def close(self, name: str) -> None:
        peak = _status_kb("VmHWM") * 1e3
        gc.collect()
        self.trim()
        kept = _status_kb("VmRSS") * 1e3
        self.records.append(
            {
                "phase": name,
                "kept_mb": round(kept / MB, 1),
                "peak_mb": round(peak / MB, 1),
                "seconds": round(time.perf_counter() - self._start, 2),
            }
        )
        _reset_peak()
        self._start = time.perf_counter()


def worker(args) -> dict:
    """One algorithm: scene, assembly, system, solver, problem; the memory of each."""
    import tracemalloc

    from mpi4py import MPI

    if args.tracemalloc:
        tracemalloc.start(40)

    import dd_contact as dc
    from dd_contact import analysis, models
    from dd_contact.solvers.linalg import release_freed_memory

    phases = Phases(release_freed_memory)
    elements = tuple(int(n) for n in args.elements.split(","))
    layout = "w-u" if args.worker == "w-u" else None
    scene = models.parallelepiped(elements, algorithm=layout, comm=MPI.COMM_WORLD)
    phases.close("scene")

    # phase boundaries inside the Analysis (measurement only; the calls are unchanged)
    assemble, use = analysis.assemble, analysis.Analysis._use

    def assemble_and_close(*a, **k):
        model = assemble(*a, **k)
        phases.close("assembly")
        return model

    def use_and_close(self, *a, **k):
        phases.close("system")
        use(self, *a, **k)
        phases.close("solver")

    analysis.assemble, analysis.Analysis._use = assemble_and_close, use_and_close
    problem = dc.TransientProblem(scene, args.dt, algorithm=args.worker, track_energy=False)
    phases.close("problem")
    dofs = sum(problem.model.system.sizes.values())
    for record in phases.records:
        record["kept_bytes_per_dof"] = round(record["kept_mb"] * MB / dofs)
    base = phases.records[0]["kept_mb"]
    out = {
        "algorithm": args.worker,
        "elements": list(elements),
        "dofs": dofs,
        "phases": phases.records,
        "kept_over_import_mb": round(phases.records[-1]["kept_mb"] - base, 1),
        "kept_over_import_bytes_per_dof": round((phases.records[-1]["kept_mb"] - base) * MB / dofs),
        "peak_mb": max(r["peak_mb"] for r in phases.records),
    }
    if args.tracemalloc:
        out["python_held_mb"] = _held_by_our_lines(tracemalloc.take_snapshot(), args.top)
    problem.close()
    return out


def _held_by_our_lines(snapshot, top: int) -> dict[str, float]:
    """Python-allocated memory alive, by the innermost dd_contact line that allocated it."""
    held: dict[str, float] = {}
    for stat in snapshot.statistics("traceback"):
        ours = [f for f in stat.traceback if "/dd_contact/" in f.filename]
        frame = ours[-1] if ours else stat.traceback[-1]  # frames run oldest to newest
        where = f"{frame.filename.split('/dd_contact/')[-1]}:{frame.lineno}"
        held[where] = held.get(where, 0.0) + stat.size / MB
    ranked = sorted(held.items(), key=lambda item: -item[1])[:top]
    return {where: round(size, 1) for where, size in ranked}


def run(args, algorithm: str) -> dict:
    """Run one algorithm in a fresh process and return its record."""
    command = [sys.executable, __file__, "--worker", algorithm, "--elements", args.elements]
    command += ["--dt", str(args.dt), "--top", str(args.top)]
    command += ["--tracemalloc"] if args.tracemalloc else []
    env = {**os.environ, **PINNED}
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        raise RuntimeError(f"{algorithm} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--elements", default="141,35,10", help="hexahedra nx,ny,nz")
    parser.add_argument("--algorithms", nargs="+", default=["FULL", "w-v-u"])
    parser.add_argument("--dt", type=float, default=1e-4)
    parser.add_argument("--label", default="after", help="key of this run in the JSON")
    parser.add_argument("--tracemalloc", action="store_true")
    parser.add_argument("--top", type=int, default=15, help="source lines listed")
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    results = json.loads(args.out.read_text()) if args.out.exists() else {}
    runs = results.setdefault(args.label, {})
    for algorithm in args.algorithms:
        record = run(args, algorithm)
        runs[f"{algorithm}|{args.elements}"] = record
        print(json.dumps(record, indent=1))
        args.out.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
