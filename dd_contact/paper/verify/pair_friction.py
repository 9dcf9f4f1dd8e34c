"""The sliding pair: Coulomb friction between two bodies against its closed form.

Block B [0,1]^2 x [0.25,0.5] (3x3x2 hexahedra) is pressed by a uniform pressure q on its
top (N = q A) on block A [0,1]^2 x [0,0.25] (4x4x2 hexahedra: the surfaces do not match),
whose base is held. B's top is held in y and moved along x in load steps: the tangential
load T is the friction force of A on B. Below mu N the contact sticks but at its corners;
once the whole face slides, T = mu N exactly. The pair's side a is B's bottom (the coarser
side), b is A's top. Scenes: ``"single"`` (FULL, w-u) and ``"interface"``, A cut in two
subdomains tied through an interface (FULL, v-w-u, w-v-u).
"""

from __future__ import annotations

import itertools

from mpi4py import MPI

import numpy as np

from dd_contact import meshes
from dd_contact.paper.verify.friction import MATERIAL, PRESSURE, watch_balance
from dd_contact.paper.verify.models import Record, locator, record
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactInterface, ContactPair, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "PAIR_SCENES",
    "PUSH",
    "case_sliding_pair",
    "pair_balance",
    "pair_scene",
    "pressed_pair",
    "sliding_pair",
]

#: Scene kinds of :func:`pair_scene` and the algorithms each is solved with.
PAIR_SCENES = {"single": ("FULL", "w-u"), "interface": ("FULL", "v-w-u", "w-v-u")}

#: Height of each block; B's top travels PUSH along x per unit of time (the centre of the
#: contact sticks longer than its edges: A's top shears with it, unlike a rigid plane).
HEIGHT, PUSH = 0.25, 5e-5


def _lower(kind: str) -> tuple[list[Subdomain], Interface | None]:
    """Block A, its base held: one subdomain, or two tied through an interface at mid-height."""
    if kind == "single":
        mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 1, HEIGHT], [4, 4, 2])
        return [Subdomain(mesh, MATERIAL, "A").fix(locator(2, 0.0))], None
    cuts = [0.0, HEIGHT / 2, HEIGHT]
    parts = [
        Subdomain(meshes.box(MPI.COMM_SELF, [0, 0, z0], [1, 1, z1], [4, 4, 1]), MATERIAL, f"A{i}")
        for i, (z0, z1) in enumerate(itertools.pairwise(cuts))
    ]
    parts[0].fix(locator(2, 0.0))
    where = locator(2, HEIGHT / 2)
    surface = meshes.surface_from_boundary(parts[0].mesh, where, comm=MPI.COMM_SELF)
    return parts, Interface(surface, parts)


def pair_scene(
    kind: str, mu: float, comm: MPI.Comm = MPI.COMM_WORLD, speed: float | None = None, **options
) -> Scene:
    """B pressed on A in a ContactPair with friction ``mu`` (``options``: the pair's).

    B's top moves by ``PUSH`` along x per unit of time: solve at t = 1, 2, ... ``speed``:
    instead, B's top is free and B starts moving along x at ``speed`` (for a dynamic run).
    """
    lower, interface = _lower(kind)
    top = 2 * HEIGHT
    mesh = meshes.box(MPI.COMM_SELF, [0, 0, HEIGHT], [1, 1, top], [3, 3, 2])
    upper = Subdomain(mesh, MATERIAL, "B")
    if speed is None:
        upper.fix(locator(2, top), components=[0, 1], value=lambda x, t: (PUSH * t, 0.0, 0.0))
    else:
        upper.velocity.interpolate(lambda x: np.vstack([speed + 0 * x[0], 0 * x[0], 0 * x[0]]))
    upper.add_traction(locator(2, top), [0.0, 0.0, -PRESSURE])
    a = ContactInterface.from_boundary(upper, locator(2, HEIGHT), None, name="bottom")
    b = ContactInterface.from_boundary(lower[-1], locator(2, HEIGHT), None, name="top")
    pair = ContactPair(a, b, friction=mu, name="base", **options)
    return Scene(comm, [*lower, upper], interface, contacts=[pair])


#: The pressed pair's gap and the tilt of its press (the contact closes from x = 1).
GAP = 1e-4


def pressed_pair(
    kind: str,
    mu: float,
    cells: int = 8,
    steps: int = 10,
    push: float = 0.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """B a gap above A, its top pressed down with a tilt: the contact closes row by row.

    A has ``cells`` x ``cells`` x 4 hexahedra (``"interface"``: two subdomains of 2 layers),
    B one cell fewer across (non-matching); nu = 0.3, so the points slide along each other
    as they close. B's top reaches A at x = 1 at t = steps / 2 and about x = 1/3 at
    t = steps, and moves ``push`` along x per unit of time. Solve at t = 1, ..., steps.
    """
    material = Material(MATERIAL.E, 0.3, MATERIAL.rho)
    cuts = [0.0, HEIGHT] if kind == "single" else [0.0, HEIGHT / 2, HEIGHT]
    layers = 4 // (len(cuts) - 1)
    lower = [
        Subdomain(
            meshes.box(MPI.COMM_SELF, [0, 0, z0], [1, 1, z1], [cells, cells, layers]),
            material,
            f"A{i}",
        )
        for i, (z0, z1) in enumerate(itertools.pairwise(cuts))
    ]
    lower[0].fix(locator(2, 0.0))
    interface = None
    if kind == "interface":
        where = locator(2, HEIGHT / 2)
        surface = meshes.surface_from_boundary(lower[0].mesh, where, comm=MPI.COMM_SELF)
        interface = Interface(surface, lower)
    bottom, top = HEIGHT + GAP, 2 * HEIGHT + GAP
    mesh = meshes.box(MPI.COMM_SELF, [0, 0, bottom], [1, 1, top], [cells - 1, cells - 1, 4])
    upper = Subdomain(mesh, material, "B")

    def pressed(x, t):
        down = -2.0 * GAP * t / steps * (0.25 + 0.75 * x[0])
        return np.stack([push * t + 0 * x[0], 0 * x[0], down])

    upper.fix(locator(2, top), value=pressed)
    a = ContactInterface.from_boundary(upper, locator(2, bottom), None, name="bottom")
    b = ContactInterface.from_boundary(lower[-1], locator(2, HEIGHT), None, name="top")
    pair = ContactPair(a, b, friction=mu, name="base")
    return Scene(comm, [*lower, upper], interface, contacts=[pair])


def sliding_pair(
    kind: str,
    algorithm: str,
    mu: float,
    steps: int,
    comm: MPI.Comm = MPI.COMM_WORLD,
    **options,
) -> dict:
    """Load steps of B's travel; per step N, T, the slip and the points slipping.

    Returns ``N``, ``T`` (per step, A's force on B: normal, along x), ``slip`` (the largest
    accumulated slip of a point), ``slipping`` (points slipping), ``dissipated`` (per step),
    ``changes`` (contact state changes over the run), ``u`` (every subdomain displacement
    after the last step) and ``w`` (the contact surfaces', on the pair's rank).
    """
    scene = pair_scene(kind, mu, comm, **options)
    problem = StaticProblem(scene, algorithm=algorithm)
    out: dict = {"N": [], "T": [], "slip": [], "slipping": [], "dissipated": []}
    zone = problem.analysis.zones[0] if problem.analysis.zones else None
    friction = None if zone is None else zone.operator.friction
    for step in range(1, steps + 1):
        problem.solve(float(step))
        force = problem.contact_forces()["base"]
        out["N"].append(float(force[2]))
        out["T"].append(float(force[0]))
        slip = 0.0 if friction is None else float(np.abs(friction.slip).max())
        out["slip"].append(slip)
        out["slipping"].append(0 if friction is None else int(np.sum(friction.state == 2)))
        out["dissipated"].append(0.0 if friction is None else friction.dissipation)
    out["changes"] = problem.changes["gamma"]
    out["u"] = np.concatenate([s.u.x.array for s in scene.subdomains])
    out["w"] = np.concatenate([c.w.x.array for c in scene.contacts])  # its owner's
    problem.close()
    return out


def pair_balance(
    kind: str, algorithm: str, mu: float, steps: int, comm: MPI.Comm = MPI.COMM_WORLD, **options
) -> list[dict]:
    """B thrown along A (0.1 m/s) under its top pressure, with inertia (dt = 1 ms).

    Per step the books of :func:`~dd_contact.paper.verify.friction.watch_balance`.
    """
    scene = pair_scene(kind, mu, comm, speed=0.1, **options)
    problem = TransientProblem(scene, 1e-3, algorithm=algorithm)
    out = watch_balance(problem, False)
    problem.run(steps, progress=False, summary=False)
    problem.close()
    return out


def _run_records(kind: str, algorithm: str, run: dict, full: dict, mu: float) -> list[Record]:
    """T = mu N sliding, no slip below mu N / 2, the steady dissipation, against FULL."""
    name, case = f"{kind}, {algorithm}", "sliding-pair"
    N, T = np.abs(run["N"]), np.abs(run["T"])
    out = [record(case, f"T / (mu N) sliding, {name}", T[-1] / (mu * N[-1]), 1.0, 1e-6)]
    slip = float(np.max(np.array(run["slip"])[T < 0.5 * mu * N], initial=0.0))
    # value: 1 + the largest slip while T < mu N / 2; reference: no slip at all
    out.append(record(case, f"1 + slip [m] below mu N / 2, {name}", 1.0 + slip, 1.0, 0.0))
    # sliding steadily, each step dissipates mu N times B's push
    steady = run["dissipated"][-1] / (mu * N[-1] * PUSH)
    out.append(record(case, f"dissipation / (mu N push), {name}", steady, 1.0, 1e-6))
    if run is not full:
        error = float(np.linalg.norm(run["u"] - full["u"]) / np.linalg.norm(full["u"]))
        out.append(record(case, f"1 + |u - u_FULL| / |u|, {name}", 1.0 + error, 1.0, 1e-8))
    return out


def case_sliding_pair() -> list[Record]:
    """The sliding pair in every algorithm that fits; mu -> 0; the books with inertia."""
    mu, steps, records = 0.3, 20, []
    for kind, algorithms in PAIR_SCENES.items():
        runs = {a: sliding_pair(kind, a, mu, steps) for a in algorithms}
        for algorithm, run in runs.items():
            records += _run_records(kind, algorithm, run, runs["FULL"], mu)
    plain, tiny = (sliding_pair("single", "w-u", m, 2)["u"] for m in (0.0, 1e-10))
    error = float(np.linalg.norm(tiny - plain) / np.linalg.norm(plain))
    quantity = "1 + |u(mu=1e-10) - u(mu=0)| / |u|, single, w-u"
    records.append(record("sliding-pair", quantity, 1.0 + error, 1.0, 1e-8))
    books = pair_balance("single", "w-u", mu, 30)
    # value: 1 + the most negative dissipation of a step, relative to the largest (none)
    least = min(s["dissipated"] for s in books) / max(s["dissipated"] for s in books)
    quantity = "1 + max(0, -min dissipation) / max, w-u"
    records.append(record("sliding-pair", quantity, 1.0 + max(0.0, -least), 1.0, 0.0))
    settled = [s for s in books if s["changes"] == 0]
    worst = max(abs(s["residual"]) / s["total"] for s in settled)
    quantity = "1 + |energy balance| / energy, steps without a change, w-u"
    records.append(record("sliding-pair", quantity, 1.0 + worst, 1.0, 1e-8))
    return records
