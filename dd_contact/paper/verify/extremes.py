"""The penalty sweep: every algorithm over tie penalties 1e0 ... 1e14 (``--case extremes``).

Blocks pressed onto a rigid plane (:func:`pressed_scene`), against the penalty-free closed form;
docs/accuracy.md.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import numpy as np

from dd_contact.obstacles import Plane
from dd_contact.paper.verify.models import Record, locator, stress_error
from dd_contact.paper.verify.orders import block_scene, blocks
from dd_contact.problem import StaticProblem
from dd_contact.scene import ContactInterface, Scene
from dd_contact.solvers.schedule import fitting_algorithms

__all__ = [
    "DISTORTION",
    "EXTREME_CASES",
    "EXTREME_CELLS",
    "EXTREME_FAMILIES",
    "EXTREME_KAPPAS",
    "MODERATE_KAPPA",
    "PENALTY_FLOOR",
    "ExtremeCase",
    "PenaltyRecord",
    "extremes",
    "penalty_tolerance",
    "pressed_scene",
]


# -- penalty extremes: every algorithm against a penalty-free reference --------------------
#: Tolerance of a penalty-sweep record: ``max(10 x the penalty's own modelling error, floor)``.
PENALTY_FLOOR = 1e-8

#: Dimensionless tie penalties of the sweep: every decade 1e0 ... 1e14.
EXTREME_KAPPAS = tuple(10.0**k for k in range(15))

#: Penalties that are not swept (the other tie, the contact penalty) in the sweep's scenes.
MODERATE_KAPPA = 1e4

#: Swept penalty -> scene kinds (:data:`ORDER_SCENES`) that carry it: ``"tie"`` sweeps the
#: interface's kappa, ``"contact-tie"`` the contact interface's.
EXTREME_FAMILIES = {"tie": ("interface", "boundary"), "contact-tie": ("interface", "single")}

#: (volume cell, surface cell) of the sweep's meshes, as they appear in the case names.
EXTREME_CELLS = {
    "hex-quad": ("hexahedron", "quadrilateral"),
    "hex-tri": ("hexahedron", "triangle"),
    "tet-quad": ("tetrahedron", "quadrilateral"),
    "tet-tri": ("tetrahedron", "triangle"),
}

#: In-plane move of the interior surface nodes of the ``-distorted`` cases (shortest edges).
DISTORTION = 0.2


def penalty_tolerance(modelling_error: float) -> float:
    """Tolerance of a penalty-sweep quantity whose penalty modelling error is given.

    Ten times the error the penalty itself makes in the quantity (relative), at least
    :data:`PENALTY_FLOOR`: a solve may lose digits only where the penalty has already
    spent them.
    """
    return max(10.0 * modelling_error, PENALTY_FLOOR)


@dataclass
class PenaltyRecord(Record):
    """A :class:`Record` of the penalty sweep: one algorithm at one penalty.

    ``rel_error`` is the larger of ``stress_error`` and ``force_error``; ``note`` says why a
    solve failed (its error is then inf) and which warnings it gave.
    """

    family: str = ""
    algorithm: str = ""
    kappa: float = 0.0
    stress_error: float = 0.0
    force_error: float = 0.0
    note: str = ""


@dataclass(frozen=True)
class ExtremeCase:
    """One scene of the penalty sweep (:func:`extremes`)."""

    family: str
    kind: str
    cells: str
    distorted: bool

    @property
    def name(self) -> str:
        """Case name, e.g. ``tie-interface-hex-quad-distorted``."""
        return f"{self.family}-{self.kind}-{self.cells}" + ("-distorted" if self.distorted else "")


#: Every case of the sweep, by name.
EXTREME_CASES = {
    c.name: c
    for c in (
        ExtremeCase(family, kind, cells, distorted)
        for family, kinds in EXTREME_FAMILIES.items()
        for kind in kinds
        for cells in EXTREME_CELLS
        for distorted in (False, True)
    )
}


def pressed_scene(
    kind: str,
    kappa: float = MODERATE_KAPPA,
    contact_tie_kappa: float = MODERATE_KAPPA,
    cells: str = "hex-quad",
    distorted: bool = False,
    pressure: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Scene:
    """The blocks of :func:`order_scene` pressed onto a rigid plane by a uniform pressure.

    A pressure on the far end x = 1 (``"single"``) or x = 2 presses A's end x = 0 onto the
    rigid plane x = 0 (contact penalty :data:`MODERATE_KAPPA`); symmetry planes y = 0 and
    z = 0 hold the rest. The exact stress is uniform, sigma_xx = -pressure, the plane carries
    the whole load, and every tie transmits a uniform traction (a tied patch test): the
    penalties add only rigid offsets, so the result carries no penalty error at any penalty.

    Args:
        kind: ``"interface"`` (FULL, v-w-u, w-v-u), ``"boundary"`` (FULL, v-u) or
            ``"single"`` (FULL, w-u).
        kappa: Tie penalty of the interface.
        contact_tie_kappa: Tie penalty of the contact interface.
        cells: Key of :data:`EXTREME_CELLS`; the surface meshes have 4 x 5 cells.
        distorted: Move the surface meshes' interior nodes in-plane (:data:`DISTORTION`).
        pressure: The pressure on the far end.
        comm: Communicator.
    """
    volume_cell, surface_cell = EXTREME_CELLS[cells]
    parts = blocks(kind, volume_cell)
    for part in parts:
        part.fix(locator(1, 0.0), components=[1])
        part.fix(locator(2, 0.0), components=[2])
    parts[-1].add_traction(locator(0, float(len(parts))), (-pressure, 0.0, 0.0))
    return block_scene(
        kind,
        parts,
        Plane([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        comm,
        kappa=kappa,
        contact_tie_kappa=contact_tie_kappa,
        contact_kappa=MODERATE_KAPPA,
        surface_cell=surface_cell,
        resolution=(4, 5),
        distortion=DISTORTION if distorted else 0.0,
    )


def _penalty_record(case: ExtremeCase, algorithm: str, kappa: float, scene: Scene) -> PenaltyRecord:
    """Solve a :func:`pressed_scene` (pressure 1 on a unit section) with ``algorithm``.

    The error is the larger of the worst cell stress's deviation from the exact uniform
    stress and the contact force's deviation from the load, both relative to the load; a
    solve that raises has error inf and says why in ``note``, as do warnings it gave.
    """
    stress = force = np.inf
    notes = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with StaticProblem(scene, algorithm) as problem:
                problem.solve()
                reaction = problem.contact_forces()["end"]
        stress = stress_error(scene, 0, -1.0)
        force = float(np.linalg.norm(reaction - [1.0, 0.0, 0.0]))
        notes += sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    except (RuntimeError, FloatingPointError) as failure:
        notes.append(f"{type(failure).__name__}: {failure}")
    note = "; ".join(notes)
    error = max(stress, force)
    # The exact solution is linear: the penalty models stress and force exactly.
    tolerance = penalty_tolerance(0.0)
    return PenaltyRecord(
        case.name,
        f"{algorithm}, kappa={kappa:.0e}: 1 + max(|sigma - sigma_exact|, |F - F_exact|) / p",
        1.0 + error,
        1.0,
        error,
        tolerance,
        bool(error <= tolerance),
        family=f"{case.family}-{case.kind}",
        algorithm=algorithm,
        kappa=kappa,
        stress_error=stress,
        force_error=force,
        note=note,
    )


def extremes(
    kappas: Sequence[float] = EXTREME_KAPPAS,
    cases: Sequence[str] | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> list[Record]:
    """Every fitting algorithm on :func:`pressed_scene` over a sweep of one tie penalty.

    The reference is penalty-free and closed-form (uniform stress, contact force = load),
    and the penalty adds no modelling error to either, so the tolerance is
    ``max(10 x 0, PENALTY_FLOOR)``: what a record shows beyond round-off is the solver's
    loss of digits at that penalty.

    Args:
        kappas: The swept penalty's values.
        cases: Names in :data:`EXTREME_CASES` (default all).
        comm: Communicator.

    Returns:
        One :class:`PenaltyRecord` per case, algorithm fitting its scene, and penalty.
    """
    names = list(EXTREME_CASES) if cases is None else list(cases)
    unknown = [n for n in names if n not in EXTREME_CASES]
    if unknown:
        raise ValueError(f"unknown extremes case(s) {unknown}; valid: {', '.join(EXTREME_CASES)}")
    records: list[Record] = []
    for case in (EXTREME_CASES[n] for n in names):
        make = functools.partial(
            pressed_scene, case.kind, cells=case.cells, distorted=case.distorted, comm=comm
        )
        probe = make()
        has_w = any(isinstance(c, ContactInterface) for c in probe.contacts)
        algorithms = fitting_algorithms(probe.interface is not None, has_w)
        swept = "kappa" if case.family == "tie" else "contact_tie_kappa"
        for kappa in kappas:
            for algorithm in algorithms:
                swept_kappa: dict[str, Any] = {swept: kappa}
                scene = make(**swept_kappa)
                records.append(_penalty_record(case, algorithm, kappa, scene))
    return records
