# # One gmsh mesh in: decompose, run, results on the one mesh
#
# A steel plate 200 x 40 x 10 mm with a hole of radius 8 mm is meshed by gmsh as **one**
# mesh of tetrahedra with physical groups: the clamped end (x = 0), the hole's wall, and the
# far end (x = 200). A rigid pin in the hole (radius 7.9 mm) moves 0.2 mm towards +x and
# presses the hole's wall; the far end faces a wall 20 mm away that it never reaches.
# `dd_contact.decompose` cuts the plate so that the hole lies in a small part (the cut the
# cost model favours), builds the interface as a copy of the facets on the cut and a
# contact interface on the hole's wall only, leaving the far end out (with the reason). The
# quasi-static solves run with w-v-u; the von Mises stress is drawn on the one
# mesh, and the table of work shows the large part factorised once.
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
L, W, T, R, CX = 200e-3, 40e-3, 10e-3, 8e-3, 180e-3  # plate, hole radius and centre (m)
CLAMP, HOLE, FAR = 1, 2, 3  # facet tags of the physical groups
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
    hole = gmsh.model.occ.addCylinder(CX, W / 2, 0, 0, 0, T, R)
    (body,), _ = gmsh.model.occ.cut([(3, box)], [(3, hole)])
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [body[1]], 1)
    walls = {CLAMP: [], HOLE: [], FAR: []}
    for _, surface in gmsh.model.getBoundary([body], oriented=False):
        x = gmsh.model.occ.getCenterOfMass(2, surface)
        if np.isclose(x[0], 0.0):
            walls[CLAMP].append(surface)
        elif np.isclose(x[0], L):
            walls[FAR].append(surface)
        elif gmsh.model.getType(2, surface) == "Cylinder":
            walls[HOLE].append(surface)
    for tag, surfaces in walls.items():
        gmsh.model.addPhysicalGroup(2, surfaces, tag)
    field = gmsh.model.mesh.field.add("Distance")
    gmsh.model.mesh.field.setNumbers(field, "SurfacesList", walls[HOLE])
    graded = gmsh.model.mesh.field.add("Threshold")
    for name, value in [("InField", field), ("SizeMin", size / 2), ("SizeMax", size)]:
        gmsh.model.mesh.field.setNumber(graded, name, value)
    gmsh.model.mesh.field.setNumber(graded, "DistMin", 1e-3)
    gmsh.model.mesh.field.setNumber(graded, "DistMax", 6e-3)
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
# Two candidate contact surfaces: the hole's wall against the pin, the far end against a
# wall. The pin's motion over the run, t in [0, 1], is checked at 11 times; a facet within
# 0.5 mm of its obstacle at one of them gets a contact interface.

# +
steel = dc.Material(E=210e9, nu=0.3, rho=7850.0)
pin = dc.Cylinder([CX, W / 2, 0], [0, 0, 1], R - 0.1e-3, motion=lambda t: (0.2e-3 * t, 0, 0))
wall = dc.Plane([L + 20e-3, 0, 0], [-1, 0, 0])
candidates = [
    dc.ContactCandidate((facets, HOLE), pin, name="hole"),
    dc.ContactCandidate((facets, FAR), wall, name="far_end"),
]
scene = dc.decompose(
    mesh, steel, contacts=candidates, margin=0.5e-3, times=np.linspace(0, 1, 11), kappa=1e8
)
scene.fix((facets, CLAMP))
# -

# ## The run: the pin pushes, results back on the one mesh

# +
with dc.StaticProblem(scene, algorithm="w-v-u") as problem:  # "auto" picks FULL this small
    for t in (0.25, 0.5, 0.75, 1.0):
        problem.solve(t)
    force = problem.results["force"]["hole"]
    work = problem.work_table()
    summary = problem.work_summary()
    chosen = problem.algorithm
fields = dc.fields_on_mesh(scene, mesh=scene.decomposition.whole.mesh)  # whole, on every rank
vm = fields.von_mises.x.array
# -

# ## Results

# +
if comm.rank == 0:
    print(f"one mesh: {cells} tetrahedra on {comm.size} rank(s)")
    print(scene.decomposition.table())
    print(f"algorithm: {chosen}")
    print(work)
    print(f"pin force on the plate: {force[0]:.6g} N (x)")
    print(f"max von Mises: {vm.max() / 1e6:.6g} MPa")
    for name, row in summary.items():
        print(f"decompositions {name}: {row['decompositions']}")
    import pyvista

    viz.use_headless_rendering()
    out.mkdir(parents=True, exist_ok=True)
    grid = viz.deformed_grid(fields.u, scale=20.0)
    grid.cell_data["von Mises"] = vm / 1e6
    plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 600))
    plotter.add_mesh(
        grid,
        scalars="von Mises",
        cmap="viridis",
        scalar_bar_args={"title": "von Mises [MPa]", "vertical": True, "fmt": "%.4g"},
    )
    plotter.add_text("plate on a pin, one mesh (deformation x 20)", font_size=12)
    plotter.view_xy()
    plotter.camera.zoom(1.6)
    png = plotter.screenshot(str(out / "decompose_plate.png"))
    plotter.close()
    print(f"wrote {out / 'decompose_plate.png'} in {time.perf_counter() - start:.1f} s")
# -
