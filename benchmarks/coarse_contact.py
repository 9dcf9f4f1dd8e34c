"""How many contact points a contact needs: a Hertz press resolved by 1 to 400 points.

An elastic hemisphere (R = 1, E = 1, nu = 0.3; a quarter, symmetry planes x = 0, y = 0, or
the whole) is pushed by ``approach`` onto a rigid plane, the mesh size ``h`` near its pole
set from the ratio a / h (a = sqrt(R approach), Hertz's contact radius). For each run:
the active contact points, the nodes' worth of surface carrying the force
(:func:`dd_contact.post.carrying_points`, what :class:`dd_contact.monitors.ContactResolution`
judges), the points' effective number ``(sum f)^2 / sum f^2`` and the largest point's share
of the force, and the errors of the force and the contact radius against
the same press on the finest mesh (the continuum the mesh converges to, its bulk compliance
included) and against Hertz's closed form ``F = 4/3 E* sqrt(R) approach^1.5``.

Writes benchmarks/results/coarse_contact.json; its table is in docs/contact.md ("A contact
carried by too few points") and sets :data:`dd_contact.monitors.MIN_CONTACT_POINTS`.

Run: python benchmarks/coarse_contact.py [--approaches 0.03 0.005] [--ratios ...]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import ContactBoundary, Material, Plane, Scene, StaticProblem, Subdomain, meshes
from dd_contact.post import carrying_points

HERE = Path(__file__).parent / "results"
R, E, NU = 1.0, 1.0, 0.3


def press(approach: float, h: float, points: str = "nodes", quarter: bool = True) -> dict:
    """The hemisphere pressed by ``approach`` with mesh size ``h`` near its pole."""
    a_hertz = np.sqrt(R * approach)
    zone_radius = max(1.2 * a_hertz, h)
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, zone_radius, h, max(0.2, h), quarter=quarter)
    ball = Subdomain(mesh, Material(E, NU), "ball")
    ball.fix((tags, meshes.HEMISPHERE_TOP), components=[2], value=[0, 0, -approach])
    if quarter:
        ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
        ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    else:  # hold the rigid motions in the plane at the top face's centre line
        ball.fix((tags, meshes.HEMISPHERE_TOP), components=[0, 1])
    cap = ball.locate_facets((tags, meshes.HEMISPHERE_CURVED))
    mid = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap)].mean(axis=1)
    near = cap[mid[:, 2] < max(2.0 * approach + 2 * h, 0.05) * R]
    zone = ContactBoundary(ball, near, Plane([0, 0, 0], [0, 0, 1]), points=points, name="cap")
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem = StaticProblem(Scene(MPI.COMM_SELF, [ball], contacts=[zone]))
        problem.solve()
    op = problem.zones[0].operator
    w = zone.w.x.array[: op.num_dofs]
    force = op.point_pressure(w) * op.points.weight
    active = force > 0
    total = float(force.sum())
    symmetry = 4.0 if quarter else 1.0
    E_star = E / (1 - NU**2)
    row = {
        "approach": approach,
        "h": h,
        "a_over_h": a_hertz / h,
        "points": points,
        "quarter": quarter,
        "dofs": ball.num_dofs,
        "active": int(active.sum()),
        "carrying": carrying_points(problem.zones[0], w, active)[0],
        "effective": total**2 / float(np.sum(force**2)) if total > 0 else 0.0,
        "largest_share": float(force.max() / total) if total > 0 else 0.0,
        "force": symmetry * total,
        "force_hertz": 4.0 / 3.0 * E_star * np.sqrt(R) * approach**1.5,
        "a": float(np.sqrt(symmetry * op.points.weight[active].sum() / np.pi)),
        "a_hertz": a_hertz,
        "seconds": time.perf_counter() - start,
    }
    problem.close()
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--approaches", type=float, nargs="+", default=[0.03, 0.005])
    parser.add_argument(
        "--ratios", type=float, nargs="+", default=[0.5, 0.75, 1, 1.5, 2, 3, 4, 6, 9]
    )
    parser.add_argument("--reference-ratio", type=float, default=16.0)
    parser.add_argument("--full", action="store_true", help="also the whole hemisphere")
    parser.add_argument("--out", default=str(HERE / "coarse_contact.json"))
    args = parser.parse_args()
    rows = []
    for approach in args.approaches:
        a = np.sqrt(R * approach)
        reference = press(approach, a / args.reference_ratio)
        reference["reference"] = True
        rows.append(reference)
        print(json.dumps(reference), flush=True)
        cases = [("nodes", True), ("quadrature", True)] + ([("nodes", False)] * args.full)
        for points, quarter in cases:
            for ratio in args.ratios:
                row = press(approach, a / ratio, points, quarter)
                row["force_error"] = row["force"] / reference["force"] - 1.0
                row["a_error"] = row["a"] / reference["a"] - 1.0
                rows.append(row)
                print(json.dumps(row), flush=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"case": "hertz press", "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
