"""Contact pairs (:class:`~dd_contact.ContactPair`) against closed forms.

The contact patch test on non-matching surfaces, Hertz between two elastic spheres of
unequal radii and materials, and two equal bars striking end to end; each in FULL and the
orders that fit, every order against FULL. The cases ``pair-patch``, ``pair-spheres`` and
``pair-bars`` of ``dd-contact verify`` hold them to issue 27's tolerances.
"""

from __future__ import annotations

from typing import Any

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from dd_contact import meshes
from dd_contact.assembly import PairZone
from dd_contact.pairs import PairOperator
from dd_contact.paper.verify.drops import energy_record
from dd_contact.paper.verify.models import Record, locator, record
from dd_contact.parallel import allgathered
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactInterface, ContactPair, Interface, Scene
from dd_contact.subdomains import Material, Subdomain

__all__ = [
    "PAIR_BARS",
    "PAIR_HERTZ",
    "PAIR_ORDERS",
    "PAIR_PATCHES",
    "case_pair_bars",
    "case_pair_patch",
    "case_pair_spheres",
    "hertz_reference",
    "pair_patch",
    "two_bars",
    "two_spheres",
    "two_spheres_scene",
]

# -- the contact patch test ------------------------------------------------------------------
STEEL, ALUMINIUM = Material(200e9, 0.3), Material(70e9, 0.25)
PATCH = {"side": 1.0, "h_a": 1.0, "h_b": 0.8, "pressure": 1.0e6}
#: The patch test's meshes (block A's cells, block B's) and pair options, by name.
PAIR_PATCHES: dict[str, Any] = {
    "hex-hex": ((("hexahedron", (3, 3, 2)), ("hexahedron", (4, 4, 2))), {}),
    "tet-hex": ((("tetrahedron", (3, 3, 2)), ("hexahedron", (4, 5, 2))), {}),
    "hex-tet-quadrature": (
        (("hexahedron", (4, 4, 2)), ("tetrahedron", (3, 3, 2))),
        {"points": "quadrature"},
    ),
    "tet-tet-unbiased": (
        (("tetrahedron", (3, 3, 2)), ("tetrahedron", (5, 4, 2))),
        {"unbiased": True},
    ),
}
#: The scenes (A one subdomain, or cut in two tied by an interface) and the orders that fit
#: each besides FULL.
PAIR_ORDERS = {False: ("w-u",), True: ("v-w-u", "w-v-u")}


def _rollers(sub: Subdomain) -> Subdomain:
    """Hold a block's sides x = 0 and y = 0 in their normal directions (it may expand)."""
    return sub.fix(locator(0, 0.0), [0]).fix(locator(1, 0.0), [1])


def _patch_blocks(cells, split: bool, comm: MPI.Comm, **pair_options):
    """Block A (steel, base held in z) under block B (aluminium, its top pressed down).

    ``split``: A is two subdomains tied through an interface at half its height.
    Returns the scene, the pair and B.
    """
    (kind_a, n_a), (kind_b, n_b) = cells
    side, h_a, h_b = PATCH["side"], PATCH["h_a"], PATCH["h_b"]
    if split:
        half = (n_a[0], n_a[1], max(n_a[2] // 2, 1))
        cuts = [(0.0, h_a / 2), (h_a / 2, h_a)]
        lower, upper = (
            Subdomain(
                meshes.box(MPI.COMM_SELF, [0, 0, z0], [side, side, z1], half, kind_a),
                STEEL,
                f"A{i}",
            )
            for i, (z0, z1) in enumerate(cuts)
        )
    else:
        mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], [side, side, h_a], n_a, kind_a)
        lower = upper = Subdomain(mesh, STEEL, "A")
    mesh_b = meshes.box(MPI.COMM_SELF, [0, 0, h_a], [side, side, h_a + h_b], n_b, kind_b)
    B = Subdomain(mesh_b, ALUMINIUM, "B")
    _rollers(lower).fix(locator(2, 0.0), [2])
    _rollers(upper)
    _rollers(B).add_traction(locator(2, h_a + h_b), [0.0, 0.0, -PATCH["pressure"]])
    a = ContactInterface.from_boundary(upper, locator(2, h_a), None, name="top_of_A")
    b = ContactInterface.from_boundary(B, locator(2, h_a), None, name="bottom_of_B")
    pair = ContactPair(a, b, **pair_options)
    interface = None
    if split:
        interface = Interface.from_boundary(lower, locator(2, h_a / 2), [lower, upper])
    subdomains = [lower, upper, B] if split else [lower, B]
    return Scene(comm, subdomains, interface, [pair]), pair, B


def pair_patch(
    name: str = "hex-hex",
    algorithm: str = "FULL",
    split: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dict:
    """The contact patch test: two blocks pressed through a flat, non-matching contact.

    Args:
        name: A key of :data:`PAIR_PATCHES`.
        algorithm: FULL or an order that fits the scene (:data:`PAIR_ORDERS`).
        split: Cut A in two subdomains tied by an interface (v-w-u and w-v-u need it).
        comm: Communicator.

    Returns:
        ``pressure_error`` (worst nodal pressure of either side against the applied one,
        relative), ``displacement_error`` (B's displacement against its closed form, uniaxial
        stress with every penalty in series, relative to its largest), ``force_error``
        (the pair's force against pressure x area, relative), ``changes`` and the
        displacement ``fields`` of every subdomain.
    """
    cells, options = PAIR_PATCHES[name]
    scene, pair, B = _patch_blocks(cells, split, comm, **options)
    pressure, side, h_a = PATCH["pressure"], PATCH["side"], PATCH["h_a"]
    with StaticProblem(scene, algorithm=algorithm) as problem:
        problem.solve()
        compliance = sum(problem.penalties.values())  # ties, interface and contact in series
        x = B.V.tabulate_dof_coordinates()
        exact = np.zeros_like(x)
        exact[:, 2] = -pressure * (h_a / STEEL.E + compliance + (x[:, 2] - h_a) / ALUMINIUM.E)
        exact[:, :2] = ALUMINIUM.nu * pressure * x[:, :2] / ALUMINIUM.E
        u_error = np.abs(B.u.x.array - exact.ravel()).max() / np.abs(exact).max()
        local = None
        if comm.rank == scene.contact_owner(pair):  # the sides' pressures land there
            local = max(np.abs(s.pressure.x.array / pressure - 1.0).max() for s in pair.sides)
        p_error = max(v for v in allgathered(comm, local) if v is not None)
        force = problem.contact_forces()[pair.name]
        f_error = np.abs(force - [0.0, 0.0, -pressure * side**2]).max() / (pressure * side**2)
        return {
            "pressure_error": float(p_error),
            "displacement_error": float(u_error),
            "force_error": float(f_error),
            "changes": int(problem.changes["gamma"]),
            "fields": [s.u.x.array.copy() for s in scene.subdomains],
        }


def case_pair_patch() -> list[Record]:
    """Every patch in every order: pressure and displacement to 1e-8, orders to FULL 1e-9."""
    out = []
    for name in PAIR_PATCHES:
        for split, orders in PAIR_ORDERS.items():
            full = None
            for algorithm in ("FULL", *orders):
                r = pair_patch(name, algorithm, split)
                case = f"pair-patch {name} {algorithm}{' (A cut in two)' if split else ''}"
                pressure, displacement = r["pressure_error"], r["displacement_error"]
                out += [
                    record(case, "1 + max |p - p_applied| / p_applied", 1 + pressure, 1, 1e-8),
                    record(case, "1 + max |u_B - u_exact| / |u_exact|", 1 + displacement, 1, 1e-8),
                    record(case, "1 + |F - p A| / (p A)", 1 + r["force_error"], 1, 1e-8),
                ]
                if full is None:
                    full = r["fields"]
                else:
                    diff = _difference(r["fields"], full)
                    out.append(record(case, "1 + max |u - u_FULL| / |u_FULL|", 1 + diff, 1, 1e-9))
    return out


def _difference(fields: list, reference: list) -> float:
    """Largest difference of two lists of fields, relative to the reference's largest."""
    size = max(np.abs(f).max() for f in reference)
    return float(max(np.abs(f - g).max() for f, g in zip(fields, reference, strict=True)) / size)


# -- Hertz between two elastic spheres -------------------------------------------------------
#: Two spheres of unequal radii and materials, touching at the origin: sphere A (radius 1,
#: E = 1) above, sphere B (radius 1.5, E = 0.5) below; each a quarter hemisphere (symmetry
#: planes x = 0 and y = 0), A's flat face pushed down by ``approach``, B's held. A's cap is
#: the pair's side a (its nodes are the contact points): mortar-style weighted gaps want
#: side a no finer than side b (``ratio`` = h_B / h_A < 1; docs/contact.md).
PAIR_HERTZ: dict[str, Any] = {
    "radii": (1.0, 1.5),
    "E": (1.0, 0.5),
    "nu": (0.3, 0.25),
    "approach": 0.05,
    "h_far": 0.2,
    "tolerance": 0.08,
}


def _hemisphere(k: int, h_contact: float, comm: MPI.Comm) -> tuple[Subdomain, np.ndarray]:
    """Sphere ``k`` (0: A above, 1: B below) as a quarter hemisphere; its cap near the pole.

    B is A's mesh turned half a turn about the line x = y, z = 0 ((x, y, z) -> (y, x, -z):
    a rotation, so its cells keep their orientation), with its own radius and size.
    """
    R, h_far = PAIR_HERTZ["radii"][k], PAIR_HERTZ["h_far"] * PAIR_HERTZ["radii"][k]
    mesh, tags = meshes.hemisphere(MPI.COMM_SELF, R, 0.2, h_contact, h_far)
    x = mesh.geometry.x
    if k == 1:
        x[:] = np.stack([x[:, 1].copy(), x[:, 0].copy(), -x[:, 2]], axis=1)
    material = Material(PAIR_HERTZ["E"][k], PAIR_HERTZ["nu"][k])
    sphere = Subdomain(mesh, material, "A" if k == 0 else "B")
    normal_x, normal_y = (0, 1) if k == 0 else (1, 0)  # the turn swaps the symmetry planes
    sphere.fix((tags, meshes.HEMISPHERE_SYMMETRY_X), components=[normal_x])
    sphere.fix((tags, meshes.HEMISPHERE_SYMMETRY_Y), components=[normal_y])
    approach = -PAIR_HERTZ["approach"] if k == 0 else 0.0
    sphere.fix((tags, meshes.HEMISPHERE_TOP), components=[2], value=[0, 0, approach])
    cap = sphere.locate_facets((tags, meshes.HEMISPHERE_CURVED))
    mid = x[dolfinx.mesh.entities_to_geometry(mesh, 2, cap)].mean(axis=1)
    return sphere, cap[np.abs(mid[:, 2]) < 0.15 * R]  # only near the pole can it touch


def two_spheres_scene(
    h_contact: float = 0.02, ratio: float = 0.67, comm: MPI.Comm = MPI.COMM_WORLD
) -> tuple[Scene, ContactPair]:
    """The two spheres of :data:`PAIR_HERTZ` and their caps' :class:`ContactPair`.

    A is meshed at ``h_contact`` near the pole, B at ``ratio * h_contact``; A's cap is side a.
    """
    (A, cap_a), (B, cap_b) = (
        _hemisphere(k, h, comm) for k, h in ((0, h_contact), (1, ratio * h_contact))
    )
    a = ContactInterface.from_boundary(A, cap_a, None, name="cap_A")
    b = ContactInterface.from_boundary(B, cap_b, None, name="cap_B")
    pair = ContactPair(a, b, tolerance=PAIR_HERTZ["tolerance"], name="spheres")
    return Scene(comm, [A, B], None, [pair]), pair


def hertz_reference(force: float) -> tuple[float, float]:
    """Hertz's contact radius and peak pressure of the two spheres at ``force``."""
    (R1, R2), (E1, E2), (nu1, nu2) = PAIR_HERTZ["radii"], PAIR_HERTZ["E"], PAIR_HERTZ["nu"]
    R = R1 * R2 / (R1 + R2)
    E_star = 1.0 / ((1 - nu1**2) / E1 + (1 - nu2**2) / E2)
    a = (3.0 * force * R / (4.0 * E_star)) ** (1.0 / 3.0)
    return a, 3.0 * force / (2.0 * np.pi * a**2)


def two_spheres(
    h_contact: float = 0.02,
    ratio: float = 0.67,
    algorithm: str = "FULL",
    comm: MPI.Comm = MPI.COMM_WORLD,
    petsc_options: dict | None = None,
) -> dict:
    """Hertz between two elastic spheres (:data:`PAIR_HERTZ`), at the computed force.

    ``petsc_options``: for MUMPS (:class:`~dd_contact.StaticProblem`), e.g. another ordering.

    Returns:
        ``force`` (the whole sphere's: 4 x the quarter's), ``a`` (radius of the circle with
        the active points' area), ``a_edge`` (largest radius of an active point), ``p_max``
        (largest pressure of a contact point), ``p_side_max`` (largest published nodal
        pressure of each side, ``[a, b]``), the Hertz values ``a_ref``, ``p0_ref``, the
        resolution ``a_over_h`` (Hertz's radius over A's mesh size there), ``dofs``,
        ``changes``, ``iterations`` and the displacement ``fields``.
    """
    scene, pair = two_spheres_scene(h_contact, ratio, comm)
    with StaticProblem(scene, algorithm=algorithm, petsc_options=petsc_options) as problem:
        problem.solve()
        force = 4.0 * float(problem.contact_forces()[pair.name][2])  # b pushes a up
        a_ref, p0_ref = hertz_reference(force)
        result = {
            "force": force,
            "a_ref": a_ref,
            "p0_ref": p0_ref,
            "a_over_h": a_ref / h_contact,
            "dofs": sum(s.num_dofs for s in scene.subdomains),
            "changes": int(problem.changes["gamma"]),
            "iterations": int(problem.iterations),
            "fields": [s.u.x.array.copy() for s in scene.subdomains],
        }
        local = None
        zones = [z for z in problem.zones if isinstance(z, PairZone)]
        if zones:  # on the pair's rank
            op = zones[0].operator
            assert isinstance(op, PairOperator)
            p = op.point_pressure(zones[0].published())
            active = p > 0
            r = np.linalg.norm(op.points.x[:, :2], axis=1)
            local = {
                "a": float(np.sqrt(4.0 * op.points.weight[active].sum() / np.pi)),
                "a_edge": float(r[active].max()),
                "p_max": float(p.max()),
                "p_side_max": [float(s.pressure.x.array.max()) for s in pair.sides],
            }
    for part in allgathered(comm, local):
        if part is not None:
            result.update(part)
    return result


def case_pair_spheres() -> list[Record]:
    """Hertz at h = 0.02 near A's pole (a / h = 8.8), B at 2/3 of it; w-u against FULL."""
    r = two_spheres()
    case = "pair-spheres h_A=0.02 h_B=0.0133"
    out = [
        record(case, "contact radius a", r["a"], r["a_ref"], 0.05),
        record(case, "peak pressure, side a (nodal)", r["p_side_max"][0], r["p0_ref"], 0.05),
        record(case, "peak pressure, side b (nodal)", r["p_side_max"][1], r["p0_ref"], 0.05),
    ]
    diff = _difference(two_spheres(algorithm="w-u")["fields"], r["fields"])
    yardstick = _yardstick(case, two_spheres(petsc_options=ROUNDOFF)["fields"], r["fields"])
    return [*out, _against_full(case + " w-u", diff, yardstick), yardstick]


#: MUMPS's AMD ordering: FULL solved again with it is FULL's own round-off (as
#: :data:`dd_contact.paper.compare.ROUNDOFF_OPTIONS`).
ROUNDOFF = {"mat_mumps_icntl_7": 0}


def _yardstick(case: str, fields: list, full: list) -> Record:
    """FULL with another ordering against FULL: shown beside the orders, not judged."""
    diff = _difference(fields, full)
    what = "1 + max |u - u_FULL| / |u_FULL| (FULL's round-off, not judged)"
    return Record(case + " FULL, AMD ordering", what, 1 + diff, 1.0, diff, float("inf"), True)


def _against_full(case: str, diff: float, yardstick: Record) -> Record:
    """An order against FULL: to 1e-9, or to twice FULL's own round-off where that is more.

    On the spheres and the bars, FULL under another ordering differs from FULL by about
    3e-9 (penalty 1e6): 1e-9 lies below their round-off, which no exact solver meets.
    """
    tolerance = max(1e-9, 2 * yardstick.rel_error)
    what = "1 + max |u - u_FULL| / |u_FULL| (1e-9, or 2x FULL's round-off if more)"
    return record(case, what, 1 + diff, 1, tolerance)


# -- two bars striking -----------------------------------------------------------------------
#: Two equal bars (E = rho = 1, nu = 0: c = 1, L = 1, section 0.1) at +-v0, a gap apart,
#: lateral faces on rollers: they touch for 2 L / c and exchange their velocities.
PAIR_BARS: dict[str, Any] = {
    "length": 1.0,
    "section": 0.1,
    "v0": 0.01,
    "gap": 0.001,
    "n": 20,
    "cfl": 0.25,
}


def _bar(x0: float, name: str, velocity: float) -> Subdomain:
    L, s, n = PAIR_BARS["length"], PAIR_BARS["section"], PAIR_BARS["n"]
    bar = Subdomain(
        meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x0 + L, s, s], [n, 1, 1]),
        Material(1.0, 0.0, 1.0),
        name,
    )
    bar.fix(locator(1, 0.0), [1]).fix(locator(2, 0.0), [2])
    bar.velocity.interpolate(
        lambda x: np.vstack([np.full(x.shape[1], velocity), 0 * x[0], 0 * x[0]])
    )
    return bar


def two_bars(
    algorithm: str = "FULL", comm: MPI.Comm = MPI.COMM_WORLD, petsc_options: dict | None = None
) -> dict:
    """Two bars striking end to end (:data:`PAIR_BARS`), default settings.

    ``petsc_options``: for MUMPS (:class:`~dd_contact.TransientProblem`).

    Returns:
        ``duration`` (time in contact) and ``duration_ref`` = 2 L / c, ``velocities`` (each
        bar's mean x velocity after, over the other's before: 1 if exchanged), the largest
        and last energy over the start's (``energy_max``, ``energy_ratio``), ``changes`` and
        the displacement ``fields``.
    """
    L, v0, gap = PAIR_BARS["length"], PAIR_BARS["v0"], PAIR_BARS["gap"]
    left, right = _bar(0.0, "left", v0), _bar(L + gap, "right", -v0)
    a = ContactInterface.from_boundary(left, locator(0, L), None, name="left_end")
    b = ContactInterface.from_boundary(right, locator(0, L + gap), None, name="right_end")
    pair = ContactPair(a, b)
    dt = PAIR_BARS["cfl"] * L / PAIR_BARS["n"]
    scene = Scene(comm, [left, right], None, [pair])
    with TransientProblem(scene, dt, algorithm=algorithm, petsc_options=petsc_options) as problem:
        start = problem.energy()["total"]
        energies, touching = [], 0
        for _ in range(int((gap / (2 * v0) + 2.3 * L) / dt)):
            touching += problem.advance()["active"][pair.name] > 0
            energies.append(problem.energy()["total"] / start)
        changes = int(problem.changes["gamma"])
    velocities = [
        float(bar.velocity.x.array.reshape(-1, 3)[:, 0].mean() / (sign * v0))
        for bar, sign in ((left, -1.0), (right, 1.0))
    ]
    return {
        "duration": dt * touching,
        "duration_ref": 2.0 * L,
        "velocities": velocities,
        "energy_max": max(energies),
        "energy_ratio": energies[-1],
        "changes": changes,
        "fields": [left.u.x.array.copy(), right.u.x.array.copy()],
    }


def case_pair_bars() -> list[Record]:
    """Issue 27's targets in FULL and w-u, w-u against FULL."""
    out, full = [], None
    for algorithm in ("FULL", "w-u"):
        r = two_bars(algorithm)
        case = f"pair-bars n={PAIR_BARS['n']} cfl={PAIR_BARS['cfl']} {algorithm}"
        ratio, top = r["energy_ratio"], r["energy_max"]
        out += [
            record(case, "contact duration", r["duration"], r["duration_ref"], 0.03),
            record(case, "left's velocity after / right's before", r["velocities"][0], 1, 0.02),
            record(case, "right's velocity after / left's before", r["velocities"][1], 1, 0.02),
            energy_record(case, ratio),
            Record(
                case,
                "largest energy / start at most 1 + 1e-6",
                top,
                1.0,
                max(0.0, top - 1.0),
                1e-6,
                top <= 1 + 1e-6,
            ),
            Record(
                case,
                "contact state changes (at most 4)",
                float(r["changes"]),
                4.0,
                max(0.0, r["changes"] - 4.0) / 4.0,
                0.0,
                r["changes"] <= 4,
            ),
        ]
        if full is None:
            full = r["fields"]
        else:
            orders = (case, _difference(r["fields"], full))  # judged below
    assert full is not None
    case = f"pair-bars n={PAIR_BARS['n']} cfl={PAIR_BARS['cfl']}"
    yardstick = _yardstick(case, two_bars(petsc_options=ROUNDOFF)["fields"], full)
    return [*out, _against_full(*orders, yardstick), yardstick]
