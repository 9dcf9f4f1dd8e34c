# # Hertz contact: an elastic hemisphere pressed on a rigid plane
#
# An elastic ball of radius R = 1 (E = 1, nu = 0.3) rests with its pole on a rigid plane
# z = 0. Its flat face is pushed down by 0.03 R. Hertz's theory gives, for the force F the
# contact carries (E* = E / (1 - nu^2), rigid plane):
#
#     a = (3 F R / (4 E*))^(1/3),      p(r) = p0 sqrt(1 - r^2 / a^2),      p0 = 3 F / (2 pi a^2)
#
# We model a quarter of the hemisphere (symmetry planes x = 0 and y = 0), put an
# independent *contact interface* on the cap near the pole (a copy of its facets with its
# own displacement w, tied to the ball by a penalty), press it on the plane with the
# exterior penalty, and compare the computed contact radius and pressure with Hertz.
# Outputs: a pyvista picture of the contact pressure on the contact interface, a matplotlib
# chart of p(r) against the closed form, and VTX files for ParaView.
#
# Run it with `python demos/demo_hertz.py`; `--small` runs a coarse version (for the tests).

# +
import argparse
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

import dd_contact as dc
from dd_contact import io, meshes, viz

parser = argparse.ArgumentParser()
parser.add_argument("--small", action="store_true", help="coarse mesh (for tests)")
parser.add_argument("--out", default="demo_output", help="output directory")
args = parser.parse_args()
out = Path(args.out)
comm = MPI.COMM_WORLD
start = time.perf_counter()
R, E, nu, approach = 1.0, 1.0, 0.3, 0.03
h = 0.03 if args.small else 0.0125
# -

# ## The ball
#
# A gmsh quarter hemisphere, refined to `h` near the pole. Every subdomain lives on one
# MPI rank, so the mesh is created on `MPI.COMM_SELF`.

# +
mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, contact_radius=0.18, h_contact=h, h_far=0.2)
ball = dc.Subdomain(mesh, dc.Material(E, nu), "ball")
ball.fix((tags, meshes.HEMISPHERE_TOP), components=[2], value=[0, 0, -approach])
ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
# -

# ## The contact interface and the obstacle
#
# Only the cap below z = 0.15 R can touch the plane; the contact interface copies its
# facets. The plane's normal points out of the wall, towards the ball. Contact is checked
# at the nodes (the default; `benchmarks/hertz_convergence.py` compares it with Gauss
# points).

# +
cap = ball.locate_facets((tags, meshes.HEMISPHERE_CURVED))
centres = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap)].mean(axis=1)
contact = dc.ContactInterface.from_boundary(
    ball, cap[centres[:, 2] < 0.15 * R], dc.Plane([0, 0, 0], [0, 0, 1]), name="cap"
)
scene = dc.Scene(comm, [ball], contacts=[contact])
problem = dc.StaticProblem(scene)
problem.solve()
# -

# ## Against Hertz
#
# The force is four times the quarter's. The contact radius is that of the circle with the
# active area (nodal areas of the nodes in contact).

# +
force = 4.0 * problem.contact_forces()["cap"][2]
E_star = E / (1 - nu**2)
a_ref = (3 * force * R / (4 * E_star)) ** (1 / 3)
p0_ref = 3 * force / (2 * np.pi * a_ref**2)
changes = problem.changes  # collective, like contact_forces: call it on every rank
if comm.rank == scene.contact_owner(contact):
    x = contact.V.tabulate_dof_coordinates()
    r = np.linalg.norm(x[:, :2], axis=1)
    p = contact.pressure.x.array
    zone = problem.zones[0]
    active = zone.operator.active_set(contact.w.x.array)
    a = np.sqrt(4 * zone.operator.points.weight[active].sum() / np.pi)
    print(f"contact force F         : {force:.6g}  (dofs: {ball.num_dofs})")
    print(f"contact radius a        : {a:.5f}  Hertz {a_ref:.5f}  ({100 * (a / a_ref - 1):+.2f}%)")
    print(
        f"peak pressure p0        : {p.max():.5f}  Hertz {p0_ref:.5f}  "
        f"({100 * (p.max() / p0_ref - 1):+.2f}%)"
    )
    print(f"contact iterations      : {problem.iterations}, state changes {changes}")
# -

# ## Pictures
#
# The contact interface seen from below, coloured by pressure, and the pressure profile.

# +
if comm.rank == scene.contact_owner(contact):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    viz.plot_contact_pressure(
        contact,
        out / "hertz_pressure.png",
        title="Contact pressure on the contact interface (quarter model)",
        unit="E",
    )

    fig, ax = plt.subplots(figsize=(6, 4))
    rr = np.linspace(0, a_ref, 200)
    ax.plot(rr / a_ref, p0_ref * np.sqrt(1 - (rr / a_ref) ** 2) / p0_ref, "k-", label="Hertz")
    inside = r < 1.6 * a_ref
    ax.plot(r[inside] / a_ref, p[inside] / p0_ref, "o", ms=3, label="computed (nodes)")
    ax.set_xlabel("r / a (Hertz)")
    ax.set_ylabel("p / p0 (Hertz)")
    ax.set_title(f"Hertz contact, h = {h} R")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "hertz_profile.png", dpi=120)
io.write_vtx(scene, out)
if comm.rank == 0:
    print(f"pictures and VTX files in {out}/; {time.perf_counter() - start:.1f} s")
# -
