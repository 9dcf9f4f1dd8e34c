"""The verification models: closed-form cases and the scenes tests, demos and benchmarks share.

Each case returns records ``{case, quantity, value, reference, rel_error, tolerance, passed}``.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.obstacles import Plane
from dd_contact.post import boundary_average, cell_stress
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import (
    ContactBoundary,
    ContactInterface,
    Interface,
    Scene,
)
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "BAR",
    "BAR_IMPACT",
    "HERTZ",
    "ORDER_SCENES",
    "Record",
    "bar_impact",
    "bent_bar",
    "block_scene",
    "blocks",
    "displacements",
    "distort_in_plane",
    "free_vibration",
    "hertz",
    "locator",
    "order_scene",
    "orders_agreement",
    "patch_test",
    "record",
    "stress_error",
]


@dataclass
class Record:
    """One verified quantity."""

    case: str
    quantity: str
    value: float
    reference: float
    rel_error: float
    tolerance: float
    passed: bool


def record(case: str, quantity: str, value: float, reference: float, tol: float) -> Record:
    """A record of ``value`` against ``reference`` with relative tolerance ``tol``."""
    rel = abs(value - reference) / abs(reference)
    return Record(case, quantity, float(value), float(reference), float(rel), tol, bool(rel <= tol))


def locator(axis: int, coordinate: float) -> Callable[[np.ndarray], np.ndarray]:
    """The points on the plane ``x[axis] = coordinate``."""
    return lambda x: np.isclose(x[axis], coordinate)


# -- tied patch test -----------------------------------------------------------------------
def patch_test(
    kappa: float = 1e6,
    surface_cell: str = "quadrilateral",
    volume_cell: str = "hexahedron",
    comm: MPI.Comm = MPI.COMM_WORLD,
    traction: float = 1.0e6,
) -> float:
    """Two non-matching boxes tied through a third mesh under uniaxial tension.

    Omega1 = [0,1]^3 (3x5x5 cells) and Omega2 = [1,2]x[0,1]^2 (4x7x3 cells), tied through a
    4x6 interface on x = 1; symmetry planes x=0, y=0, z=0; traction on x = 2. The exact
    stress is uniform sigma_xx = traction, all other components zero.

    Returns:
        The largest deviation of any stress component in any cell, relative to the traction.
    """
    steel = Material(E=210e9, nu=0.3)
    left = Subdomain(
        meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 1], [3, 5, 5], volume_cell), steel, "left"
    )
    right = Subdomain(
        meshes.box(MPI.COMM_SELF, [1, 0, 0], [2, 1, 1], [4, 7, 3], volume_cell), steel, "right"
    )
    for axis in range(3):
        for sub in (left, right):
            if not (sub is right and axis == 0):
                sub.fix(locator(axis, 0.0), components=[axis])
    right.add_traction(locator(0, 2.0), (traction, 0.0, 0.0))
    interface = Interface.from_boundary(
        left, locator(0, 1.0), [left, right], resolution=(4, 6), cell_type=surface_cell, kappa=kappa
    )
    scene = Scene(comm, [left, right], interface)
    StaticProblem(scene).solve()
    return stress_error(scene, 0, traction)


def stress_error(scene: Scene, axis: int, traction: float) -> float:
    """Largest deviation of any cell's stress from uniaxial ``traction`` along ``axis``.

    Relative to the traction, over every cell of every subdomain.
    """
    exact = np.zeros((3, 3))
    exact[axis, axis] = traction
    return max(
        float(np.abs(cell_stress(s) - exact).max()) / abs(traction) for s in scene.subdomains
    )


# -- bent bar against one conforming mesh --------------------------------------------------
BAR = {"length": 10.0, "width": 1.0, "height": 1.0, "E": 1.0e3, "nu": 0.3, "force": 1.0e-2}


def _bar_subdomain(x0: float, x1: float, cells: tuple[int, int, int], name: str) -> Subdomain:
    return Subdomain(
        meshes.box(MPI.COMM_SELF, [x0, 0.0, 0.0], [x1, BAR["width"], BAR["height"]], cells),
        Material(BAR["E"], BAR["nu"]),
        name,
    )


def _load_bar(clamped: Subdomain, tip: Subdomain) -> None:
    clamped.fix(locator(0, 0.0))
    area = BAR["width"] * BAR["height"]
    tip.add_traction(locator(0, BAR["length"]), (0.0, 0.0, -BAR["force"] / area))


def bent_bar(
    refinement: int = 1,
    kappa: float = 1e6,
    matching: bool = True,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> tuple[float, float]:
    """A cantilever (10 x 1 x 1, clamped at x = 0, shear load at the tip), cut at x = 5.

    The tied model has two halves tied through an interface mesh: with ``matching`` the
    halves and the interface have the single mesh's cells (the difference is then the
    penalty's alone); otherwise the right half and the interface use other resolutions.

    Returns:
        Tip deflection (mean u_z over the tip face) of the tied model and of one conforming
        mesh with the left half's resolution.
    """
    r = refinement
    L = BAR["length"]
    single = _bar_subdomain(0.0, L, (10 * r, 2 * r, 2 * r), "bar")
    _load_bar(single, single)
    StaticProblem(Scene(comm, [single])).solve()
    reference = boundary_average(single, locator(0, L))[2]

    left = _bar_subdomain(0.0, L / 2, (5 * r, 2 * r, 2 * r), "left")
    right_cells = (5 * r, 2 * r, 2 * r) if matching else (4 * r, 3 * r, 3 * r)
    right = _bar_subdomain(L / 2, L, right_cells, "right")
    _load_bar(left, right)
    interface = Interface.from_boundary(
        left,
        locator(0, L / 2),
        [left, right],
        resolution=(2 * r, 2 * r) if matching else (3 * r, 4 * r),
        cell_type="quadrilateral" if matching else "triangle",
        kappa=kappa,
    )
    StaticProblem(Scene(comm, [left, right], interface)).solve()
    return float(boundary_average(right, locator(0, L))[2]), float(reference)


# -- Hertz ---------------------------------------------------------------------------------
#: The Hertz model: a quarter hemisphere of radius R (E, nu) pushed by its flat face onto a
#: rigid plane; the approach is prescribed, the force is what the contact carries.
HERTZ = {"radius": 1.0, "E": 1.0, "nu": 0.3, "approach": 0.03, "h_far": 0.2}


def hertz(
    h_contact: float,
    points: str = "nodes",
    contact: str = "boundary",
    contact_kappa: float | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dict:
    """Elastic hemisphere on a rigid plane against Hertz's closed form.

    The flat face z = R is pushed down by ``approach``; symmetry planes x = 0 and y = 0.
    Hertz (E* = E / (1 - nu^2), rigid plane): a = (3 F R / (4 E*))^(1/3), p0 = 3F/(2 pi a^2),
    evaluated with the computed contact force F.

    Args:
        h_contact: Mesh size near the pole.
        points: Contact scheme, ``"nodes"`` or ``"quadrature"``.
        contact: ``"boundary"`` (contact on the body's own boundary, the FULL baseline) or
            ``"interface"`` (a contact interface, a copy of the cap's facets, tied to it).
        contact_kappa: Dimensionless contact penalty.
        comm: Communicator of the analysis.

    Returns:
        force, contact radius (``a``: radius of the circle with the active area; ``a_edge``:
        largest radius of an active point), peak pressure, the Hertz values, iterations,
        state changes, dofs, and the pressure profile (r, p) at the contact points.
    """
    R, E, nu = HERTZ["radius"], HERTZ["E"], HERTZ["nu"]
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, 0.18 * R, h_contact, HERTZ["h_far"] * R)
    ball = Subdomain(mesh, Material(E, nu), "ball")
    ball.fix((tags, meshes.HEMISPHERE_TOP), components=[2], value=[0, 0, -HERTZ["approach"]])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    cap = (tags, meshes.HEMISPHERE_CURVED)
    cap_facets = ball.locate_facets(cap)
    # Only the cap near the pole can touch: keep the contact surface small.
    mid = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap_facets)].mean(axis=1)
    near = cap_facets[mid[:, 2] < 0.15 * R]
    kwargs = {"contact_kappa": contact_kappa, "points": points, "name": "cap"}
    if contact == "boundary":
        zone = ContactBoundary(ball, near, plane, **kwargs)
    else:
        zone = ContactInterface.from_boundary(ball, near, plane, **kwargs)
    problem = StaticProblem(Scene(comm, [ball], contacts=[zone]))
    problem.solve()
    force = 4.0 * problem.contact_forces()["cap"][2]  # quarter model
    E_star = E / (1.0 - nu**2)
    a_ref = (3.0 * force * R / (4.0 * E_star)) ** (1.0 / 3.0)
    p0_ref = 3.0 * force / (2.0 * np.pi * a_ref**2)
    result = {"force": force, "a_ref": a_ref, "p0_ref": p0_ref, "dofs": ball.num_dofs}
    result.update(problem.changes)
    result["iterations"] = problem.iterations
    local = None
    if problem.zones:
        op = problem.zones[0].operator
        p = op.point_pressure(zone.w.x.array[: op.num_dofs])
        active = p > 0
        r = np.linalg.norm(op.points.x[:, :2], axis=1)
        order = np.argsort(r[active])
        local = {
            "a": float(np.sqrt(4.0 * op.points.weight[active].sum() / np.pi)),
            "a_edge": float(r[active].max()),
            "p_max": float(p.max()),
            "profile_r": r[active][order].tolist(),
            "profile_p": p[active][order].tolist(),
        }
    for part in comm.allgather(local):
        if part is not None:
            result.update(part)
    return result


# -- bar impact ----------------------------------------------------------------------------
#: An elastic bar (E = rho = 1, nu = 0 so it is exactly one-dimensional, c = 1) of length 1
#: and section 0.1 x 0.1 hits a rigid wall at x = 0 with speed v0.
BAR_IMPACT = {"length": 1.0, "section": 0.1, "v0": 0.01}


def bar_impact(
    n: int = 40,
    cfl: float = 0.5,
    contact_kappa: float | None = None,
    contact: str = "boundary",
    end_time: float = 3.0,
    split: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    algorithm: str = "FULL",
    energy_safe_contact: bool = True,
    mass: str = "consistent",
    scheme: str = "trapezoidal",
    rho_infinity: float | None = None,
) -> dict:
    """Bar impact on a rigid wall: contact duration, rebound velocity, energy and force.

    The exact answer (1-D wave theory): contact lasts 2L/c at the force rho c v0 A, the
    bar leaves with velocity -v0 and no strain, so kinetic energy is restored.

    Args:
        n: Elements along the bar.
        cfl: Time step in units of h / c.
        contact_kappa: Dimensionless contact penalty (default: the package's).
        contact: ``"boundary"`` or ``"interface"`` (a 1x1 contact interface on the end).
        end_time: Simulated time (in units of L / c).
        split: Cut the bar in the middle into two subdomains tied by an interface.
        comm: Communicator.
        algorithm: Elimination order.
        energy_safe_contact: See :class:`dd_contact.TransientProblem`.
        mass: See :class:`dd_contact.TransientProblem`.
        scheme: See :class:`dd_contact.TransientProblem`.
        rho_infinity: See :class:`dd_contact.TransientProblem`.

    Returns:
        duration, rebound (mean velocity after / -v0), energy ratio after/before, changes,
        factorisations, steps, the contact force of every step (``forces``), its largest
        (``peak_force``) and its median while in contact (``plateau_force``) against
        ``force_ref`` = rho c v0 A.
    """
    L, a, v0 = BAR_IMPACT["length"], BAR_IMPACT["section"], BAR_IMPACT["v0"]
    material = Material(1.0, 0.0, 1.0)
    cuts = [0.0, L / 2, L] if split else [0.0, L]
    parts = [
        Subdomain(
            meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x1, a, a], [round(n * (x1 - x0) / L), 1, 1]),
            material,
            f"bar{k}" if split else "bar",
        )
        for k, (x0, x1) in enumerate(itertools.pairwise(cuts))
    ]
    for part in parts:
        part.velocity.interpolate(
            lambda x: np.vstack([np.full(x.shape[1], -v0), 0 * x[0], 0 * x[0]])
        )
    bar = parts[0]
    interface = (
        Interface.from_boundary(bar, locator(0, L / 2), parts, resolution=(1, 1)) if split else None
    )
    wall = Plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    end = locator(0, 0.0)
    if contact == "boundary":
        zone = ContactBoundary(bar, end, wall, contact_kappa=contact_kappa, name="end")
    else:
        zone = ContactInterface.from_boundary(
            bar, end, wall, resolution=(1, 1), contact_kappa=contact_kappa, name="end"
        )
    dt = cfl * L / n
    problem = TransientProblem(
        Scene(comm, parts, interface, contacts=[zone]),
        dt,
        algorithm=algorithm,
        energy_safe_contact=energy_safe_contact,
        mass=mass,
        scheme=scheme,
        rho_infinity=rho_infinity,
    )
    # The signed penetration of the end: positive in contact, negative once the bar has left.
    penetration = []

    def record(_):
        local = None
        if problem.zones:
            op = problem.zones[0].operator
            local = float(op.penetration(zone.w.x.array[: op.num_dofs]).mean())
        penetration.append(next(p for p in comm.allgather(local) if p is not None))

    problem.run(round(end_time / dt), callback=record, progress=False, summary=False)
    g = np.array(penetration)
    times = dt * np.arange(1, len(g) + 1)
    k = int(np.argmax(g < 0))  # first step apart
    duration = times[k - 1] + dt * g[k - 1] / (g[k - 1] - g[k])
    momentum, total_mass = 0.0, 0.0
    for part in parts:
        M = problem.model.mass.get(part.block)
        if M is not None:  # owned here
            ones = np.zeros(part.num_dofs)
            ones[0::3] = 1.0
            momentum += float(ones @ (M @ part.velocity.x.array))
            total_mass += float(ones @ (M @ ones))
    momentum, total_mass = comm.allreduce(momentum), comm.allreduce(total_mass)
    work = problem.work_summary()  # collective: every rank's work, merged
    energy0 = 0.5 * total_mass * v0**2
    forces = np.array([np.linalg.norm(r["force"]["end"]) for r in problem.history])
    pressing = forces[forces > 0]
    return {
        "forces": forces.tolist(),
        "peak_force": float(forces.max()),
        "plateau_force": float(np.median(pressing)) if len(pressing) else 0.0,
        "force_ref": material.rho * np.sqrt(material.E / material.rho) * v0 * a * a,
        "duration": float(duration),
        "duration_ref": 2.0 * L,
        "rebound": momentum / total_mass / v0,
        "energy_ratio": problem.energy()["total"] / energy0,
        "changes": problem.changes["gamma"],
        "factorisations": comm.allreduce(problem.work.count("sparse_factor", "FULL"), op=MPI.MAX),
        "steps": len(g),
        "history": [record["changes"] for record in problem.history],
        "substitutions": sum(work.get(part.block, {}).get("substitutions", 0) for part in parts),
    }


# -- free vibration ------------------------------------------------------------------------
def free_vibration(
    steps: int = 1000, kappa: float | None = None, comm: MPI.Comm = MPI.COMM_WORLD
) -> dict:
    """Energy of a tied two-part cantilever in free vibration (no contact, no load).

    The cantilever 4 x 1 x 1 (E = 1000, nu = 0.3, rho = 1) is clamped at x = 0, cut at x = 2
    into two non-matching halves tied by an interface, and released from a bent shape with
    an initial velocity. The trapezoidal rule conserves energy exactly for a linear system.

    Args:
        steps: Number of time steps (dt = 0.01, about 1/30 of the first period).
        kappa: Tie penalty (default :data:`dd_contact.scene.DEFAULT_KAPPA`).
        comm: Communicator.

    Returns:
        Initial energy, the largest relative drift over the run, and the energies.
    """
    material = Material(1000.0, 0.3, 1.0)
    left = Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, 0], [2, 1, 1], [6, 3, 3]), material, "left")
    right = Subdomain(meshes.box(MPI.COMM_SELF, [2, 0, 0], [4, 1, 1], [5, 2, 2]), material, "right")
    left.fix(locator(0, 0.0))
    interface = Interface.from_boundary(
        left, locator(0, 2.0), [left, right], resolution=(3, 3), kappa=kappa
    )
    for sub in (left, right):
        sub.u.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], 1e-3 * x[0] ** 2]))
        sub.velocity.interpolate(lambda x: np.vstack([0 * x[0], 1e-2 * x[0], 0 * x[0]]))
    left.u.x.array[left.dirichlet[0]] = 0.0
    problem = TransientProblem(Scene(comm, [left, right], interface), dt=0.01)
    problem.start()
    e0 = problem.energy()["total"]
    history = problem.run(steps, progress=False, summary=False)
    energies = np.array([h["energy"]["total"] for h in history])
    return {
        "energy0": e0,
        "drift": float(np.max(np.abs(energies - e0)) / e0),
        "energies": energies.tolist(),
    }


# -- every elimination order against FULL ----------------------------------------------------
#: Scene kinds of :func:`order_scene` and the decomposition orders each one admits.
ORDER_SCENES = {
    "interface": ("v-w-u", "w-v-u"),  # two blocks, an interface, a contact interface
    "boundary": ("v-u",),  # two blocks, an interface, contact on a block's own boundary
    "single": ("w-u",),  # one block with a contact interface
}


def blocks(kind: str, volume_cell: str = "hexahedron") -> list[Subdomain]:
    """The blocks of :func:`block_scene` (no loads, no supports).

    A = [0,1]^3 (4x3x3 cells) and, unless ``kind`` is ``"single"``, the non-matching
    B = [1,2]x[0,1]^2 (3x4x4 cells); E = 1000, nu = 0.3, rho = 1.
    """
    material = Material(1000.0, 0.3, 1.0)

    def box(x0: float, n: list[int]) -> dolfinx.mesh.Mesh:
        return meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x0 + 1, 1, 1], n, volume_cell)

    parts = [Subdomain(box(0.0, [4, 3, 3]), material, "A")]
    if kind != "single":
        parts.append(Subdomain(box(1.0, [3, 4, 4]), material, "B"))
    return parts


def block_scene(
    kind: str,
    parts: list[Subdomain],
    wall: Plane,
    comm: MPI.Comm,
    kappa: float | None = None,
    contact_tie_kappa: float | None = None,
    contact_kappa: float = 1.0,
    surface_cell: str = "quadrilateral",
    resolution: tuple[int, int] = (3, 3),
    distortion: float = 0.0,
) -> Scene:
    """The scene of :func:`blocks`: their surfaces and the rigid ``wall`` at A's end x = 0.

    ``kind`` (:data:`ORDER_SCENES`) says which surfaces there are: ``"interface"`` an
    interface on x = 1 and a contact interface on x = 0; ``"boundary"`` the interface and
    contact on A's own boundary; ``"single"`` a contact interface only. The surface meshes
    have ``resolution`` cells of ``surface_cell``; ``distortion`` moves their interior nodes
    in-plane (:func:`distort_in_plane`).
    """
    a = parts[0]

    def surface(x: float):
        mesh = meshes.surface_from_boundary(
            a.mesh, locator(0, x), resolution, surface_cell, comm=MPI.COMM_SELF
        )
        return distort_in_plane(mesh, distortion) if distortion else mesh

    interface = None
    if kind != "single":
        interface = Interface(surface(1.0), parts, kappa=kappa)
    if kind == "boundary":
        zone = ContactBoundary(a, locator(0, 0.0), wall, contact_kappa=contact_kappa, name="end")
    else:
        zone = ContactInterface(
            surface(0.0), a, wall, kappa=contact_tie_kappa, contact_kappa=contact_kappa, name="end"
        )
    return Scene(comm, parts, interface, contacts=[zone])


def distort_in_plane(mesh: dolfinx.mesh.Mesh, amount: float) -> dolfinx.mesh.Mesh:
    """Move the interior nodes of a planar surface mesh within its plane (in place).

    Each interior node moves by up to ``amount`` times the shortest cell edge along each of
    two in-plane directions, in a fixed pseudo-random pattern of its position (the same on
    every rank); boundary nodes stay, so the mesh still covers the same region.
    """
    topology = mesh.topology
    topology.create_entities(1)
    topology.create_connectivity(1, 2)
    x = mesh.geometry.x
    edges = dolfinx.mesh.entities_to_geometry(
        mesh, 1, np.arange(topology.index_map(1).size_local, dtype=np.int32)
    )
    h = float(np.linalg.norm(x[edges[:, 1]] - x[edges[:, 0]], axis=1).min())
    outer = dolfinx.mesh.entities_to_geometry(
        mesh, 1, dolfinx.mesh.exterior_facet_indices(topology)
    )
    interior = np.setdiff1d(np.arange(len(x)), outer)
    _, _, axes = np.linalg.svd(x - x.mean(axis=0))
    phase = x[interior] @ np.array([12.9898, 78.233, 37.719])
    shift = np.sin(phase)[:, None] * axes[0] + np.cos(1.7 * phase + 0.5)[:, None] * axes[1]
    x[interior] += amount * h * shift
    return mesh


def order_scene(
    kind: str, dynamic: bool, kappa: float | None = None, comm: MPI.Comm = MPI.COMM_WORLD
) -> Scene:
    """A small scene whose contact state changes, for comparing elimination orders.

    Non-matching blocks A = [0,1]^3 and B = [1,2]x[0,1]^2 (``"single"``: A only) against a
    rigid wall at x = -0.002. Statically, the far end is pushed and tilted so part of the end
    face A touches and part lifts off; dynamically, both blocks fly at the wall with a
    velocity that varies across the section, so the contact area grows and shrinks.

    Args:
        kind: One of :data:`ORDER_SCENES`.
        dynamic: Flying blocks (for TransientProblem) instead of a pushed, held bar.
        kappa: Tie penalty of the interface and contact interface (default: the default).
        comm: Communicator.
    """
    parts = blocks(kind)
    far = parts[-1]
    if dynamic:
        for part in parts:
            part.velocity.interpolate(
                lambda x: np.vstack([-1.0 - 0.8 * (x[1] - 0.5), 0 * x[0], 0.2 + 0 * x[0]])
            )
    else:
        end = float(len(parts))
        far.fix(
            locator(0, end),
            value=lambda x: np.vstack([-0.004 - 0.02 * (x[1] - 0.5), 0 * x[0], 0 * x[0]]),
        )
    wall = Plane([-0.002, 0, 0], [1, 0, 0])
    return block_scene(kind, parts, wall, comm, kappa=kappa, contact_tie_kappa=kappa)


def displacements(scene: Scene) -> np.ndarray:
    """Every displacement of a scene (subdomains, interface, contacts) in one vector."""
    parts = [s.u.x.array for s in scene.subdomains]
    if scene.interface is not None:
        parts.append(scene.interface.v.x.array)
    return np.concatenate(parts)


def _run_order(kind, dynamic, kappa, order, comm, steps, dt):
    scene = order_scene(kind, dynamic, kappa, comm)
    if dynamic:
        problem = TransientProblem(scene, dt, algorithm=order)
        states = []
        problem.run(
            steps,
            progress=False,
            summary=False,
            callback=lambda _: states.append(displacements(scene)),
        )
        path = [r["changes"] for r in problem.history]
    else:
        problem = StaticProblem(scene, algorithm=order)
        problem.solve()
        states, path = [displacements(scene)], [problem.changes["gamma"]]
    return np.array(states), path, problem


def orders_agreement(
    kappa: float | None = 1e4,
    steps: int = 40,
    dt: float = 0.01,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> list[dict]:
    """Every decomposition order against FULL on the same scenes (static and dynamic).

    Returns:
        One dict per scene kind, static/dynamic and order: ``difference`` (largest over the
        steps of ||x - x_FULL|| / ||x_FULL||, x the subdomain and interface displacements),
        ``same_path`` (the contact state changes at the same steps) and ``changes`` (gamma).
    """
    out = []
    for kind, orders in ORDER_SCENES.items():
        for dynamic in (False, True):
            ref, ref_path, _ = _run_order(kind, dynamic, kappa, "FULL", comm, steps, dt)
            for order in orders:
                x, path, _ = _run_order(kind, dynamic, kappa, order, comm, steps, dt)
                diff = np.linalg.norm(x - ref, axis=1) / np.linalg.norm(ref, axis=1)
                out.append(
                    {
                        "scene": kind,
                        "dynamic": dynamic,
                        "order": order,
                        "difference": float(diff.max()),
                        "same_path": path == ref_path,
                        "changes": int(sum(path)),
                    }
                )
    return out
