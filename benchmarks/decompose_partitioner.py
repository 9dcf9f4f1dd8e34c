"""decompose's partitioners for a number of parts: bisection, SCOTCH, KaHIP (issue 26).

Part 1, the cut: for a structured box of hexahedra, one of tetrahedra, and a gmsh plate with
three holes (unstructured tetrahedra, two sizes), n = 2, 4, 8 parts: the facets between
parts (the interface's size), the parts' pieces (connected components), the largest part
over the mean, and the partitioner's seconds (median of 3).

Part 2, the run: the finer plate cut into 8 parts by bisection and by SCOTCH, clamped at
x = 0 and pulled at x = 1, a static solve with v-u; each run its own process (BLAS on one
thread), interleaved, medians of ``--repeats``: wall and CPU seconds (decompose, set-up,
solve) and peak resident memory.

Writes benchmarks/results/decompose_partitioner.json.

Run: python benchmarks/decompose_partitioner.py [--size 0.012] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import resource
import time
from pathlib import Path

PARTITIONERS = ("bisection", "scotch", "kahip")


def plate(size):
    """A 1 x 0.2 x 0.05 plate with three holes of radius 0.06, gmsh tetrahedra of ``size``."""
    from mpi4py import MPI

    import dolfinx.io.gmsh
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 0.2, 0.05)
    holes = [(3, gmsh.model.occ.addCylinder(x, 0.1, 0, 0, 0, 0.05, 0.06)) for x in (0.2, 0.5, 0.8)]
    (body,), _ = gmsh.model.occ.cut([(3, box)], holes)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [body[1]], 1)
    gmsh.model.mesh.generate(3)
    mesh = dolfinx.io.gmsh.model_to_mesh(gmsh.model, MPI.COMM_SELF, 0, gdim=3).mesh
    gmsh.finalize()
    return mesh


def cut_quality(name, mesh, n):
    """The cut of each partitioner: facets between parts, pieces, balance, seconds."""
    import numpy as np

    from dd_contact import partition

    rows = {}
    for method in PARTITIONERS:
        seconds = []
        for _ in range(3):
            start = time.perf_counter()
            if method == "bisection":
                part = partition.bisection(partition.cell_midpoints(mesh), n)
            else:
                part = partition.graph_partition(mesh, n, method)
            seconds.append(time.perf_counter() - start)
        graph = partition.dual_graph(mesh).tocoo()
        inside = part[graph.row] == part[graph.col]
        import scipy.sparse
        import scipy.sparse.csgraph

        kept = scipy.sparse.coo_array(
            (graph.data[inside], (graph.row[inside], graph.col[inside])), shape=graph.shape
        )
        pieces = scipy.sparse.csgraph.connected_components(kept, directed=False)[0]
        counts = np.bincount(part, minlength=n)
        rows[method] = {
            "facets_between_parts": len(partition.interface_facets(mesh, part)),
            "pieces": int(pieces),
            "largest_over_mean": float(counts.max() / counts.mean()),
            "seconds": float(np.median(seconds)),
        }
    print(name, n, {m: (r["facets_between_parts"], r["pieces"]) for m, r in rows.items()})
    return {"mesh": name, "cells": len(part), "parts": n, **rows}


def worker(method, size, parts, queue):
    """One static solve in this process: decompose (``method``), v-u, clamped and pulled."""
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    import warnings

    from mpi4py import MPI

    import numpy as np

    import dd_contact as dc

    mesh = plate(size)
    wall, cpu = time.perf_counter(), time.process_time()
    steel = dc.Material(E=210e9, nu=0.3, rho=7850.0)
    scene = dc.decompose(mesh, steel, parts=parts, partitioner=method, comm=MPI.COMM_SELF)
    scene.fix(lambda x: np.isclose(x[0], 0.0))
    scene.add_traction(lambda x: np.isclose(x[0], 1.0), (1e6, 0.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with dc.StaticProblem(scene, algorithm="v-u") as problem:
            problem.solve()
    queue.put(
        {
            "partitioner": method,
            "cells": int(mesh.topology.index_map(3).size_local),
            "interface_facets": scene.decomposition.interface_facets,
            "interface_dofs": int(scene.interface.mesh.geometry.x.shape[0] * 3),
            "wall_seconds": time.perf_counter() - wall,
            "cpu_seconds": time.process_time() - cpu,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        }
    )


def run(method, size, parts):
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    process = context.Process(target=worker, args=(method, size, parts, queue))
    process.start()
    result = queue.get()
    process.join()
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.012, help="the run's plate cell size")
    parser.add_argument("--parts", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    from mpi4py import MPI

    import numpy as np

    from dd_contact import meshes

    cases = [
        ("box 40x8x8 hexahedra", meshes.box(MPI.COMM_SELF, [0, 0, 0], [10, 1, 1], [40, 8, 8])),
        (
            "box 20x10x10 tetrahedra",
            meshes.box(MPI.COMM_SELF, [0, 0, 0], [2, 1, 1], [20, 10, 10], "tetrahedron"),
        ),
        ("plate with holes 0.03", plate(0.03)),
        ("plate with holes 0.015", plate(0.015)),
    ]
    quality = [cut_quality(name, mesh, n) for name, mesh in cases for n in (2, 4, 8)]
    runs = []
    for _ in range(args.repeats):
        for method in ("bisection", "scotch"):
            runs.append(run(method, args.size, args.parts))
            r = runs[-1]
            print(f"{method:9s} {r['interface_dofs']:5d} interface dofs {r['wall_seconds']:6.2f} s")
    median = {
        m: {
            k: float(np.median([r[k] for r in runs if r["partitioner"] == m]))
            for k in ("wall_seconds", "cpu_seconds", "peak_rss_mb")
        }
        for m in ("bisection", "scotch")
    }
    ratio = median["scotch"]["cpu_seconds"] / median["bisection"]["cpu_seconds"]
    print(f"scotch / bisection, CPU seconds: {ratio:.3f}")
    out = {
        "quality": quality,
        "run": {"size": args.size, "parts": args.parts, "runs": runs, "median": median},
        "scotch_over_bisection_cpu": ratio,
        "load_average": os.getloadavg(),
    }
    path = Path(__file__).parent / "results" / "decompose_partitioner.json"
    path.write_text(json.dumps(out, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
