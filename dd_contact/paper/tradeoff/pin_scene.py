"""The trade-study scene ``pin-joint``: its knobs, reference and error (runs: :mod:`.pin`)."""

from __future__ import annotations

from typing import Any

from dd_contact.paper.tradeoff.design import (
    ENERGY_SAFE_CONTACT,
    MASS,
    RHO_INFINITY,
    Knob,
    Level,
    scheme,
)
from dd_contact.paper.tradeoff.scenes import TradeScene
from dd_contact.scene import DEFAULT_KAPPA

__all__ = ["PIN"]


def _measure_pin(settings: dict[str, Any]) -> dict[str, Any]:
    from dd_contact.paper.tradeoff.pin import pin_error

    return pin_error(settings)


PIN: TradeScene = TradeScene(
    name="pin-joint",
    knobs=(
        Knob(
            "elements",
            [6, 4, 2, 8],
            (Level([3, 2, 1, 4]), Level([4, 3, 2, 12]), Level([9, 6, 3, 12], costly=True)),
            "resolution",
            "cells per quarter hole, radial, through the plate, along a grip",
        ),
        Knob(
            "dt",
            2e-6,
            tuple(Level(dt) for dt in (1e-6, 4e-6, 1e-5, 2e-5)),
            "resolution",
            "time step [s] (the demo's 1.6 us; a strike on a pin lasts 0.12-0.2 ms)",
        ),
        scheme(0.8, 0.5),
        RHO_INFINITY,
        MASS,
        ENERGY_SAFE_CONTACT,
        Knob(
            "contact_kappa",
            DEFAULT_KAPPA,
            tuple(Level(k) for k in (1e2, 1e4, 1e8)),
            what="contact penalty h / (E eps_C) of the hole walls",
        ),
        Knob(
            "kappa",
            DEFAULT_KAPPA,
            tuple(Level(k) for k in (1e2, 1e4, 1e8)),
            what="tie penalty of the interface and of the hole walls' contact interfaces",
        ),
        Knob("points", "nodes", (Level("quadrature", costly=True),), what="contact points"),
        Knob(
            "walls",
            "cylinders",
            (Level("facets"),),
            what="hole walls: cylinder meshes turned half a cell from the wall's nodes, or "
            "copies of the wall's facets (matching)",
        ),
        Knob(
            "wall_cells",
            None,
            (Level(2),),
            "resolution",
            "cells of a hole wall's contact interface per quarter circle (None: the plate's)",
        ),
        Knob(
            "algorithm",
            "FULL",
            (Level("v-w-u"), Level("w-v-u"), Level("auto")),
            "time only",
            "elimination order",
        ),
    ),
    error=(
        "relative L2 error of the ten hole walls' forces along the load, averaged over "
        "windows of 20 us, against a converged run's: the load each pin bears from each plate "
        "over time (its strike, its peak, how the pins share it), what pins and holes are "
        "sized by (bearing stress, fatigue); at the step's scale each strike rings"
    ),
    reference={
        "kind": "converged run (Richardson over two refinements)",
        "model": "the paper's pin joint (dd_contact.paper.models.pin_joint): steel plates "
        "10 mm thick, 300 mm wide, five rigid pins of 20 mm in holes 0.05 mm wider, the grips "
        "pulled apart by 20 kN sin(2 pi t / 2 ms); 0.6 ms (0.3 of a period) simulated",
        "run": "cells (12, 8, 4, 16), dt = 1 us (benchmarks/tradeoff_pin_reference.py)",
        "own_error": "Richardson over (3, 2, 1, 4) at 4 us, (6, 4, 2, 8) at 2 us and the "
        "reference: see dd_contact.paper.tradeoff.pin.REFERENCE['richardson']",
    },
    measure=_measure_pin,
)
