"""The verification models: the cases with closed-form references.

Each case returns records ``{case, quantity, value, reference, rel_error, tolerance, passed}``.
The small block scenes that compare the elimination orders are in
:mod:`~dd_contact.paper.verify.orders`.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import forms, meshes
from dd_contact.obstacles import Plane
from dd_contact.parallel import allgathered, max_over_ranks, sum_over_ranks
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
    "Record",
    "bar_impact",
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
    kwargs: dict[str, Any] = {"contact_kappa": contact_kappa, "points": points, "name": "cap"}
    zone: ContactBoundary | ContactInterface
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
    for part in allgathered(comm, local):
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
        ``force_ref`` = rho c v0 A; what a user reads at the end face
        (:meth:`_EndFaceWatch.summary`: ``face_tracking``, ``face_speed``,
        ``kinetic_error``).
    """
    L, a, v0 = BAR_IMPACT["length"], BAR_IMPACT["section"], BAR_IMPACT["v0"]
    material = Material(1.0, 0.0, 1.0)
    parts, interface = _impact_bar(n, split, material)
    zone = _end_contact(parts[0], contact, contact_kappa)
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
    watch = _EndFaceWatch(problem, parts, n)
    g = _run_tracking_penetration(problem, zone, round(end_time / dt), comm, watch)
    duration = _contact_duration(g, dt)
    momentum, total_mass = _axial_momentum_and_mass(problem, parts, comm)
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
        "factorisations": max_over_ranks(comm, problem.work.count("sparse_factor", "FULL")),
        "steps": len(g),
        "history": [record["changes"] for record in problem.history],
        "substitutions": sum(work.get(part.block, {}).get("substitutions", 0) for part in parts),
        "whole_iterates": problem.iteration.whole_iterates,
        # the face against the bar from half a wave transit L / 2c after the release on
        **watch.summary(v0, energy0, settle=round(0.5 * L / dt)),
    }


def _impact_bar(
    n: int, split: bool, material: Material
) -> tuple[list[Subdomain], Interface | None]:
    """The bar of :func:`bar_impact` flying at -v0 along x: whole, or halves and their tie."""
    L, a, v0 = BAR_IMPACT["length"], BAR_IMPACT["section"], BAR_IMPACT["v0"]
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
    return parts, interface


def _end_contact(
    bar: Subdomain, contact: str, contact_kappa: float | None
) -> ContactBoundary | ContactInterface:
    """Contact of the bar's end x = 0 with the rigid wall there: on its boundary or a 1x1 mesh."""
    wall = Plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    end = locator(0, 0.0)
    if contact == "boundary":
        return ContactBoundary(bar, end, wall, contact_kappa=contact_kappa, name="end")
    return ContactInterface.from_boundary(
        bar, end, wall, resolution=(1, 1), contact_kappa=contact_kappa, name="end"
    )


class _EndFaceWatch:
    """What a user reads of the bar at its end face after every step (every rank).

    The face's and the next node layer's mean axial velocity, and the kinetic energy a user
    integrates from ``Subdomain.velocity`` with the material's true density (the mass matrix
    of the problem's kind, the walls' mass where it belongs), beside the package's own.
    """

    def __init__(self, problem: TransientProblem, parts: list[Subdomain], n: int):
        self.problem, self.parts = problem, parts
        self.rows: list[tuple[float, ...]] = []
        self.mass = {}
        for part in parts:
            if part.block in problem.model.mass:  # owned here
                degree = part.V.element.basix_element.degree
                consistent = forms.assemble_mass(part)
                self.mass[part.block] = forms.mass_of_kind(consistent, degree, problem.mass_kind)
        bar = parts[0]
        x = bar.V.tabulate_dof_coordinates()[: bar.num_dofs // 3, 0]
        h = BAR_IMPACT["length"] / n
        self.face = 3 * np.flatnonzero(np.isclose(x, 0.0))  # axial dofs of the end face
        self.next = 3 * np.flatnonzero(np.isclose(x, h))  # ... and of the layer behind it

    def read(self, record: dict) -> None:
        comm = self.problem.comm
        kinetic, momentum, mass = 0.0, 0.0, 0.0
        for part in self.parts:
            if part.block in self.mass:
                v = part.velocity.x.array[: part.num_dofs]
                M = self.mass[part.block]
                kinetic += 0.5 * float(v @ (M @ v))
                axial = np.zeros(part.num_dofs)
                axial[0::3] = 1.0
                momentum += float(axial @ (M @ v))
                mass += float(axial @ (M @ axial))
        local = None
        bar = self.parts[0]
        if bar.block in self.mass:
            v = bar.velocity.x.array
            local = (float(v[self.face].mean()), float(v[self.next].mean()))
        face, behind = next(p for p in allgathered(comm, local) if p is not None)
        pressing = float(np.linalg.norm(record["force"]["end"])) > 0
        user, momentum, mass = sum_over_ranks(comm, np.array([kinetic, momentum, mass]))
        kept = (face, behind, momentum / mass, user, record["energy"]["kinetic"], pressing)
        self.rows.append(kept)

    def summary(self, v0: float, energy0: float, settle: int) -> dict:
        """The face against the layer it follows once released, and the two kinetic energies.

        ``face_tracking``: from the second step after the last contact on, the largest
        ``|v_face - (v_next,n + v_next,n+1) / 2| / v0`` (the face moves with the layer
        behind it: its velocity is the step's mean, the layer's is the trapezoidal one);
        ``face_speed``: the largest ``|v_face| / v0`` of the run; ``face_against_bar``: from
        ``settle`` steps after the last contact on (the end rings while the release wave
        leaves it), the largest ``|v_face - v_bar| / v0`` (``v_bar``: the bar's momentum
        over its mass); ``behind_against_bar``: the same of the node layer behind the face
        (with mass: the mesh's own ringing); ``kinetic_error``: the largest ``|KE_user -
        KE_package| / E0``.
        """
        rows = np.array(self.rows)
        face, behind, bar, user, package, pressing = rows.T
        last = int(np.flatnonzero(pressing)[-1]) if pressing.any() else -1
        after = np.arange(max(last + 2, 1), len(rows))
        mean_behind = 0.5 * (behind[after] + behind[after - 1])
        return {
            "face_tracking": float(np.max(np.abs(face[after] - mean_behind), initial=0.0) / v0),
            "face_speed": float(np.max(np.abs(face)) / v0),
            "face_against_bar": float(
                np.max(np.abs(face - bar)[last + settle :], initial=0.0) / v0
            ),
            "behind_against_bar": float(
                np.max(np.abs(behind - bar)[last + settle :], initial=0.0) / v0
            ),
            "kinetic_error": float(np.max(np.abs(user - package)) / energy0),
        }


def _run_tracking_penetration(
    problem: TransientProblem,
    zone: ContactBoundary | ContactInterface,
    steps: int,
    comm: MPI.Comm,
    watch: _EndFaceWatch,
) -> np.ndarray:
    """Run ``steps`` steps; the end's mean signed penetration after each, on every rank.

    Positive in contact, negative once the bar has left the wall. ``watch`` reads the face.
    """
    penetration = []

    def after_step(record):
        local = None
        if problem.zones:  # the contact's owner
            op = problem.zones[0].operator
            local = float(op.penetration(zone.w.x.array[: op.num_dofs]).mean())
        penetration.append(next(p for p in allgathered(comm, local) if p is not None))
        watch.read(record)

    problem.run(steps, callback=after_step, progress=False, summary=False)
    return np.array(penetration)


def _contact_duration(g: np.ndarray, dt: float) -> float:
    """When the penetration ``g`` (one per step) first turns negative, linearly interpolated."""
    times = dt * np.arange(1, len(g) + 1)
    k = int(np.argmax(g < 0))  # first step apart
    return times[k - 1] + dt * g[k - 1] / (g[k - 1] - g[k])


def _axial_momentum_and_mass(
    problem: TransientProblem, parts: list[Subdomain], comm: MPI.Comm
) -> tuple[float, float]:
    """The bar's momentum along x and its mass, from the mass matrices (summed over ranks)."""
    momentum, total_mass = 0.0, 0.0
    for part in parts:
        M = problem.model.mass.get(part.block)
        if M is not None:  # owned here
            ones = np.zeros(part.num_dofs)
            ones[0::3] = 1.0
            momentum += float(ones @ (M @ part.velocity.x.array))
            total_mass += float(ones @ (M @ ones))
    return sum_over_ranks(comm, momentum), sum_over_ranks(comm, total_mass)


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
