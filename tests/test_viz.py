"""Pictures: colour ranges, units, obstacles and contact pressure, checked with numbers."""

import os
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

import dd_contact as dd
from dd_contact import meshes, post, viz

pyvista = pytest.importorskip("pyvista")
matplotlib_colors = pytest.importorskip("matplotlib.colors")
matplotlib_image = pytest.importorskip("matplotlib.image")

ROOT = Path(__file__).resolve().parents[1]
STEEL = dd.Material(E=210e9, nu=0.3)


def _on(axis, value):
    return lambda x: np.isclose(x[axis], value)


def _block(n=3):
    return dd.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [n, n, n]), STEEL, "block")


def _uniaxial(stress=1e6):
    """A unit cube on rollers pulled along x: von Mises = stress up to round-off."""
    block = _block()
    for axis in range(3):
        block.fix(_on(axis, 0.0), components=[axis])
    block.add_traction(_on(0, 1.0), (stress, 0.0, 0.0))
    scene = dd.Scene(MPI.COMM_WORLD, [block])
    dd.StaticProblem(scene).solve()
    return scene


def _pressed():
    """A cube pressed 1e-4 m onto the plane z = 0 by its clamped top: varying stress."""
    block = _block()
    block.fix(_on(2, 1.0), value=[0.0, 0.0, -1e-4])
    contact = dd.ContactBoundary(block, _on(2, 0.0), dd.Plane([0, 0, 0], [0, 0, 1]), name="floor")
    scene = dd.Scene(MPI.COMM_WORLD, [block], contacts=[contact])
    dd.StaticProblem(scene).solve()
    return scene, contact


def _mapper_range(plotter, actor):
    return np.array(plotter.actors[actor].mapper.scalar_range)


def _bar_titles(plotter):
    return [bar.GetTitle() for bar in plotter.scalar_bars.values()]


def _cell_colours(plotter, actor, name):
    """The RGB the lookup table gives each drawn cell (the colours before shading)."""
    mapper = plotter.actors[actor].mapper
    values = mapper.dataset.cell_data[name]
    table = mapper.lookup_table
    return np.array([table.map_value(float(v), opacity=False) for v in values])


def _hues(png, min_saturation=0.3):
    """Hues (0..1) of the saturated pixels of the picture's middle.

    The middle (15 % to 80 % of the width) leaves out the colour bar on the right and the
    axes at the bottom left; shading changes a colour's value, not its hue.
    """
    image = matplotlib_image.imread(png)[:, :, :3]
    width = image.shape[1]
    hsv = matplotlib_colors.rgb_to_hsv(image[:, int(0.15 * width) : int(0.8 * width)])
    return hsv[hsv[..., 1] > min_saturation, 0]


def _main_hue_share(png):
    """Share of the coloured pixels within 0.02 of their median hue (1: one colour)."""
    hues = _hues(png)
    assert len(hues) > 10_000  # the body fills a good part of the picture
    return np.mean(np.abs(hues - np.median(hues)) < 0.02)


def test_uniform_field_is_one_colour(tmp_path):
    scene = _uniaxial(1e6)
    stress = post.von_mises(scene.subdomains[0]).x.array
    assert 0 < np.ptp(stress) < 1e-6 * stress.max()  # round-off spread, the case that misled
    plotter = viz.deformed_plotter(scene)
    # Bar of +-10 % around 1 MPa, in MPa; every cell one colour of the map.
    assert _mapper_range(plotter, "subdomain block") == pytest.approx([0.9, 1.1], rel=1e-12)
    assert _bar_titles(plotter) == ["von Mises [MPa]\nuniform"]
    colours = _cell_colours(plotter, "subdomain block", "von Mises")
    assert np.ptp(colours, axis=0).max() == 0.0
    png = viz.plot_deformed(scene, tmp_path / "uniform.png")
    assert _main_hue_share(png) > 0.99  # the rest: anti-aliased edges


def test_varying_field_spans_the_map(tmp_path):
    scene, _ = _pressed()
    stress = post.von_mises(scene.subdomains[0]).x.array
    assert np.ptp(stress) > 0.1 * stress.max()
    plotter = viz.deformed_plotter(scene, obstacles=False)
    low, high = _mapper_range(plotter, "subdomain block")
    assert (low, high) == pytest.approx((stress.min() / 1e6, stress.max() / 1e6), rel=1e-12)
    assert _bar_titles(plotter) == ["von Mises [MPa]"]
    colours = _cell_colours(plotter, "subdomain block", "von Mises")
    assert len(np.unique(colours, axis=0)) > 5
    png = viz.plot_deformed(scene, tmp_path / "pressed.png", obstacles=False)
    assert _main_hue_share(png) < 0.5


@pytest.mark.parametrize(
    ("unit", "stress", "shown"),
    [
        ("Pa", 5e2, "Pa"),
        ("Pa", 5e4, "kPa"),
        ("Pa", 2e8, "MPa"),
        ("Pa", 3e9, "GPa"),
        ("N/mm2", 7.0, "N/mm2"),
    ],
)
def test_bar_unit(unit, stress, shown):
    scene = _uniaxial(stress)
    plotter = viz.deformed_plotter(scene, stress_unit=unit)
    assert _bar_titles(plotter)[0].startswith(f"von Mises [{shown}]")
    divisor = {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9, "N/mm2": 1.0}[shown]
    assert np.mean(_mapper_range(plotter, "subdomain block")) == pytest.approx(stress / divisor)
    plotter.close()


def test_bar_title_clear_of_ticks():
    plotter = viz.deformed_plotter(_uniaxial())
    bar = next(iter(plotter.scalar_bars.values()))
    plotter.render()
    # Vertical bar: the title is above the bar and the tick labels beside it.
    assert bar.GetOrientation() == 1
    plotter.close()


def _unsolved_scene(obstacle):
    block = _block(2)
    block.fix(_on(2, 1.0))
    contact = dd.ContactBoundary(block, _on(2, 0.0), obstacle, name="bottom")
    return dd.Scene(MPI.COMM_WORLD, [block], contacts=[contact])


HALF_PLANE = 0.75 * 3**0.5  # the plane: 1.5 x the model's diagonal (sqrt 3) wide
HALF_PIN = 0.6 * 3**0.5  # the pin: 1.2 x the diagonal long


@pytest.mark.parametrize(
    ("obstacle", "bounds"),
    [
        (
            dd.Plane([0, 0, 0], [0, 0, 1]),
            [0.5 - HALF_PLANE, 0.5 + HALF_PLANE, 0.5 - HALF_PLANE, 0.5 + HALF_PLANE, 0, 0],
        ),
        (dd.Sphere([0.5, 0.5, -2.0], 2.0), [-1.5, 2.5, -1.5, 2.5, -4.0, 0.0]),
        # A pin along y under the model, centred on it along its axis.
        (
            dd.Cylinder([0.5, 0, -1.0], [0, 1, 0], 1.0),
            [-0.5, 1.5, 0.5 - HALF_PIN, 0.5 + HALF_PIN, -2.0, 0.0],
        ),
    ],
)
def test_obstacles_drawn(obstacle, bounds):
    plotter = viz.deformed_plotter(_unsolved_scene(obstacle))
    drawn = plotter.actors["obstacle bottom"].mapper.dataset.bounds
    assert np.array(drawn) == pytest.approx(bounds, abs=0.01)
    assert "contact bottom" in plotter.actors  # the contact surface too
    plotter.close()
    plotter = viz.deformed_plotter(_unsolved_scene(obstacle), obstacles=False)
    assert "obstacle bottom" not in plotter.actors
    plotter.close()


def test_interface_drawn():
    left = dd.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]), STEEL, "l")
    right = dd.Subdomain(meshes.box(MPI.COMM_SELF, [1, 0, 0], [2, 1, 1], [3, 3, 3]), STEEL, "r")
    left.fix(_on(0, 0.0))
    interface = dd.Interface.from_boundary(left, _on(0, 1.0), [left, right], resolution=(4, 4))
    plotter = viz.deformed_plotter(dd.Scene(MPI.COMM_WORLD, [left, right], interface))
    bounds = np.array(plotter.actors["interface"].mapper.dataset.bounds)
    assert bounds == pytest.approx([1, 1, 0, 1, 0, 1])
    assert {"subdomain l", "subdomain r"} <= set(plotter.actors)
    plotter.close()


def test_contact_pressure(tmp_path):
    scene, contact = _pressed()
    pressure = contact.pressure.x.array
    assert pressure.min() > 0  # the whole bottom is pressed, more at the clamped edges
    plotter = viz.contact_pressure_plotter(contact)
    low, high = _mapper_range(plotter, "contact floor")
    assert (low, high) == pytest.approx((pressure.min() / 1e6, pressure.max() / 1e6), rel=1e-12)
    assert _bar_titles(plotter) == ["contact pressure [MPa]"]
    assert plotter.actors["active floor"].mapper.dataset.n_points == len(pressure)
    # Seen from the obstacle: the plane's wall side, below the body.
    assert plotter.camera_position[0][2] < -1.0
    plotter.close()
    png = viz.plot_contact_pressure(contact, tmp_path / "p.png", unit="Pa")
    assert png.stat().st_size > 10_000
    assert _main_hue_share(png) < 0.5
    # The deformed picture marks the same active points.
    plotter = viz.deformed_plotter(scene)
    assert plotter.actors["active floor"].mapper.dataset.n_points == len(pressure)
    plotter.close()


def test_headless_without_environment(tmp_path):
    """A user's script renders with no display and no rendering variables set."""
    script = tmp_path / "user.py"
    script.write_text(
        "from mpi4py import MPI\n"
        "import numpy as np\n"
        "import dd_contact as dd\n"
        "from dd_contact import meshes, viz\n"
        "b = dd.Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [2, 2, 2]),\n"
        "                 dd.Material(E=1e9, nu=0.3), 'b')\n"
        "b.fix(lambda x: np.isclose(x[0], 0.0))\n"
        "b.add_traction(lambda x: np.isclose(x[0], 1.0), (0.0, 0.0, -1e5))\n"
        "scene = dd.Scene(MPI.COMM_WORLD, [b])\n"
        "dd.StaticProblem(scene).solve()\n"
        "print(viz.plot_deformed(scene, 'out/b.png'))\n"
    )
    unset = {"DISPLAY", "WAYLAND_DISPLAY", "PYVISTA_OFF_SCREEN", "VTK_DEFAULT_OPENGL_WINDOW"}
    env = {k: v for k, v in os.environ.items() if k not in unset}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    done = subprocess.run(
        [sys.executable, script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "X server" not in done.stderr + done.stdout
    png = tmp_path / "out" / "b.png"
    assert png.stat().st_size > 10_000
    assert _main_hue_share(png) < 0.9  # coloured by a varying stress


@pytest.fixture(scope="module")
def joint_walls():
    """The tiny pin joint's hole walls with a pressure set as a known function of angle."""
    from dd_contact.paper import models

    scene = models.pin_joint("tiny", comm=MPI.COMM_SELF)
    walls = [c for c in scene.contacts if c.name.startswith("hole_")]
    for c in walls:
        x = c.pressure.function_space.tabulate_dof_coordinates()
        r = x - c.obstacle.point
        angle = np.arctan2(r @ np.array([0.0, 1.0, 0.0]), r @ np.array([1.0, 0.0, 0.0]))
        c.pressure.x.array[:] = 2e6 * (1.0 + np.cos(angle - 0.5))  # 0 to 4 MPa
    return scene, walls


def test_unrolled_wall_angles_and_values(joint_walls):
    _, walls = joint_walls
    for c in walls:
        angle, axial, pressure = viz.unrolled_wall(c)
        cells = c.pressure.function_space.mesh.topology.index_map(2).size_local
        seam = len(angle) - 2 * cells  # triangles across +-180 degrees are drawn twice
        assert seam > 0 and len(angle) == 2 * cells + seam
        assert np.ptp(angle, axis=1).max() < 180.0  # no triangle spans the seam
        assert angle.min() > -360.0 and angle.max() < 360.0
        # Each corner's value is the field at its own angle (also on the duplicated side).
        expected = 2e6 * (1.0 + np.cos(np.radians(angle) - 0.5))
        np.testing.assert_allclose(pressure, expected, rtol=1e-12, atol=1e-6)
        z = c.pressure.function_space.tabulate_dof_coordinates()[:, 2] - c.obstacle.point[2]
        assert np.isclose(axial.min(), z.min()) and np.isclose(axial.max(), z.max())


def test_wall_pressures_figure(joint_walls, tmp_path):
    scene, walls = joint_walls
    rows = [[c.name for c in walls if plate in c.name] for plate in ("upper", "lower")]
    fig = viz.wall_pressures_figure(scene, rows, title="walls")
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_title()]
    assert sorted(ax.get_title() for ax in panels) == sorted(c.name for c in walls)
    bar = fig.axes[-1]
    assert bar.get_ylabel() == "contact pressure [MPa]"
    top = max(c.pressure.x.array.max() for c in walls) / 1e6  # the largest value, in MPa
    assert 3.9 < top <= 4.0 and np.isclose(bar.get_ylim()[1], top, rtol=1e-12)
    assert panels[-1].get_xlabel() == "angle from +x [deg]"
    viz.pyplot().close(fig)
    path = viz.plot_wall_pressures(scene, tmp_path / "walls.png", rows)
    assert matplotlib_image.imread(path).shape[1] > 1000


def test_unrolled_wall_needs_a_cylinder():
    scene, contact = _pressed()
    with pytest.raises(dd.InputError, match="Plane, not a Cylinder"):
        viz.unrolled_wall(contact)
    with pytest.raises(dd.InputError, match="no contact surface named"):
        viz.wall_pressures_figure(scene, [["nowhere"]])
