"""The sliding block: Coulomb friction against its closed form (``dd-contact verify``).

A block on a rigid plane z = 0 is pressed by a uniform pressure q on its top (the normal
load N = q A), held there tangentially (x and y fixed); the plane then moves along x in
load steps, dragging the block's bottom with it (the tangential load T, the friction force
of the plane on the block). Below mu N every point sticks: the block's bottom follows the
plane but for the tangential penalty and the block's shear compliance, and nothing slips.
Once the whole face slides, T = mu N exactly. Scenes: one block with a contact interface
(w-u), two blocks stacked with an interface (v-w-u, w-v-u), the block's own boundary
(FULL); FULL solves the others too.
"""

from __future__ import annotations

import itertools

from mpi4py import MPI

import numpy as np

from dd_contact import meshes
from dd_contact.friction import SLIP
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.models import Record, locator, record
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactBoundary, ContactInterface, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "DRAG",
    "SLIDING_SCENES",
    "case_sliding_block",
    "sliding_balance",
    "sliding_block",
    "sliding_scene",
    "watch_balance",
]

#: Scene kinds of :func:`sliding_scene` and the algorithms each is solved with.
SLIDING_SCENES = {
    "single": ("FULL", "w-u"),
    "interface": ("FULL", "v-w-u", "w-v-u"),
    "boundary": ("FULL",),
}

#: The block's material, pressure and plane travel per load step and unit of block height
#: (nu = 0: pressing does not spread the block, so it starts with no tangential traction).
MATERIAL = Material(1000.0, 0.0, 1.0)
PRESSURE = 1.0
TRAVEL = 8e-5


def sliding_scene(kind: str, mu: float, comm: MPI.Comm = MPI.COMM_WORLD) -> Scene:
    """The block [0,1]^2 x [0,0.25] (``"interface"``: and [0,1]^2 x [0.25,0.5] on it).

    The plane moves by ``TRAVEL`` times the block's height along x per unit of time: solve
    at t = 1, 2, ...
    """
    top = 0.5 if kind == "interface" else 0.25
    travel = TRAVEL * top
    cuts = [0.0, 0.25, 0.5][: 3 if kind == "interface" else 2]
    parts = []
    for i, (z0, z1) in enumerate(itertools.pairwise(cuts)):
        mesh = meshes.box(MPI.COMM_SELF, [0, 0, z0], [1, 1, z1], [4, 4, 2])
        parts.append(Subdomain(mesh, MATERIAL, f"B{i}"))
    parts[-1].fix(locator(2, top), components=[0, 1])
    parts[-1].add_traction(locator(2, top), [0.0, 0.0, -PRESSURE])
    plane = Plane([0, 0, 0], [0, 0, 1], motion=lambda t: (travel * t, 0.0, 0.0))
    interface = None
    if kind == "interface":
        surface = meshes.surface_from_boundary(parts[0].mesh, locator(2, 0.25), comm=MPI.COMM_SELF)
        interface = Interface(surface, parts)
    contact: ContactBoundary | ContactInterface
    if kind == "boundary":
        contact = ContactBoundary(parts[0], locator(2, 0.0), plane, friction=mu, name="base")
    else:
        contact = ContactInterface.from_boundary(
            parts[0], locator(2, 0.0), plane, friction=mu, name="base"
        )
    return Scene(comm, parts, interface, contacts=[contact])


def sliding_block(
    kind: str, algorithm: str, mu: float, steps: int, comm: MPI.Comm = MPI.COMM_WORLD
) -> dict:
    """Load steps of the plane's travel; per step N, T, the slip and the points slipping.

    Returns ``N``, ``T`` (per step, the plane's force on the block: normal, along x),
    ``slip`` (the largest accumulated slip of a point), ``slipping`` (points slipping),
    ``changes`` (contact state changes over the run) and ``u`` (every subdomain
    displacement after the last step).
    """
    problem = StaticProblem(sliding_scene(kind, mu, comm), algorithm=algorithm)
    out: dict = {"N": [], "T": [], "slip": [], "slipping": []}
    zone = problem.analysis.zones[0] if problem.analysis.zones else None
    for step in range(1, steps + 1):
        problem.solve(float(step))
        force = problem.contact_forces()["base"]
        out["N"].append(float(force[2]))
        out["T"].append(float(force[0]))
        friction = None if zone is None else zone.operator.friction
        slip = 0.0 if friction is None else float(np.abs(friction.slip).max())
        out["slip"].append(slip)
        out["slipping"].append(0 if friction is None else int(np.sum(friction.state == 2)))
    out["changes"] = problem.changes["gamma"]
    out["u"] = np.concatenate([s.u.x.array for s in problem.scene.subdomains])
    problem.close()
    return out


#: The dragging plane's travel along x: ``DRAG t^3`` [m]. Its acceleration 6 DRAG t grows
#: through mu N / m = 1.2 m/s^2 (mu = 0.3, the block's 0.25 kg under 1 N) at 15 ms: the
#: block, landed at 6 ms, sticks, then slips (from 25 ms; all its points from 27 ms).
DRAG = 13.0


def sliding_balance(
    kind: str,
    algorithm: str,
    mu: float,
    steps: int,
    comm: MPI.Comm = MPI.COMM_WORLD,
    drag: float = 0.0,
) -> list[dict]:
    """The block thrown along a fixed plane (0.1 m/s) under its top pressure, with inertia.

    ``drag``: instead, the block starts at rest and the plane drags it, moving by
    ``drag t^3`` along x (the obstacle's work counted).

    Per step (dt = 1 ms): ``changes``, ``dissipated``, ``obstacle`` (the obstacle's work),
    ``slipping`` (points slipping), and ``residual``, the energy now less the energy
    before, the loads' and the obstacle's work and plus the dissipation
    (``EnergyBalance``'s books).
    """
    mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, 0.25], [4, 4, 2])
    block = Subdomain(mesh, MATERIAL, "B0")
    block.add_traction(locator(2, 0.25), [0.0, 0.0, -PRESSURE])
    speed = 0.0 if drag else 0.1
    block.velocity.interpolate(lambda x: np.vstack([speed + 0 * x[0], 0 * x[0], 0 * x[0]]))
    travel = (lambda t: (drag * t**3, 0.0, 0.0)) if drag else None
    plane = Plane([0, 0, 0], [0, 0, 1], motion=travel)
    contact: ContactBoundary | ContactInterface
    if kind == "boundary":
        contact = ContactBoundary(block, locator(2, 0.0), plane, friction=mu, name="base")
    else:
        contact = ContactInterface.from_boundary(
            block, locator(2, 0.0), plane, friction=mu, name="base"
        )
    problem = TransientProblem(Scene(comm, [block], contacts=[contact]), 1e-3, algorithm=algorithm)
    out = watch_balance(problem, bool(drag))
    problem.run(steps, progress=False, summary=False)
    problem.close()
    return out


def watch_balance(problem: TransientProblem, moving: bool) -> list[dict]:
    """Each step's books as ``problem``'s energy balance checks them, filled as it runs.

    ``moving``: an obstacle moves (its work counted). Per step: ``changes``,
    ``dissipated``, ``obstacle`` (the obstacle's work), ``slipping`` (points slipping),
    ``total`` (the energy) and ``residual``, the energy now less the energy before, the
    loads' and the obstacle's work and plus the dissipation.
    """
    balance, out = problem.energy_balance, []
    zones = problem.analysis.zones
    friction = zones[0].operator.friction if zones else None
    check = balance.check

    def watched(record, work, obstacle_work=lambda: 0.0):
        loads, moved = work()
        obstacle = obstacle_work() if moving else 0.0  # this rank's
        if balance.before is not None:
            energy = record["energy"]
            change = energy["total"] - balance.before - loads - obstacle
            dissipated = energy.get("dissipated", 0.0)
            out.append(
                {
                    "changes": record["changes"],
                    "dissipated": dissipated,
                    "obstacle": obstacle,
                    "slipping": int(np.sum(friction.state == SLIP)) if friction else 0,
                    "residual": change + dissipated,
                    "total": energy["total"],
                }
            )
        check(record, lambda: (loads, moved), lambda: obstacle)

    balance.check = watched  # type: ignore[method-assign]
    return out


def case_sliding_block() -> list[Record]:
    """T = mu N once sliding, nothing slips below mu N / 2, mu = 0 frictionless (each one)."""
    mu, steps, records = 0.3, 20, []
    for kind, algorithms in SLIDING_SCENES.items():
        for algorithm in algorithms:
            run = sliding_block(kind, algorithm, mu, steps)
            name = f"{kind}, {algorithm}"
            N, T = np.abs(run["N"]), np.abs(run["T"])
            ratio = T[-1] / (mu * N[-1])
            records.append(record("sliding-block", f"T / (mu N) sliding, {name}", ratio, 1.0, 1e-6))
            below = T < 0.5 * mu * N
            slip = float(np.max(np.array(run["slip"])[below], initial=0.0))
            # value: 1 + the largest slip while T < mu N / 2; reference: no slip at all
            quantity = f"1 + slip [m] below mu N / 2, {name}"
            records.append(record("sliding-block", quantity, 1.0 + slip, 1.0, 0.0))
            plain = sliding_block(kind, algorithm, 0.0, 2)["u"]
            tiny = sliding_block(kind, algorithm, 1e-10, 2)["u"]
            # value: 1 + |u(mu = 1e-10) - u(mu = 0)| / |u|: the friction path tends to none
            error = float(np.linalg.norm(tiny - plain) / np.linalg.norm(plain))
            quantity = f"1 + |u(mu=1e-10) - u(mu=0)| / |u|, {name}"
            records.append(record("sliding-block", quantity, 1.0 + error, 1.0, 1e-8))
    return records
