# # One gmsh mesh in: decompose, a transient run with contact, results on the one mesh
#
# A steel plate 300 x 40 x 10 mm with a row of three pin holes (radius 6 mm, at x = 240,
# 260 and 280 mm) is meshed by gmsh as **one** mesh of tetrahedra with physical groups: the
# clamped end (x = 0) and each hole's wall. A rigid pin sits in every hole with 20 um of
# clearance and is pulled 0.1 mm towards +x over 2 ms, so it presses the +x side of its
# hole. `dd_contact.decompose` cuts the plate so that the holes lie in a small part (the cut
# the cost model favours), builds the interface as a copy of the facets on the cut, and a
# contact interface only on the facets a pin can reach over the run (within the margin at
# one of the times checked): the -x side of each hole is left out, with the reason. The
# transient run (Newmark) steps with w-v-u; the von Mises stress is drawn on the one mesh,
# and the table of work shows the parts factorised once, the contact blocks at each change.
#
# Run it with `make demo`; `--small` coarsens the mesh (used by the tests).

# +
import argparse
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.io.gmsh
import numpy as np

import dd_contact as dc
from dd_contact import viz

parser = argparse.ArgumentParser()
parser.add_argument("--small", action="store_true", help="a coarse mesh (for tests)")
parser.add_argument("--out", default="demo_output", help="output directory")
args = parser.parse_args()
out = Path(args.out)
comm = MPI.COMM_WORLD
start = time.perf_counter()
L, W, T, R = 300e-3, 40e-3, 10e-3, 6e-3  # plate and hole radius (m)
HOLES = (240e-3, 260e-3, 280e-3)  # the holes' centres along x (m)
CLAMP = 1  # facet tag of the clamped end; the holes' walls are 11, 12, 13
CLEARANCE, PULL, DURATION, STEPS = 20e-6, 0.1e-3, 2e-3, 20  # m, m, s, time steps
# -

# ## The one mesh
#
# Built by gmsh on rank 0 and distributed by dolfinx, as a user's mesh from CAD would be.

# +


def plate(comm, size):
    """The plate's mesh, distributed over ``comm``, and its facet tags."""
    if comm.rank != 0:
        return dolfinx.io.gmsh.model_to_mesh(None, comm, 0, gdim=3)
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size / 2)
    box = gmsh.model.occ.addBox(0, 0, 0, L, W, T)
    holes = [gmsh.model.occ.addCylinder(cx, W / 2, 0, 0, 0, T, R) for cx in HOLES]
    (body,), _ = gmsh.model.occ.cut([(3, box)], [(3, h) for h in holes])
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [body[1]], 1)
    walls: dict[int, list[int]] = {CLAMP: [], 11: [], 12: [], 13: []}
    for _, surface in gmsh.model.getBoundary([body], oriented=False):
        x = gmsh.model.occ.getCenterOfMass(2, surface)
        if np.isclose(x[0], 0.0):
            walls[CLAMP].append(surface)
        elif gmsh.model.getType(2, surface) == "Cylinder":
            walls[11 + int(np.argmin(np.abs(np.array(HOLES) - x[0])))].append(surface)
    for tag, surfaces in walls.items():
        gmsh.model.addPhysicalGroup(2, surfaces, tag)
    field = gmsh.model.mesh.field.add("Distance")
    gmsh.model.mesh.field.setNumbers(field, "SurfacesList", walls[11] + walls[12] + walls[13])
    graded = gmsh.model.mesh.field.add("Threshold")
    for name, value in [("InField", field), ("SizeMin", size / 2), ("SizeMax", size)]:
        gmsh.model.mesh.field.setNumber(graded, name, value)
    gmsh.model.mesh.field.setNumber(graded, "DistMin", 1e-3)
    gmsh.model.mesh.field.setNumber(graded, "DistMax", 5e-3)
    gmsh.model.mesh.field.setAsBackgroundMesh(graded)
    gmsh.model.mesh.generate(3)
    data = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    gmsh.finalize()
    return data


data = plate(comm, 8e-3 if args.small else 4e-3)
mesh, facets = data.mesh, data.facet_tags
cells = comm.allreduce(mesh.topology.index_map(3).size_local)
# -

# ## The decomposition
#
# Each hole's wall is a candidate contact surface against its pin. The pins' motion over
# the run is checked at 11 times; a facet with a node within 10 um of its pin at one of them
# gets a contact interface (the margin covers the plate's own motion there, a few um).

# +
steel = dc.Material(E=210e9, nu=0.3, rho=7850.0)


def pull(t):
    """The pins' displacement at time t: a smooth ramp to PULL over DURATION."""
    s = min(t / DURATION, 1.0)
    return (PULL * s * s * (3 - 2 * s), 0.0, 0.0)


candidates = [
    dc.ContactCandidate(
        (facets, 11 + k),
        dc.Cylinder([cx, W / 2, 0], [0, 0, 1], R - CLEARANCE, motion=pull),
        name=f"hole{k + 1}",
    )
    for k, cx in enumerate(HOLES)
]
scene = dc.decompose(
    mesh, steel, contacts=candidates, margin=10e-6, times=np.linspace(0, DURATION, 11)
)
scene.fix((facets, CLAMP))
# -

# ## The transient run: the pins pull, results back on the one mesh

# +
run = dc.TransientProblem(scene, DURATION / STEPS, algorithm="w-v-u")
with run as problem:
    history = problem.run(STEPS, summary=False)
    work = problem.work_table()
    summary = problem.work_summary()
fields = dc.fields_on_mesh(scene, mesh=scene.decomposition.whole.mesh)  # whole, on every rank
vm = fields.von_mises.x.array
force = sum(np.asarray(history[-1]["force"][c.name]) for c in candidates)
# -

# ## Results

# +
if comm.rank == 0:
    print(f"one mesh: {cells} tetrahedra on {comm.size} rank(s)")
    print(scene.decomposition.table())
    print(work)
    print(f"pins' force on the plate at t = {history[-1]['t'] * 1e3:.3g} ms: {force[0]:.6g} N (x)")
    print(f"max von Mises: {vm.max() / 1e6:.6g} MPa")
    for name, row in summary.items():
        if row["decompositions"]:  # the low-rank updates' row counts updates instead
            print(f"decompositions {name}: {row['decompositions']}")
    import pyvista

    viz.use_headless_rendering()
    out.mkdir(parents=True, exist_ok=True)
    grid = viz.deformed_grid(fields.u, scale=100.0)
    grid.cell_data["von Mises"] = vm / 1e6
    plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 600))
    plotter.add_mesh(
        grid,
        scalars="von Mises",
        cmap="viridis",
        scalar_bar_args={"title": "von Mises [MPa]", "vertical": True, "fmt": "%.4g"},
    )
    plotter.add_text("plate on three pins, one mesh (deformation x 100)", font_size=12)
    plotter.view_xy()
    plotter.camera.zoom(1.6)
    plotter.screenshot(str(out / "one_mesh_plate.png"))
    plotter.close()
    print(f"wrote {out / 'one_mesh_plate.png'} in {time.perf_counter() - start:.1f} s")
# -
