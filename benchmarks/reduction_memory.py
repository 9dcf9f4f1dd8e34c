"""What a reduced subdomain holds, phase by phase, and what its pieces cost (issue 28).

Builds the parallelepiped of ``paper_scale.py`` at ``--scale`` with its subdomain reduced
to ``--modes`` fixed-interface modes (``none``: the unreduced w-u, whose peak is the
target), runs ``--steps`` steps with w-u and records per phase the resident memory kept
at its end and its peak (``setup_memory.Phases``: ``VmRSS`` after ``malloc_trim``,
``VmHWM`` reset at each phase's start), with the interior's factorisation as phases of
their own: its blocks of A and M, the factor, SLEPc's modes, the load modes, ``A_r`` and
``M_r``, the rest of the reduction, the solver, the steps. After the run: MUMPS's own
account of the factor's memory (INFOG/INFO), the interior matrices' stored entries and
the sizes of the arrays the basis keeps. The unreduced run gives its subdomain's MUMPS
account instead.

``--trees`` runs each case once per source tree (``PYTHONPATH``), interleaved, the whole
``--repeats`` times. Writes ``benchmarks/results/reduction_memory_held.json`` (``--out``),
keyed by label, scale, modes and tree, after every run.

Run: python benchmarks/reduction_memory.py --scale 1/16 --modes 20
     --trees before=/tmp/main after=. [--label peakmem]
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from reduction_setup import case_parser, run, run_case
from setup_memory import Phases, wrap_after, wrap_before

OUT = Path(__file__).parent / "results" / "reduction_memory_held.json"

#: MUMPS's statistics recorded: factor entries (INFOG(9), (29)), ordering (INFOG(7)),
#: memory estimated and used in MB (INFOG(16), (21); INFO(16) allocated, INFO(22) used).
INFOG = (7, 9, 16, 21, 29)
INFO = (16, 22)


def _wrap_class(module, name: str, phases: Phases, before: str, after: str) -> None:
    """Close ``before`` when ``module.name`` (a class) is instantiated, ``after`` when built."""
    original = getattr(module, name)

    def built(*a, **k):
        phases.close(before)
        out = original(*a, **k)
        phases.close(after)
        return out

    setattr(module, name, built)


def worker(args) -> dict:
    """One case in this process: the scene, its reduction by phases, the steps."""
    from dd_contact import analysis
    from dd_contact.solvers import reduced
    from dd_contact.solvers.linalg import release_freed_memory

    phases = Phases(release_freed_memory)
    factor = next(
        f for f in ("interior_factor", "InteriorCholesky", "SparseCholesky") if hasattr(reduced, f)
    )
    _wrap_class(reduced, factor, phases, "assembly, blocks of A and M", "interior factor")
    wrap_after(reduced.ReducedBasis, "_modes", phases, "fixed-interface modes")
    wrap_before(reduced.ReducedBasis, "_reduced", phases, "load modes")
    wrap_after(reduced.ReducedBasis, "_reduced", phases, "A_r, M_r (constraint modes)")
    wrap_after(analysis, "reduce_model", phases, "rest of the reduction")
    modes, elements, scene, problem = run_case(args, phases)
    out = {
        "modes": modes,
        "elements": list(elements),
        "dofs": int(sum(s.num_dofs for s in scene.subdomains)),
        "phases": phases.records,
        "peak_mb": max(r["peak_mb"] for r in phases.records),
        "kept_end_mb": phases.records[-1]["kept_mb"],
        "held": _held(problem.model.reduced) if modes is not None else _schur_factors(),
    }
    problem.close()
    return out


def _mumps(get_infog, get_info) -> dict:
    return {
        **{f"INFOG({k})": int(get_infog(k)) for k in INFOG},
        **{f"INFO({k})": int(get_info(k)) for k in INFO},
    }


def _held(bases: dict) -> dict:
    """MUMPS's account of each interior factor and the sizes of what the basis keeps (MB)."""
    out = {}
    for block, basis in bases.items():
        factor = basis.factor
        if hasattr(factor, "_factor"):  # the Schur factorisation, driven through MUMPS's C API
            mumps = factor._factor._id
            infog, info = (lambda k: mumps.infog[k - 1]), (lambda k: mumps.info[k - 1])
        else:
            factor = getattr(factor, "_cholesky", factor)
            F = getattr(factor, "factor_matrix", None) or factor.ksp.getPC().getFactorMatrix()
            infog, info = F.getMumpsInfog, F.getMumpsInfo
        arrays = {"G": basis.G, "A_r": basis.A_r, "M_r": basis.M_r, "patterns": basis._patterns}
        record = {
            "n_i": int(basis.i.size),
            "n_b": int(basis.b.size),
            "G_columns": int(basis.G.shape[1]),
            "mumps": _mumps(infog, info),
            "arrays_mb": {k: round(a.nbytes / 1e6, 1) for k, a in arrays.items() if a is not None},
        }
        if basis._M_ii is not None:
            record["M_ii_stored_entries"] = int(basis._M_ii.mat.getInfo()["nz_used"])
            record["M_ii_type"] = basis._M_ii.mat.getType()
        out[str(block)] = record
    return out


def _schur_factors() -> list[dict]:
    """MUMPS's account of the unreduced run's Schur factorisations (found by the collector)."""
    import gc

    from dd_contact.solvers import mumps_schur

    found = [
        f for f in gc.get_objects() if isinstance(f, mumps_schur.SchurFactorisation) and f.handle
    ]
    return [
        {
            "size": f.size,
            "schur": f.schur,
            "mumps": _mumps(lambda k, f=f: f._id.infog[k - 1], lambda k, f=f: f._id.info[k - 1]),
        }
        for f in found
    ]


def main() -> None:
    parser = case_parser(__doc__.split("\n")[0], "20", OUT)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    results = json.loads(args.out.read_text()) if args.out.exists() else {}
    trees = dict(t.split("=", 1) for t in args.trees)
    for _ in range(args.repeats):
        for name, tree in trees.items():  # interleaved: each tree once per round
            record = {**run(args, tree, __file__), "load_average": round(os.getloadavg()[0], 2)}
            key = f"{args.label}|{args.scale}|m={args.modes}|{name}"
            results.setdefault(key, []).append(record)
            print(key, json.dumps({k: record[k] for k in ("peak_mb", "kept_end_mb")}))
            args.out.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
