"""Pictures: pyvista images of deformed meshes (offscreen, no display needed)."""

from __future__ import annotations

from pathlib import Path

import dolfinx.plot
import numpy as np

from dd_contact.post import von_mises
from dd_contact.scene import Scene

__all__ = ["deformed_grid", "plot_deformed"]


def deformed_grid(function, scale: float):
    """A pyvista grid of a P1 vector function's mesh, displaced by ``scale * function``."""
    import pyvista

    grid = pyvista.UnstructuredGrid(*dolfinx.plot.vtk_mesh(function.function_space))
    values = function.x.array.reshape(-1, 3)
    grid.point_data["displacement"] = values
    grid.points = grid.points + scale * values
    return grid


def plot_deformed(
    scene: Scene, filename: str | Path, scale: float | None = None, title: str = ""
) -> Path:
    """Save a PNG of the deformed subdomains coloured by von Mises stress.

    The interface mesh is drawn as a black wireframe on its deformed position.

    Args:
        scene: A solved scene.
        filename: PNG path.
        scale: Displacement magnification (default: largest displacement drawn as 10% of
            the model's size).
        title: Text at the top of the picture.
    """
    import pyvista

    pyvista.OFF_SCREEN = True
    if scale is None:
        size = max(np.ptp(s.mesh.geometry.x, axis=0).max() for s in scene.subdomains)
        umax = max(np.abs(s.u.x.array).max() for s in scene.subdomains)
        scale = 0.1 * size / umax if umax > 0 else 1.0
    plotter = pyvista.Plotter(off_screen=True, window_size=(1400, 700))
    stress_range = [np.inf, -np.inf]
    grids = []
    for sub in scene.subdomains:
        grid = deformed_grid(sub.u, scale)
        grid.cell_data["von Mises"] = von_mises(sub).x.array
        stress_range = [
            min(stress_range[0], grid.cell_data["von Mises"].min()),
            max(stress_range[1], grid.cell_data["von Mises"].max()),
        ]
        grids.append(grid)
    for grid in grids:
        plotter.add_mesh(
            grid, scalars="von Mises", clim=stress_range, show_edges=True, cmap="viridis"
        )
    if scene.interface is not None:
        plotter.add_mesh(
            deformed_grid(scene.interface.v, scale),
            style="wireframe",
            color="black",
            line_width=2,
        )
    plotter.add_text(f"{title}  (displacement x {scale:.3g})", font_size=10)
    # Look at the x-z plane from the front, a little from above: bending shows best.
    plotter.view_xz()
    plotter.camera.azimuth = 25
    plotter.camera.elevation = 20
    plotter.reset_camera()
    plotter.camera.zoom(1.4)
    plotter.add_axes()
    path = Path(filename)
    path.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(path))
    plotter.close()
    return path
