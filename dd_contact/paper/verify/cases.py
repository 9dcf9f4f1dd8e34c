"""The cases of ``dd-contact verify``: each a list of records against its reference."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict

from dd_contact.paper.verify.bar import bar_impact
from dd_contact.paper.verify.cattaneo import case_cattaneo_mindlin
from dd_contact.paper.verify.drops import case_falling_block, case_sphere_drop, energy_record
from dd_contact.paper.verify.extremes import extremes
from dd_contact.paper.verify.friction import case_sliding_block
from dd_contact.paper.verify.models import (
    Record,
    bent_bar,
    free_vibration,
    hertz,
    patch_test,
    record,
)
from dd_contact.paper.verify.orders import orders_agreement
from dd_contact.paper.verify.pair_friction import case_sliding_pair
from dd_contact.paper.verify.pairs import case_pair_bars, case_pair_patch, case_pair_spheres
from dd_contact.paper.verify.reduced import case_reduced_modes, case_reduced_static

__all__ = ["CASES", "run_cases"]


# -- cases ---------------------------------------------------------------------------------
def _case_patch(name: str, surface_cell: str, volume_cell: str) -> Callable[[], list[Record]]:
    def run() -> list[Record]:
        error = patch_test(1e6, surface_cell, volume_cell)
        # value: the worst stress relative to the traction; reference: the exact 1.
        return [record(name, "1 + max |sigma - sigma_exact| / t", 1.0 + error, 1.0, 1e-6)]

    return run


def _case_bent_bar() -> list[Record]:
    records = []
    for kappa in (1e4, 1e6):
        tied, single = bent_bar(1, kappa, matching=True)
        # The tie adds a compliance of order 1/kappa (measured: 0.22/kappa for this bar).
        quantity = f"tip deflection, kappa={kappa:g}"
        records.append(record("bent-bar", quantity, tied, single, 1.0 / kappa))
    tied, single = bent_bar(1, 1e6, matching=False)
    records.append(record("bent-bar", "tip deflection, non-matching", tied, single, 0.05))
    return records


def _case_hertz() -> list[Record]:
    r = hertz(0.015)
    return [
        record("hertz", "contact radius a", r["a"], r["a_ref"], 0.05),
        record("hertz", "peak pressure p0", r["p_max"], r["p0_ref"], 0.10),
    ]


def _case_bar_impact() -> list[Record]:
    """Default settings at two meshes and two steps; the peak force with averaged mass.

    The contact plateau force is held to 2 % of rho c v0 A; the peak to 10 % with averaged
    mass at CFL 0.25, as issue 13 asks "with the dissipative scheme or lumped mass" (1.08 at
    40 and 80 elements; at CFL 1 every option overshoots 13-18 %, docs/contact.md). With
    that option the energy is held to never grow.
    """
    out = []
    for n, cfl in ((40, 0.58), (80, 0.58), (40, 0.1)):
        r = bar_impact(n=n, cfl=cfl, contact_kappa=None)
        case = f"bar-impact n={n} cfl={cfl} (default settings)"
        ratio = r["energy_ratio"]
        out += [
            record(case, "contact duration", r["duration"], r["duration_ref"], 0.03),
            record(case, "rebound velocity / -v0", r["rebound"], 1.0, 0.02),
            # never above 1 + 1e-6 (no energy created), at most 2 % lost
            energy_record(case, ratio),
            Record(
                case,
                "contact state changes (at most 4)",
                r["changes"],
                4.0,
                max(0.0, r["changes"] - 4.0) / 4.0,
                0.0,
                r["changes"] <= 4,
            ),
            record(case, "plateau contact force", r["plateau_force"], r["force_ref"], 0.02),
        ]
    for n in (40, 80):
        r = bar_impact(n=n, cfl=0.25, contact_kappa=None, mass="averaged")
        case = f"bar-impact n={n} cfl=0.25 (averaged mass)"
        ratio = r["energy_ratio"]
        out += [
            Record(
                case,
                "energy after / before at most 1 + 1e-6",
                ratio,
                1.0,
                max(0.0, ratio - 1.0),
                1e-6,
                ratio <= 1 + 1e-6,
            ),
            record(case, "plateau contact force", r["plateau_force"], r["force_ref"], 0.02),
            record(case, "peak contact force", r["peak_force"], r["force_ref"], 0.10),
        ]
    return out


def _case_face_velocity() -> list[Record]:
    """What a user reads at the bar's end face, every mass kind (issue 30).

    The face is massless (energy-safe contact): once released it moves with the node layer
    behind it, its velocity the step's mean of that layer's (to round-off); half a wave
    transit later it is as close to the bar's velocity as that layer, which has mass (the
    mesh's own ringing); the kinetic energy a user integrates from ``Subdomain.velocity``
    with the true density is within 1 % of the package's at 80 elements (the wall's mass,
    spread over the bar, is 1/160 of it there; 1.2-1.7 % at 40 elements); one release.
    """
    out = []
    for mass in ("consistent", "lumped", "averaged"):
        for kappa, cfl in ((1.0, 0.1), (None, 0.1), (1.0, 1.0), (None, 1.0)):
            r = bar_impact(n=80, cfl=cfl, contact_kappa=kappa, mass=mass)
            case = f"face-velocity {mass} contact_kappa={kappa} cfl={cfl}"
            tracking, ringing = r["face_tracking"], r["behind_against_bar"]
            out += [
                record(case, "1 + |v_face - layer behind's step mean| / v0", 1 + tracking, 1, 1e-6),
                Record(
                    case,
                    "|v_face - v_bar| / v0 at most the layer behind's (+1e-3)",
                    r["face_against_bar"],
                    ringing,
                    max(0.0, r["face_against_bar"] - ringing),
                    1e-3,
                    r["face_against_bar"] <= ringing + 1e-3,
                ),
                Record(
                    case,
                    "|KE_user - KE_package| / E0 at most 1 %",
                    r["kinetic_error"],
                    0.0,
                    r["kinetic_error"],
                    0.01,
                    r["kinetic_error"] <= 0.01,
                ),
                record(case, "contact state changes (the release)", r["changes"], 1, 0.0),
            ]
    return out


def _case_free_vibration() -> list[Record]:
    r = free_vibration(1000)
    quantity = "1 + max energy drift over 1000 steps"
    return [record("free-vibration", quantity, 1.0 + r["drift"], 1.0, 1e-8)]


def _case_orders() -> list[Record]:
    records = []
    for r in orders_agreement():
        what = f"{r['order']}, {r['scene']}, {'dynamic' if r['dynamic'] else 'static'}"
        records.append(
            record(
                "orders", f"1 + |u - u_FULL| / |u_FULL|, {what}", 1.0 + r["difference"], 1.0, 1e-9
            )
        )
        changes = r["changes"] if r["same_path"] else -1
        records.append(
            record(
                "orders",
                f"contact changes on FULL's path, {what}",
                1 + changes,
                1 + r["changes"],
                0.0,
            )
        )
    return records


CASES: dict[str, Callable[[], list[Record]]] = {
    "patch-hex-quad": _case_patch("patch-hex-quad", "quadrilateral", "hexahedron"),
    "patch-hex-tri": _case_patch("patch-hex-tri", "triangle", "hexahedron"),
    "patch-tet-tri": _case_patch("patch-tet-tri", "triangle", "tetrahedron"),
    "bent-bar": _case_bent_bar,
    "hertz": _case_hertz,
    "bar-impact": _case_bar_impact,
    "face-velocity": _case_face_velocity,
    "falling-block": case_falling_block,
    "sphere-drop": case_sphere_drop,
    "free-vibration": _case_free_vibration,
    "orders": _case_orders,
    "extremes": extremes,
    "pair-patch": case_pair_patch,
    "pair-spheres": case_pair_spheres,
    "pair-bars": case_pair_bars,
    "reduced-static": case_reduced_static,
    "reduced-modes": case_reduced_modes,
    "sliding-block": case_sliding_block,
    "sliding-pair": case_sliding_pair,
    "cattaneo-mindlin": case_cattaneo_mindlin,
}


def run_cases(names: list[str] | None = None) -> list[dict]:
    """Run the named cases (default all) and return their records as dicts."""
    names = list(CASES) if not names else names
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise ValueError(f"unknown case(s) {unknown}; valid: {', '.join(CASES)}")
    return [asdict(r) for name in names for r in CASES[name]()]
