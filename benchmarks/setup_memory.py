"""Memory a transient problem holds, phase by phase (issue 14 item 2).

Builds ``models.parallelepiped`` at ``--elements`` (141 x 35 x 10 hexahedra: about 170k
dofs, 1/8 of the paper's bar) or, with ``--model pin_joint``, the multi-pin joint at
``--scale`` (``paper`` or cell counts ``c,r,t,grip``: ``8,8,4,36`` is 1/8 of the paper's
cells, ``10,10,5,45`` about 1/4) for each algorithm in its own process, the
``TransientProblem`` included, and stops before the first step or, with ``--steps``, after
that many steps. Per phase it records the process's resident memory kept at the end of
the phase (``VmRSS`` after ``gc.collect`` and glibc's ``malloc_trim``) and its peak within
the phase (``VmHWM``, reset at each phase's start through ``/proc/self/clear_refs``), in MB
and per dof. The phases end where the package's calls return (wrapped here, unchanged):

- ``meshes``: gmsh and the dolfinx meshes (the pin joint only); ``scene``: the rest of it;
- ``assembly``: ``dd_contact.assembly.assemble`` (stiffness, mass, tie operators, zones);
- ``effective K + cM``: its copy of the system with the mass added; ``constraints``: the
  Dirichlet elimination (``mask @ A @ mask``); ``system``: lifting and contact checks;
- ``subdomain COO + MUMPS instances``: the orders' upper-triangle COO handed to MUMPS;
  ``solver``: the rest of the solver (the dense surface base; FULL's PETSc matrix);
- ``problem``: the residual check, results, load forms;
- with ``--steps``: ``factorisations`` (every subdomain's Schur factorisation, up to the
  first condensation reaching the surface), ``surface`` (the condensed surface pairs and
  the dense groups' factorisations) and the rest of the steps.

``--tracemalloc`` also lists the source lines that hold the most Python-allocated memory
(numpy arrays included; PETSc's and MUMPS's own memory is not traced) at the end.
``--petsc-options`` passes MUMPS controls (e.g. out-of-core), ``--tag`` marks the run's key.

Writes ``benchmarks/results/setup_memory.json`` under ``--label``, keeping the other labels
in the file.

Run: python benchmarks/setup_memory.py --label after [--elements 141,35,10]
     [--algorithms FULL w-v-u] [--tracemalloc]
     python benchmarks/setup_memory.py --model pin_joint --scale 8,8,4,36 --steps 1
     --algorithms w-v-u --label pin_joint_after [--petsc-options '{"mat_mumps_icntl_22": 1}']
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

from pinned import PINNED

OUT = Path(__file__).parent / "results" / "setup_memory.json"
MB = 1e6


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
    """One algorithm: scene, assembly, system, solver, problem (, first step); their memory."""
    import tracemalloc

    from mpi4py import MPI

    if args.tracemalloc:
        tracemalloc.start(40)

    import dd_contact as dc
    from dd_contact import analysis, assembly, blocks
    from dd_contact.paper import models
    from dd_contact.solvers import engine, surface
    from dd_contact.solvers.linalg import release_freed_memory

    pin_joint_module = sys.modules["dd_contact.paper.models.pin_joint"]  # the name is a function
    phases = Phases(release_freed_memory)
    # Phase boundaries (measurement only: each wrapped call is unchanged).
    wrap_after(pin_joint_module, "pin_joint_meshes", phases, "meshes (gmsh, dolfinx)")
    wrap_after(analysis, "assemble", phases, "assembly (K, M, ties)")
    wrap_first(blocks.BlockSystem, "constrain", phases, "effective K + cM (copy)")
    wrap_after(assembly.Model, "effective", phases, "constraints (mask A mask)")
    wrap_before(analysis.Analysis, "_use", phases, "system (lifting, checks)")
    wrap_after(engine, "owned_subdomains", phases, "subdomain COO + MUMPS instances")
    wrap_after(analysis.Analysis, "_use", phases, "solver (surface base)")
    wrap_first(surface.Surface, "set_condensed", phases, "factorisations (Schur)")
    wrap_after(surface.Surface, "factorise", phases, "surface (R, dense groups)")
    if args.model == "pin_joint":
        scene = models.pin_joint(_joint_layout(args.scale), comm=MPI.COMM_WORLD)
        dt = 4e-5
    else:
        elements = tuple(int(n) for n in args.elements.split(","))
        layout = "w-u" if args.worker == "w-u" else None
        scene = models.parallelepiped(elements, algorithm=layout, comm=MPI.COMM_WORLD)
        dt = args.dt
    phases.close("scene")
    options = json.loads(args.petsc_options) if args.petsc_options else None
    problem = dc.TransientProblem(
        scene, dt, algorithm=args.worker, track_energy=False, petsc_options=options
    )
    phases.close("problem")
    dofs = sum(problem.model.system.sizes.values())
    if args.steps:
        for _ in range(args.steps):
            problem.advance()
        phases.close(f"first {args.steps} step(s), rest")
    for record in phases.records:
        record["kept_bytes_per_dof"] = round(record["kept_mb"] * MB / dofs)
        record["peak_bytes_per_dof"] = round(record["peak_mb"] * MB / dofs)
    base = phases.records[0]["kept_mb"]
    out = {
        "algorithm": args.worker,
        "model": args.model,
        "dofs": dofs,
        "phases": phases.records,
        "kept_over_import_mb": round(phases.records[-1]["kept_mb"] - base, 1),
        "kept_over_import_bytes_per_dof": round((phases.records[-1]["kept_mb"] - base) * MB / dofs),
        "peak_mb": max(r["peak_mb"] for r in phases.records),
    }
    if args.model == "pin_joint":
        out["scale"] = args.scale
    else:
        out["elements"] = list(elements)
    if args.tracemalloc:
        out["python_held_mb"] = _held_by_our_lines(tracemalloc.take_snapshot(), args.top)
    problem.close()
    return out


def _joint_layout(scale: str):
    """The pin joint at ``paper`` or cell counts ``c,r,t,grip`` (``8,8,4,36`` is 1/8)."""
    import dataclasses

    from dd_contact.paper import models

    if scale in models.PIN_JOINT_SCALES:
        return models.pin_joint_layout(scale)
    names = ("n_circumferential", "n_radial", "n_layers", "n_length")
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    return dataclasses.replace(models.pin_joint_layout("paper"), **counts)


def wrap_after(owner, name: str, phases: Phases, phase: str) -> None:
    """Close ``phase`` when ``owner.name`` returns."""
    original = getattr(owner, name)

    def wrapped(*a, **k):
        out = original(*a, **k)
        phases.close(phase)
        return out

    setattr(owner, name, wrapped)


def wrap_before(owner, name: str, phases: Phases, phase: str) -> None:
    """Close ``phase`` when ``owner.name`` is called."""
    original = getattr(owner, name)

    def wrapped(*a, **k):
        phases.close(phase)
        return original(*a, **k)

    setattr(owner, name, wrapped)


def wrap_first(owner, name: str, phases: Phases, phase: str) -> None:
    """Close ``phase`` at the first call of ``owner.name`` only."""
    original, calls = getattr(owner, name), []

    def wrapped(*a, **k):
        if not calls:
            phases.close(phase)
        calls.append(1)
        return original(*a, **k)

    setattr(owner, name, wrapped)


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
    command += ["--dt", str(args.dt), "--top", str(args.top), "--model", args.model]
    command += ["--scale", args.scale, "--steps", str(args.steps)]
    command += ["--petsc-options", args.petsc_options] if args.petsc_options else []
    command += ["--tracemalloc"] if args.tracemalloc else []
    env = {**os.environ, **PINNED}
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        raise RuntimeError(f"{algorithm} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    models = ["parallelepiped", "pin_joint"]
    parser.add_argument("--model", default="parallelepiped", choices=models)
    parser.add_argument("--elements", default="141,35,10", help="hexahedra nx,ny,nz")
    parser.add_argument("--scale", default="8,8,4,36", help="pin joint: paper or c,r,t,grip")
    parser.add_argument("--steps", type=int, default=0, help="steps after the build (0: none)")
    parser.add_argument("--petsc-options", help="JSON, e.g. '{\"mat_mumps_icntl_22\": 1}'")
    parser.add_argument("--algorithms", nargs="+", default=["FULL", "w-v-u"])
    parser.add_argument("--dt", type=float, default=1e-4)
    parser.add_argument("--label", default="after", help="key of this run in the JSON")
    parser.add_argument("--tag", default="", help="suffix of the run's key, e.g. '+ooc'")
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
        size = args.elements if args.model == "parallelepiped" else f"pin_joint:{args.scale}"
        record["petsc_options"] = json.loads(args.petsc_options) if args.petsc_options else None
        runs[f"{algorithm}|{size}{args.tag}"] = record
        print(json.dumps(record, indent=1))
        args.out.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
