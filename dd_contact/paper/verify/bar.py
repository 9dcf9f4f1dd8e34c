"""The bar impact on a rigid wall (1-D wave theory), and what a user reads at its end face."""

from __future__ import annotations

import itertools

from mpi4py import MPI

import numpy as np

from dd_contact import forms, meshes
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.models import locator
from dd_contact.parallel import allgathered, max_over_ranks, sum_over_ranks
from dd_contact.problem import TransientProblem
from dd_contact.scene import ContactBoundary, ContactInterface, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = ["BAR_IMPACT", "bar_impact"]


#: An elastic bar (E = rho = 1, nu = 0 so it is exactly one-dimensional, c = 1) of length 1
#: and section 0.1 x 0.1 hits a rigid wall at x = 0 with speed v0.
BAR_IMPACT = {"length": 1.0, "section": 0.1, "v0": 0.01}


def bar_impact(
    n: int = 40,
    cfl: float | None = 1.0,
    contact_kappa: float | None = None,
    contact: str = "boundary",
    end_time: float = 3.0,
    split: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    algorithm: str = "FULL",
    energy_safe_contact: bool = True,
    mass: str | None = None,
    scheme: str = "trapezoidal",
    rho_infinity: float | None = None,
    kappa: float | None = None,
    degree: int = 1,
    interface_resolution: tuple[int, int] = (1, 1),
    across: int = 1,
    accuracy: str = "balanced",
    watch: bool = True,
) -> dict:
    """Bar impact on a rigid wall: contact duration, rebound velocity, energy and force.

    The exact answer (1-D wave theory): contact lasts 2L/c at the force rho c v0 A, the
    bar leaves with velocity -v0 and no strain, so kinetic energy is restored.

    Args:
        n: Elements along the bar.
        cfl: Time step in units of h / c (1: more accurate than 0.5, docs/tradeoff.md;
            ``None``: the ``accuracy`` preset's).
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
        accuracy: See :class:`dd_contact.TransientProblem` (it sets dt with ``cfl=None``).
        kappa: Tie penalty of the interface (with ``split``).
        degree: Lagrange degree of the bar (2 needs ``contact="interface"``).
        interface_resolution: Interface cells across the section (with ``split``).
        across: Elements across the section, each way (nu = 0: the answer stays 1-D).
        watch: Read the end face and the kinetic energy a user sees after every step (the
            ``face_*`` and ``kinetic_error`` entries; False: 11 % less CPU time at n = 40,
            benchmarks/tradeoff_fast.py).

    Returns:
        duration (read off the force), parting (the gap's opening), rebound, energy ratio,
        changes, factorisations, steps, dt, the contact force of every step and its peak
        and plateau (:func:`_forces`); what a user reads at the end face
        (:meth:`_EndFaceWatch.summary`).
    """
    L = BAR_IMPACT["length"]
    parts, interface = _impact_bar(
        n, split, Material(1.0, 0.0, 1.0), kappa, degree, interface_resolution, across
    )
    zone = _end_contact(parts[0], contact, contact_kappa)
    problem = TransientProblem(
        Scene(comm, parts, interface, contacts=[zone]),
        None if cfl is None else cfl * L / n,
        algorithm=algorithm,
        energy_safe_contact=energy_safe_contact,
        mass=mass,
        scheme=scheme,
        rho_infinity=rho_infinity,
        accuracy=accuracy,
    )
    face = _EndFaceWatch(problem, parts, n) if watch else None
    steps = round(end_time / problem.dt)
    g = _run_tracking_penetration(problem, zone, steps, comm, face)
    return _impact_summary(problem, parts, g, face)


def _impact_summary(
    problem: TransientProblem,
    parts: list[Subdomain],
    g: np.ndarray,
    watch: _EndFaceWatch | None,
) -> dict:
    """Collective: what :func:`bar_impact` returns, from its run's problem and gaps ``g``."""
    L, a, v0 = BAR_IMPACT["length"], BAR_IMPACT["section"], BAR_IMPACT["v0"]
    material, comm, dt = parts[0].material, problem.comm, problem.dt
    momentum, total_mass = _axial_momentum_and_mass(problem, parts, comm)
    work = problem.work_summary()  # collective: every rank's work, merged
    energy0 = 0.5 * total_mass * v0**2
    forces = _forces(problem, material.rho * np.sqrt(material.E / material.rho) * v0 * a * a)
    return {
        **forces,
        "duration": float(_contact_duration(forces["forces"], forces["plateau_force"], dt)),
        "parting": float(_parting(g, dt)),
        "duration_ref": 2.0 * L,
        "rebound": momentum / total_mass / v0,
        "energy_ratio": problem.energy()["total"] / energy0,
        "changes": problem.changes["gamma"],
        "factorisations": max_over_ranks(comm, problem.work.count("sparse_factor", "FULL")),
        "steps": len(g),
        "dt": dt,
        "history": [record["changes"] for record in problem.history],
        "substitutions": sum(work.get(part.block, {}).get("substitutions", 0) for part in parts),
        "whole_iterates": problem.iteration.whole_iterates,
        # from L / 2c after the release
        **(watch.summary(v0, energy0, settle=round(0.5 * L / dt)) if watch else {}),
    }


def _forces(problem: TransientProblem, reference: float) -> dict:
    """The end's contact force of every step, its largest and its median while pressing."""
    forces = np.array([np.linalg.norm(r["force"]["end"]) for r in problem.history])
    pressing = forces[forces > 0]
    return {
        "forces": forces.tolist(),
        "peak_force": float(forces.max()),
        "plateau_force": float(np.median(pressing)) if len(pressing) else 0.0,
        "force_ref": reference,
    }


def _impact_bar(
    n: int,
    split: bool,
    material: Material,
    kappa: float | None = None,
    degree: int = 1,
    resolution: tuple[int, int] = (1, 1),
    across: int = 1,
) -> tuple[list[Subdomain], Interface | None]:
    """The bar of :func:`bar_impact` flying at -v0 along x: whole, or halves and their tie."""
    L, a, v0 = BAR_IMPACT["length"], BAR_IMPACT["section"], BAR_IMPACT["v0"]
    cuts = [0.0, L / 2, L] if split else [0.0, L]
    parts = [
        Subdomain(
            meshes.box(
                MPI.COMM_SELF, [x0, 0, 0], [x1, a, a], [round(n * (x1 - x0) / L), across, across]
            ),
            material,
            f"bar{k}" if split else "bar",
            degree=degree,
        )
        for k, (x0, x1) in enumerate(itertools.pairwise(cuts))
    ]
    for part in parts:
        part.velocity.interpolate(
            lambda x: np.vstack([np.full(x.shape[1], -v0), 0 * x[0], 0 * x[0]])
        )
    bar = parts[0]
    interface = (
        Interface.from_boundary(bar, locator(0, L / 2), parts, resolution=resolution, kappa=kappa)
        if split
        else None
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
    watch: _EndFaceWatch | None,
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
        if watch is not None:
            watch.read(record)

    problem.run(steps, callback=after_step, progress=False, summary=False)
    return np.array(penetration)


def _contact_duration(forces: list[float], plateau: float, dt: float) -> float:
    """When the contact force last falls through half its plateau, interpolated between steps.

    The bar touches the wall at t = 0. The mesh spreads the release over several elements
    (more steps the finer it is); half the plateau is the middle of that ramp, where the
    exact force jumps (docs/tradeoff.md, "The bar's contact duration"). The ramp's end, when
    the face parts (:func:`_parting`), lags 2 L / c by one to two steps at CFL 1.
    """
    f = np.asarray(forces)
    k = int(np.flatnonzero(f >= 0.5 * plateau)[-1])
    if k + 1 == len(f):  # still pressing at the end
        return dt * len(f)
    return dt * (k + 1 + (f[k] - 0.5 * plateau) / (f[k] - f[k + 1]))


def _parting(g: np.ndarray, dt: float) -> float:
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
