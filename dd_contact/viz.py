"""Pictures: pyvista images of deformed meshes, obstacles and contact pressure.

Rendering is off-screen. On Linux without a display (no ``DISPLAY`` or ``WAYLAND_DISPLAY``)
VTK is told to render through EGL before the first window is made, so a script needs no
environment variables and VTK does not probe for an X server.

Every function here is rank-local: it draws this rank's copy of the results. Subdomain
displacements and the interface are on every rank; a contact region's ``w`` and
``pressure`` hold results on its owner, ``scene.contact_owner(contact)``.

Each picture comes in two forms: ``*_plotter`` returns the :class:`pyvista.Plotter` (to
add to it, or to show it interactively) and ``plot_*`` saves a PNG and closes it.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import dolfinx.plot
import numpy as np

from dd_contact.errors import InputError
from dd_contact.obstacles import Cylinder, Obstacle, Plane, Sphere
from dd_contact.post import von_mises
from dd_contact.scene import ContactBoundary, ContactInterface, Scene

__all__ = [
    "UNIFORM_RTOL",
    "contact_pressure_plotter",
    "contact_pressures_plotter",
    "deformed_grid",
    "deformed_plotter",
    "plot_contact_pressure",
    "plot_contact_pressures",
    "plot_deformed",
    "plot_wall_pressures",
    "pyplot",
    "unrolled_wall",
    "use_headless_rendering",
    "wall_pressures_figure",
]

# A field whose spread is below this fraction of its magnitude is drawn as one colour: a
# 1 MPa stress with 2e-9 Pa of round-off is uniform, not a purple-to-yellow gradient.
UNIFORM_RTOL = 1e-6

_SI_PREFIXES = {0: "", 1: "k", 2: "M", 3: "G", 4: "T"}
_WINDOW = (1400, 700)

# The type: ignores on pyvista calls are for its annotations: Plotter's methods that forward
# to its renderer are wrapped with functools.wraps, whose stub keeps the Renderer method's
# self (call-arg); Plotter(window_size=...) is annotated a list, and takes any sequence.


def use_headless_rendering() -> None:
    """Render off-screen, through EGL when there is no display to connect to.

    Called by every picture function before its first window; an explicit
    ``VTK_DEFAULT_OPENGL_WINDOW`` in the environment is kept.
    """
    import pyvista

    no_display = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if sys.platform.startswith("linux") and no_display and ctypes.util.find_library("EGL"):
        # VTK reads this when it creates a render window: set it before the first one.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    pyvista.OFF_SCREEN = True


def deformed_grid(function, scale: float):
    """A pyvista grid of a P1 vector function's mesh, displaced by ``scale * function``."""
    import pyvista

    grid = pyvista.UnstructuredGrid(*dolfinx.plot.vtk_mesh(function.function_space))
    values = function.x.array.reshape(-1, 3)
    grid.point_data["displacement"] = values
    grid.points = grid.points + scale * values
    return grid


def _scaled_unit(magnitude: float, unit: str) -> tuple[float, str]:
    """Divisor and label for values in ``unit``: Pa becomes kPa, MPa or GPa by magnitude."""
    if unit != "Pa" or not magnitude > 0:
        return 1.0, unit
    power = int(np.clip(np.floor(np.log10(magnitude) / 3), 0, max(_SI_PREFIXES)))
    return 1000.0**power, f"{_SI_PREFIXES[power]}Pa"


def _colour_range(values: np.ndarray) -> tuple[tuple[float, float], bool]:
    """Colour-bar limits and whether the field is uniform (spread within UNIFORM_RTOL)."""
    low, high = float(values.min()), float(values.max())
    size = max(abs(low), abs(high))
    if high - low > UNIFORM_RTOL * size:
        return (low, high), False
    # One colour, the middle of the map, with a bar of +-10 % around the value.
    half = 0.1 * size if size > 0 else 1.0
    middle = 0.5 * (low + high)
    return (middle - half, middle + half), True


def _bar_args(title: str) -> dict:
    # Vertical on the right: the title sits above the bar, clear of the tick labels.
    return {
        "title": title,
        "vertical": True,
        "position_x": 0.86,
        "position_y": 0.12,
        "width": 0.05,
        "height": 0.72,
        "fmt": "%.4g",
        "title_font_size": 16,
        "label_font_size": 14,
        "n_labels": 5,
    }


def _add_field(plotter, grids: dict, name: str, values: list, unit: str, label: str, **kw):
    """Colour ``grids`` (actor name: grid) by ``values`` with one bar ``label [unit]``."""
    every = np.concatenate(values)
    divisor, shown_unit = _scaled_unit(float(np.abs(every).max(initial=0.0)), unit)
    clim, uniform = _colour_range(every / divisor)
    title = f"{label} [{shown_unit}]" if shown_unit else label
    if uniform:
        title += "\nuniform"
    for k, ((actor, grid), v) in enumerate(zip(grids.items(), values, strict=True)):
        data = grid.cell_data if len(v) == grid.n_cells else grid.point_data
        # A uniform field is drawn at its mean: round-off must not pick neighbouring colours.
        data[name] = np.full(len(v), every.mean() / divisor) if uniform else v / divisor
        plotter.add_mesh(
            grid,
            scalars=name,
            clim=clim,
            cmap="viridis",
            show_scalar_bar=k == 0,
            scalar_bar_args=_bar_args(title),
            name=actor,
            **kw,
        )


def _bounds(scene: Scene, parts=None) -> tuple[np.ndarray, np.ndarray]:
    x = np.concatenate([s.mesh.geometry.x for s in (scene.subdomains if parts is None else parts)])
    return x.min(axis=0), x.max(axis=0)


def _obstacle_mesh(obstacle: Obstacle, low: np.ndarray, high: np.ndarray, t: float):
    """A surface of the obstacle around the model's bounding box, or None if not drawable."""
    import pyvista

    centre, size = 0.5 * (low + high), float(np.linalg.norm(high - low))
    offset = np.zeros(3) if obstacle.motion is None else np.asarray(obstacle.motion(t), float)
    if isinstance(obstacle, Plane):
        point = obstacle.point + offset
        foot = centre - ((centre - point) @ obstacle.normal) * obstacle.normal
        return pyvista.Plane(
            center=foot, direction=obstacle.normal, i_size=1.5 * size, j_size=1.5 * size
        )
    if isinstance(obstacle, Sphere):
        return pyvista.Sphere(
            radius=obstacle.radius,
            center=obstacle.centre + offset,
            theta_resolution=48,
            phi_resolution=48,
        )
    if isinstance(obstacle, Cylinder):
        # The pin's length: the model's extent along the axis, and a little more.
        point = obstacle.point + offset
        along = (centre - point) @ obstacle.axis
        return pyvista.Cylinder(
            center=point + along * obstacle.axis,
            direction=obstacle.axis,
            radius=obstacle.radius,
            height=1.2 * size,
            resolution=64,
        )
    return None  # a UserObstacle has no shape to draw


def _contact_owned(scene: Scene, contact: ContactInterface | ContactBoundary) -> bool:
    return scene.contact_owner(contact) == scene.comm.rank


def deformed_plotter(
    scene: Scene,
    scale: float | None = None,
    title: str = "",
    stress_unit: str = "Pa",
    obstacles: bool = True,
    subdomains: Sequence[str] | None = None,
):
    """A plotter of the deformed subdomains coloured by von Mises stress.

    The interface is drawn as a black wireframe and the contact surfaces this rank holds
    results for as red wireframes with their active points (positive pressure) as red
    dots, all at their deformed positions; the rigid obstacles (Plane, Sphere, Cylinder) as
    translucent grey surfaces. A field uniform to within :data:`UNIFORM_RTOL` is one colour.

    Args:
        scene: A solved scene.
        scale: Displacement magnification (default: largest displacement drawn as 10% of
            the model's size).
        title: Text at the top of the picture.
        stress_unit: Unit of the model's stresses; ``"Pa"`` (SI input) is shown as kPa,
            MPa or GPa, whichever fits; any other text is shown as it is.
        obstacles: Whether to draw the obstacles.
        subdomains: The names of the subdomains to draw (default all), framed alone: no
            interface, contact surface or obstacle.

    Returns:
        The :class:`pyvista.Plotter`, off-screen; close it when done. Its actors are named
        ``subdomain NAME``, ``interface``, ``contact NAME``, ``active NAME`` and
        ``obstacle NAME``.
    """
    use_headless_rendering()
    import pyvista

    parts = [s for s in scene.subdomains if subdomains is None or s.name in subdomains]
    low, high = _bounds(scene, parts)
    if scale is None:
        umax = max(np.abs(s.u.x.array).max() for s in parts)
        scale = 0.1 * float((high - low).max()) / umax if umax > 0 else 1.0
    plotter = pyvista.Plotter(off_screen=True, window_size=_WINDOW)  # type: ignore[arg-type]
    grids = {f"subdomain {s.name}": deformed_grid(s.u, scale) for s in parts}
    stresses = [von_mises(s).x.array for s in parts]
    _add_field(plotter, grids, "von Mises", stresses, stress_unit, "von Mises", show_edges=True)
    if scene.interface is not None and subdomains is None:
        interface = deformed_grid(scene.interface.v, scale)
        plotter.add_mesh(
            interface, style="wireframe", color="black", line_width=2, name="interface"
        )
    time = scene.subdomains[0].time.value
    for contact in scene.contacts:  # a pair's sides are contacts of their own
        if subdomains is not None:  # the chosen subdomains alone, their stress unhidden
            break
        name = contact.name
        if _contact_owned(scene, contact):
            surface = deformed_grid(contact.w, scale)
            plotter.add_mesh(
                surface, style="wireframe", color="red", line_width=2, name=f"contact {name}"
            )
            _add_active_points(plotter, surface, contact.pressure.x.array > 0, name, "red", 8)
        drawn = obstacles and contact.obstacle is not None  # a pair's side has none
        shape = _obstacle_mesh(contact.obstacle, low, high, float(time)) if drawn else None
        if shape is not None:
            plotter.add_mesh(shape, color="grey", opacity=0.35, name=f"obstacle {name}")
    plotter.add_text(f"{title}  (displacement x {scale:.3g})".strip(), font_size=10)
    # Look at the x-z plane from the front, a little from above: bending shows best.
    plotter.view_xz()  # type: ignore[call-arg]
    plotter.camera.azimuth = 25
    plotter.camera.elevation = 20
    plotter.reset_camera(bounds=[v for pair in zip(low, high, strict=True) for v in pair])  # type: ignore[call-arg]
    plotter.camera.zoom(1.4)
    plotter.add_axes()  # type: ignore[call-arg]
    return plotter


def contact_pressure_plotter(
    contact: ContactInterface | ContactBoundary,
    scale: float = 1.0,
    title: str = "",
    unit: str = "Pa",
):
    """A plotter of a contact surface coloured by its nodal contact pressure.

    The surface is drawn displaced by ``scale * w`` and seen from the obstacle (along the
    mean contact normal), with its active points (positive pressure) as black dots.
    Rank-local: the results are on the contact's owner rank.

    Args:
        contact: A solved contact interface or contact boundary.
        scale: Displacement magnification.
        title: Text at the top of the picture.
        unit: Unit of the model's stresses; ``"Pa"`` is shown as kPa, MPa or GPa.

    Returns:
        The :class:`pyvista.Plotter`, off-screen; close it when done.
    """
    use_headless_rendering()
    import pyvista

    plotter = pyvista.Plotter(off_screen=True, window_size=(1000, 800))  # type: ignore[arg-type]
    surface = deformed_grid(contact.w, scale)
    pressure = contact.pressure.x.array
    surfaces = {f"contact {contact.name}": surface}
    _add_field(plotter, surfaces, "pressure", [pressure], unit, "contact pressure", show_edges=True)
    _add_active_points(plotter, surface, pressure > 0, contact.name, "black", 6)
    plotter.add_text(title or f"contact pressure on {contact.name!r}", font_size=10)
    # The body's outward contact normal points at the obstacle: look back along it.
    x = contact.V.tabulate_dof_coordinates()
    _, normals = contact.obstacle.gap_normal(x, float(contact.subdomain.time.value))
    mean = normals.mean(axis=0)
    if np.linalg.norm(mean) > 0.5:
        centre = surface.center
        distance = 3.0 * surface.length
        plotter.camera_position = [centre + distance * mean, centre, _up(mean)]
    else:  # a surface all around a pin: no single side to look from
        plotter.view_isometric()  # type: ignore[call-arg]
    plotter.reset_camera()  # type: ignore[call-arg]
    plotter.add_axes()  # type: ignore[call-arg]
    return plotter


def contact_pressures_plotter(
    scene: Scene,
    scale: float = 1.0,
    title: str = "",
    unit: str = "Pa",
    view: tuple[float, float, float] = (0.0, -1.0, 0.9),
):
    """A plotter of every contact surface of the scene, coloured by contact pressure.

    One colour bar; each surface displaced by ``scale * w`` (the pin joint's ten hole walls).

    Rank-local: draws the contact results this rank holds, all of them after
    :func:`dd_contact.post.gather_contact_fields`. ``view`` is the direction the camera
    looks from.

    Returns:
        The :class:`pyvista.Plotter`, off-screen; close it when done (actors
        ``contact NAME``).
    """
    use_headless_rendering()
    import pyvista

    plotter = pyvista.Plotter(off_screen=True, window_size=_WINDOW)  # type: ignore[arg-type]
    surfaces = {f"contact {c.name}": deformed_grid(c.w, scale) for c in scene.contacts}
    pressures = [c.pressure.x.array for c in scene.contacts]
    _add_field(plotter, surfaces, "pressure", pressures, unit, "contact pressure", show_edges=True)
    plotter.add_text(f"{title}  (displacement x {scale:.3g})".strip(), font_size=10)
    plotter.view_vector(view)  # type: ignore[arg-type]
    plotter.reset_camera()  # type: ignore[call-arg]
    plotter.camera.zoom(1.4)
    plotter.add_axes()  # type: ignore[call-arg]
    return plotter


def _up(direction: np.ndarray) -> np.ndarray:
    """A view-up vector not parallel to the viewing direction."""
    axis = np.eye(3)[int(np.argmin(np.abs(direction)))]
    return axis - (axis @ direction) / (direction @ direction) * direction


def _save(plotter, filename: str | Path) -> Path:
    path = Path(filename)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        plotter.screenshot(str(path))
    finally:
        plotter.close()
    return path


def plot_deformed(
    scene: Scene,
    filename: str | Path,
    scale: float | None = None,
    title: str = "",
    stress_unit: str = "Pa",
    obstacles: bool = True,
    subdomains: Sequence[str] | None = None,
) -> Path:
    """Save a PNG of :func:`deformed_plotter`'s picture; returns its path."""
    plotter = deformed_plotter(scene, scale, title, stress_unit, obstacles, subdomains)
    return _save(plotter, filename)


def plot_contact_pressure(
    contact: ContactInterface | ContactBoundary,
    filename: str | Path,
    scale: float = 1.0,
    title: str = "",
    unit: str = "Pa",
) -> Path:
    """Save a PNG of :func:`contact_pressure_plotter`'s picture; returns its path."""
    return _save(contact_pressure_plotter(contact, scale, title, unit), filename)


def plot_contact_pressures(
    scene: Scene,
    filename: str | Path,
    scale: float = 1.0,
    title: str = "",
    unit: str = "Pa",
    view: tuple[float, float, float] = (0.0, -1.0, 0.9),
) -> Path:
    """Save a PNG of :func:`contact_pressures_plotter`'s picture; returns its path."""
    return _save(contact_pressures_plotter(scene, scale, title, unit, view), filename)


def _add_active_points(plotter, surface, active: np.ndarray, name: str, color: str, size: int):
    """The nodes in contact as dots (actor ``active <name>``), if there are any."""
    import pyvista  # optional, as in the other drawing functions

    if active.any():
        plotter.add_mesh(
            pyvista.PolyData(surface.points[active]),
            color=color,
            point_size=size,
            render_points_as_spheres=True,
            name=f"active {name}",
        )


# -- matplotlib charts ---------------------------------------------------------------------
def pyplot():
    """Pyplot of matplotlib without a display (extra ``viz``)."""
    import matplotlib  # optional dependency: imported when a chart is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def unrolled_wall(contact, reference=(1.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A contact surface on a cylinder, unrolled: triangles in (angle [deg], axial position).

    The angle is measured around the cylinder's axis from ``reference`` (projected onto the
    plane normal to the axis), in [-180, 180); the axial position from the obstacle's point.
    Triangles across the seam at +-180 degrees are drawn on both sides.

    Returns:
        ``(angle, axial, pressure)``, each of shape (triangles, 3): the triangles' corners.
    """
    obstacle = contact.obstacle
    if not isinstance(obstacle, Cylinder):
        raise InputError(
            f"contact {contact.name!r} presses on a {type(obstacle).__name__}, not a Cylinder: "
            "only a wall around a cylinder can be unrolled; draw it with plot_contact_pressures"
        )
    topology, cell_types, x = dolfinx.plot.vtk_mesh(contact.pressure.function_space)
    corners = {5: 3, 9: 4}  # VTK triangle, quadrilateral
    if len(np.unique(cell_types)) != 1 or int(cell_types[0]) not in corners:
        raise InputError(f"contact {contact.name!r}: its mesh must be all triangles or all quads")
    n = corners[int(cell_types[0])]
    cells = topology.reshape(-1, n + 1)[:, 1:]
    triangles = cells if n == 3 else np.vstack([cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]])
    axis = obstacle.axis
    e1 = np.asarray(reference, float) - (np.asarray(reference, float) @ axis) * axis
    if np.linalg.norm(e1) < 1e-12:
        raise InputError(f"reference {tuple(reference)} is parallel to the cylinder's axis")
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    r = x - obstacle.point
    angle = np.degrees(np.arctan2(r @ e2, r @ e1))[triangles]
    axial = (r @ axis)[triangles]
    pressure = contact.pressure.x.array[triangles]
    seam = np.ptp(angle, axis=1) > 180.0  # corners on both sides of +-180 degrees
    wrapped = np.where(angle[seam] < 0.0, angle[seam] + 360.0, angle[seam])
    angle = np.vstack([angle[~seam], wrapped, wrapped - 360.0])
    axial = np.vstack([axial[~seam], axial[seam], axial[seam]])
    pressure = np.vstack([pressure[~seam], pressure[seam], pressure[seam]])
    return angle, axial, pressure


def _direction_name(direction) -> str:
    """``+x`` for (1, 0, 0) and the like, else the vector."""
    d = np.asarray(direction, float)
    axis = int(np.argmax(np.abs(d)))
    if np.count_nonzero(d) == 1:
        return f"{'+' if d[axis] > 0 else '-'}{'xyz'[axis]}"
    return str(tuple(float(c) for c in d))


def wall_pressures_figure(
    scene: Scene,
    rows: Sequence[Sequence[str]],
    unit: str = "Pa",
    title: str = "",
    reference=(1.0, 0.0, 0.0),
    length_unit: tuple[float, str] = (1e-3, "mm"),
):
    """Contact pressure on walls around cylinders (pins in holes), unrolled, one panel each.

    ``rows`` names the contact surfaces panel by panel; all share one colour scale. Every
    panel shows angle around its cylinder (0 along ``reference``) against the position
    along its axis, so no wall hides another. Rank-local, as the pyvista pictures.

    Returns:
        The matplotlib figure; save and close it (:func:`plot_wall_pressures` does).
    """
    from matplotlib.tri import Triangulation  # optional dependency, as pyplot

    plt = pyplot()
    contacts = {c.name: c for c in scene.contacts}
    unknown = [name for row in rows for name in row if name not in contacts]
    if unknown:
        raise InputError(f"no contact surface named {unknown}; the scene has {sorted(contacts)}")
    walls = {name: unrolled_wall(contacts[name], reference) for row in rows for name in row}
    every = np.concatenate([p.ravel() for _, _, p in walls.values()])
    divisor, shown = _scaled_unit(float(np.abs(every).max(initial=0.0)), unit)
    top = float(every.max(initial=0.0)) / divisor
    length, length_name = length_unit
    ncols = max(len(row) for row in rows)
    fig, axes = plt.subplots(
        len(rows), ncols, figsize=(2.6 * ncols + 1.5, 2.4 * len(rows) + 0.8),
        sharex=True, squeeze=False, layout="constrained",
    )  # fmt: skip
    image = None
    for i, row in enumerate(rows):
        for j in range(ncols):
            ax = axes[i, j]
            if j >= len(row):
                ax.set_visible(False)
                continue
            angle, axial, pressure = walls[row[j]]
            mesh = Triangulation(
                angle.ravel(), axial.ravel() / length, np.arange(angle.size).reshape(-1, 3)
            )
            image = ax.tripcolor(
                mesh, pressure.ravel() / divisor, shading="gouraud", cmap="viridis",
                vmin=0.0, vmax=top if top > 0 else 1.0,
            )  # fmt: skip
            ax.set_xlim(-180.0, 180.0)
            ax.set_xticks([-180, -90, 0, 90, 180])
            ax.set_title(row[j], fontsize=9)
            if i == len(rows) - 1:
                ax.set_xlabel(f"angle from {_direction_name(reference)} [deg]")
            if j == 0:
                ax.set_ylabel(f"along the axis [{length_name}]")
    label = f"contact pressure [{shown}]" + ("" if top > 0 else " (no contact)")
    fig.colorbar(image, ax=axes, label=label, shrink=0.9)
    if title:
        fig.suptitle(title)
    return fig


def plot_wall_pressures(scene: Scene, filename: str | Path, rows, **kwargs) -> Path:
    """Save :func:`wall_pressures_figure` as a PNG; returns its path."""
    fig = wall_pressures_figure(scene, rows, **kwargs)
    path = Path(filename)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fig.savefig(path, dpi=110)
    finally:
        pyplot().close(fig)
    return path
