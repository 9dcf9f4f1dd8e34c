"""The verification models: the cases with closed-form references.

Each case returns records ``{case, quantity, value, reference, rel_error, tolerance, passed}``.
The small block scenes that compare the elimination orders are in
:mod:`~dd_contact.paper.verify.orders`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.accuracy import mesh_size
from dd_contact.obstacles import Plane
from dd_contact.parallel import allgathered
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
    "HERTZ",
    "Record",
    "bent_bar",
    "free_vibration",
    "hertz",
    "locator",
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
    kappa: float | None = None,
    degree: int = 1,
    grading: float = 0.2,
    algorithm: str = "FULL",
    accuracy: str = "balanced",
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
        kappa: Tie penalty of the contact interface (``contact="interface"`` only).
        degree: Lagrange degree of the ball (2 needs ``contact="interface"``).
        grading: Growth of the mesh size away from the pole (``meshes.hemisphere``; 0.2:
            0.1's answer with 65 % of the dofs, half the time: docs/tradeoff.md).
        algorithm: Elimination order (``"w-u"`` fits ``contact="interface"``).
        accuracy: The preset of :class:`dd_contact.StaticProblem` (it sets nothing there)
            and of the mesh: ``h_contact`` times its :data:`dd_contact.accuracy.MESH_FACTORS`
            (fast: 2, reference: 2/3).

    Returns:
        force, contact radius (``a``: radius of the circle with the active area; ``a_edge``:
        largest radius of an active point), peak pressure, the Hertz values, iterations,
        state changes, dofs, and the pressure profile (r, p) at the contact points.
    """
    R, E, nu = HERTZ["radius"], HERTZ["E"], HERTZ["nu"]
    far = HERTZ["h_far"] * R
    h = mesh_size(h_contact, accuracy)  # "balanced": h_contact itself
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, 0.18 * R, h, far, grading=grading)
    ball = Subdomain(mesh, Material(E, nu), "ball", degree=degree)
    ball.fix((tags, meshes.HEMISPHERE_TOP), components=[2], value=[0, 0, -HERTZ["approach"]])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[0])
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    cap = (tags, meshes.HEMISPHERE_CURVED)
    cap_facets = ball.locate_facets(cap)
    # Only the cap near the pole can touch: keep the contact surface small.
    mid = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap_facets)].mean(axis=1)
    near = cap_facets[mid[:, 2] < 0.15 * R]
    kwargs: dict[str, Any] = {"contact_kappa": contact_kappa, "points": points, "name": "cap"}
    zone: ContactBoundary | ContactInterface
    if contact == "boundary":
        zone = ContactBoundary(ball, near, plane, **kwargs)
    else:
        zone = ContactInterface.from_boundary(ball, near, plane, kappa=kappa, **kwargs)
    problem = StaticProblem(
        Scene(comm, [ball], contacts=[zone]), algorithm=algorithm, accuracy=accuracy
    )
    problem.solve()
    force = 4.0 * problem.contact_forces()["cap"][2]  # quarter model
    E_star = E / (1.0 - nu**2)
    a_ref = (3.0 * force * R / (4.0 * E_star)) ** (1.0 / 3.0)
    p0_ref = 3.0 * force / (2.0 * np.pi * a_ref**2)
    result = {"force": force, "a_ref": a_ref, "p0_ref": p0_ref, "dofs": ball.num_dofs}
    result.update(problem.changes)
    result["iterations"] = problem.iterations
    for part in allgathered(comm, _hertz_profile(problem, zone)):
        if part is not None:
            result.update(part)
    return result


def _hertz_profile(problem: StaticProblem, zone: ContactBoundary | ContactInterface) -> dict | None:
    """The active contact points' radii and pressures, where the contact is owned (else None)."""
    if not problem.zones:
        return None
    op = problem.zones[0].operator
    p = op.point_pressure(zone.w.x.array[: op.num_dofs])
    active = p > 0
    r = np.linalg.norm(op.points.x[:, :2], axis=1)
    order = np.argsort(r[active])
    return {
        "a": float(np.sqrt(4.0 * op.points.weight[active].sum() / np.pi)),
        "a_edge": float(r[active].max()),
        "p_max": float(p.max()),
        "profile_r": r[active][order].tolist(),
        "profile_p": p[active][order].tolist(),
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
