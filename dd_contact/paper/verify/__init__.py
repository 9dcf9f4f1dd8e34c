"""Verification cases with closed-form or independent references (``dd-contact verify``).

Each case returns records ``{case, quantity, value, reference, rel_error, tolerance, passed}``.
The scene builders are public so tests, demos and benchmarks use the same models:
:mod:`~dd_contact.paper.verify.models` (the closed-form cases),
:mod:`~dd_contact.paper.verify.orders` (the block scenes shared by tests and every order
against FULL), :mod:`~dd_contact.paper.verify.extremes` (the penalty sweep),
:mod:`~dd_contact.paper.verify.drops` (3-D bodies dropped on a plane),
:mod:`~dd_contact.paper.verify.pairs` (contact between two bodies),
:mod:`~dd_contact.paper.verify.cattaneo` (a Hertz contact under a tangential load),
:mod:`~dd_contact.paper.verify.cases` (the registry of ``dd-contact verify``).
"""

from dd_contact.paper.verify.bar import bar_impact
from dd_contact.paper.verify.cases import CASES, run_cases
from dd_contact.paper.verify.cattaneo import cattaneo_mindlin
from dd_contact.paper.verify.drops import (
    box_drop_scene,
    drop,
    falling_block,
    hemisphere_drop_scene,
    sphere_drop,
)
from dd_contact.paper.verify.extremes import (
    DISTORTION,
    EXTREME_CASES,
    EXTREME_CELLS,
    EXTREME_FAMILIES,
    EXTREME_KAPPAS,
    MODERATE_KAPPA,
    PENALTY_FLOOR,
    ExtremeCase,
    PenaltyRecord,
    extremes,
    penalty_tolerance,
    pressed_scene,
)
from dd_contact.paper.verify.models import (
    Record,
    bent_bar,
    free_vibration,
    hertz,
    patch_test,
)
from dd_contact.paper.verify.orders import (
    ORDER_SCENES,
    displacements,
    order_scene,
    orders_agreement,
)
from dd_contact.paper.verify.pairs import (
    PAIR_BARS,
    PAIR_HERTZ,
    PAIR_PATCHES,
    hertz_reference,
    pair_patch,
    two_bars,
    two_spheres,
    two_spheres_scene,
)

__all__ = [
    "CASES",
    "DISTORTION",
    "EXTREME_CASES",
    "EXTREME_CELLS",
    "EXTREME_FAMILIES",
    "EXTREME_KAPPAS",
    "MODERATE_KAPPA",
    "ORDER_SCENES",
    "PAIR_BARS",
    "PAIR_HERTZ",
    "PAIR_PATCHES",
    "PENALTY_FLOOR",
    "ExtremeCase",
    "PenaltyRecord",
    "Record",
    "bar_impact",
    "bent_bar",
    "box_drop_scene",
    "cattaneo_mindlin",
    "displacements",
    "drop",
    "extremes",
    "falling_block",
    "free_vibration",
    "hemisphere_drop_scene",
    "hertz",
    "hertz_reference",
    "order_scene",
    "orders_agreement",
    "pair_patch",
    "patch_test",
    "penalty_tolerance",
    "pressed_scene",
    "run_cases",
    "sphere_drop",
    "two_bars",
    "two_spheres",
    "two_spheres_scene",
]
