"""Cattaneo-Mindlin: a Hertz contact under a tangential load (``dd-contact verify``).

The elastic hemisphere of the Hertz case (:data:`~dd_contact.paper.verify.models.HERTZ`),
as a half model (symmetry plane y = 0, which contains the load's direction x), is pressed
on a rigid plane by a prescribed approach of its flat top face (the normal load P, what the
contact carries); its top then moves along x in load steps (the tangential load Q, the
friction force of the plane). Closed forms for one elastic body (E, nu, G = E / (2 (1 +
nu))) on a rigid plane (K. L. Johnson, *Contact Mechanics*, 1985, sec. 7.2, eqs. 7.36-7.42
with the second body rigid; Mindlin 1949), with a from Hertz for the measured P::

    stuck radius         c = a (1 - Q / (mu P))^(1/3)
    tangential compliance delta = 3 mu P (2 - nu) / (16 G a) [1 - (1 - Q / (mu P))^(2/3)]

Both assume that pressing makes no tangential traction (the bodies elastically alike,
Dundurs' beta = 0); an elastic ball on a rigid plane has beta = 0.29 at nu = 0.3 and
pressed with friction keeps radial tractions (Spence's problem) that shrink the stuck disc
by 25 % here. So the ball is pressed without friction (mu = 0 for the first load step, the
history then starts at rest), as the closed form assumes.

delta is the displacement of distant points relative to the plane; the top of a hemisphere
is not distant: its displacement is delta plus the hemisphere's own shear compliance (a
third of delta here), linear in Q. That part is measured once with the contact bonded (mu =
``BONDED``: every point sticks) and taken out: ``C_body = D_bonded / Q_bonded - (2 - nu) /
(8 G a)``, the bonded top displacement per unit load less Mindlin's no-slip compliance; the
slip's share (what friction adds) is not calibrated.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.friction import OPEN, STICK
from dd_contact.obstacles import Plane
from dd_contact.paper.verify.models import HERTZ, Record, record
from dd_contact.problem import StaticProblem
from dd_contact.scene import ContactBoundary, ContactInterface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = ["BONDED", "CM_LEVELS", "CM_MESH", "PROBE", "case_cattaneo_mindlin", "cattaneo_mindlin"]

#: The Coulomb coefficient of the bonded run: every point sticks under the loads used.
BONDED = 1e3

#: The bonded run's travel of the top over R: small enough that no point at the edge of
#: the contact opens (at 1e-3 two did, h = 0.02: the compliance 4 % off).
PROBE = 1e-5

#: The tangential loads Q / (mu P) the top's travel aims at, one load step each.
CM_LEVELS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)

#: The mesh size at the pole of ``dd-contact verify --case cattaneo-mindlin``.
CM_MESH = 0.015

CASE = "cattaneo-mindlin"


def _scene(h: float, mu: float, contact: str, travel: list[float], comm: MPI.Comm) -> Scene:
    R, E, nu = HERTZ["radius"], HERTZ["E"], HERTZ["nu"]
    approach = HERTZ["approach"]
    mesh, tags = meshes.hemisphere(
        MPI.COMM_SELF, R, 0.18 * R, h, HERTZ["h_far"] * R, quarter="half", grading=0.2
    )
    ball = Subdomain(mesh, Material(E, nu), "ball")
    top = (tags, meshes.HEMISPHERE_TOP)
    ball.fix(top, components=[0, 2], value=lambda x, t: (travel[0], 0.0, -approach))
    ball.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[1])
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    cap = ball.locate_facets((tags, meshes.HEMISPHERE_CURVED))
    mid = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap)].mean(axis=1)
    near = cap[mid[:, 2] < 0.15 * R]  # only the cap near the pole can touch
    zone: ContactBoundary | ContactInterface
    if contact == "boundary":
        zone = ContactBoundary(ball, near, plane, friction=mu, name="cap")
    else:
        zone = ContactInterface.from_boundary(ball, near, plane, friction=mu, name="cap")
    return Scene(comm, [ball], contacts=[zone])


class _Run:
    """A pressed half ball: the problem, its friction, the loads and radii at a solve."""

    def __init__(self, h: float, mu: float, contact: str, algorithm: str, comm: MPI.Comm):
        self.mu, self.travel = mu, [0.0]
        scene = _scene(h, mu, contact, self.travel, comm)
        self.problem = StaticProblem(scene, algorithm=algorithm)
        self.dofs = scene.subdomains[0].num_dofs
        self.operator = self.problem.analysis.zones[0].operator
        self.friction = self.operator.friction
        self.friction.mu = 0.0  # pressed without friction, as the closed form assumes
        self.problem.solve(1.0)
        self.friction.mu = mu
        active = self.friction.state != OPEN
        self.friction.state[active] = STICK  # at rest: the history starts here
        self.friction.direction[:] = 0.0
        self.friction.scale[:] = 0.0
        self.t = 1.0

    def step(self, travel: float) -> dict:
        """A load step to the top's travel; the loads (whole ball) and the radii."""
        self.travel[0], self.t = travel, self.t + 1.0
        self.problem.solve(self.t)
        force = 2.0 * self.problem.contact_forces()["cap"]  # half model
        state, weight = self.friction.state, self.operator.points.weight
        # radii of the half discs with the active and the sticking points' areas
        return {
            "P": float(force[2]),
            "Q": float(-force[0]),
            "travel": travel,
            "a_measured": float(np.sqrt(2.0 * weight[state != OPEN].sum() / np.pi)),
            "c": float(np.sqrt(2.0 * weight[state == STICK].sum() / np.pi)),
            "sticking": int(np.sum(state == STICK)),
            "active": int(np.sum(state != OPEN)),
        }


def _closed_form(P: float, Q: float, mu: float) -> dict:
    R, E, nu = HERTZ["radius"], HERTZ["E"], HERTZ["nu"]
    G = E / (2.0 * (1.0 + nu))
    a = (3.0 * P * R * (1.0 - nu**2) / (4.0 * E)) ** (1.0 / 3.0)
    x = min(Q / (mu * P), 1.0)
    return {
        "a": a,
        "c": a * (1.0 - x) ** (1.0 / 3.0),
        "delta": 3.0 * mu * P * (2.0 - nu) / (16.0 * G * a) * (1.0 - (1.0 - x) ** (2.0 / 3.0)),
        "no_slip": Q * (2.0 - nu) / (8.0 * G * a),
    }


def cattaneo_mindlin(
    h: float,
    mu: float = 0.3,
    levels: tuple[float, ...] = CM_LEVELS,
    contact: str = "boundary",
    algorithm: str = "FULL",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dict:
    """The half ball pressed, then pulled along x in load steps aiming at ``levels``.

    Returns ``dofs``, ``body`` (C_body), ``changes`` and per load step (``steps``): P, Q,
    x = Q / (mu P), the stuck radius c and its closed form ``c_ref``, the compliance
    ``delta`` (top travel less C_body Q) and ``delta_ref``, the slip's share ``slip`` (top
    travel less the bonded one at that Q) and ``slip_ref`` (delta less no-slip's).
    """
    bonded = _Run(h, BONDED, contact, algorithm, comm)
    pressed = bonded.step(0.0)
    probe = PROBE * HERTZ["radius"]
    pulled = bonded.step(probe)
    if pulled["active"] != pressed["active"]:  # the body's compliance is a linear one
        raise RuntimeError(f"cattaneo_mindlin: the probe released points at h = {h}")
    bonded.problem.close()
    P, Q = pressed["P"], pulled["Q"]
    body = probe / Q - _closed_form(P, Q, mu)["no_slip"] / Q
    run = _Run(h, mu, contact, algorithm, comm)
    steps = []
    for level in levels:
        # the top's travel for this level, by the closed form and the body's compliance
        aim = _closed_form(P, level * mu * P, mu)["delta"] + body * level * mu * P
        out = run.step(aim)
        ref = _closed_form(out["P"], out["Q"], mu)
        out.update(x=out["Q"] / (mu * out["P"]), c_ref=ref["c"], a=ref["a"])
        out.update(delta=aim - body * out["Q"], delta_ref=ref["delta"])
        out.update(slip=aim - probe * out["Q"] / Q, slip_ref=ref["delta"] - ref["no_slip"])
        steps.append(out)
    result = {"dofs": run.dofs, "body": body, "steps": steps, "changes": run.problem.changes}
    run.problem.close()
    return result


def case_cattaneo_mindlin(h: float = CM_MESH) -> list[Record]:
    """Stuck radius within 10 %, compliance within 5 % at Q / (mu P) = 0.3, 0.6, 0.9."""
    records = []
    for s in cattaneo_mindlin(h)["steps"]:
        if min(abs(s["x"] - level) for level in (0.3, 0.6, 0.9)) > 0.05:
            continue
        name = f"Q/(mu P) = {s['x']:.2f}, h = {h:g}"
        records += [
            record(CASE, f"stuck radius c, {name}", s["c"], s["c_ref"], 0.10),
            record(CASE, f"compliance delta, {name}", s["delta"], s["delta_ref"], 0.05),
        ]
    return records
