"""Accuracy presets of a problem: ``accuracy="fast" | "balanced" | "reference"``.

A preset fills in what the user left out, from the measured fronts (docs/tradeoff.md,
"Presets"); it never overrides an argument given. ``"balanced"`` is the package's default
and changes nothing. What a preset sets:

* a transient problem with inertia: its time step when ``dt`` is not given, in units of the
  contacts' wave time (:func:`contact_wave_time`), and its mass kind when ``mass`` is not
  given;
* a static problem: nothing. What it owns buys no accuracy for time: the contact penalty
  gives the same answer from 1e4 up, contact at nodes is both the cheapest and the most
  accurate scheme, and the algorithm changes the time only. A static answer's accuracy is
  its mesh's, which is the user's;
* a mesh built from an element size near the contact: that size times the preset's
  factor (:func:`mesh_size`), where the caller asks for it (the Hertz scene's builder).
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.mesh
import numpy as np

from dd_contact.errors import InputError
from dd_contact.forms import MASS_KINDS
from dd_contact.parallel import max_over_ranks
from dd_contact.scene import Scene

__all__ = [
    "ACCURACY_PRESETS",
    "MESH_FACTORS",
    "TransientPreset",
    "contact_wave_time",
    "mesh_size",
    "transient_preset",
]


@dataclass(frozen=True)
class TransientPreset:
    """What a preset gives a transient problem.

    Attributes:
        courant: The time step in units of the contacts' wave time h / c.
        mass: The mass kind.
    """

    courant: float
    mass: str


#: The presets, from the bar impact's front (n = 40, the L1 error of the contact force):
#: a step of one wave time is both more accurate and cheaper than half of one (the
#: trapezoidal rule's period lengthening offsets the consistent mass's shortening); two
#: wave times cost 0.8x for 1.7x the error; a quarter with averaged mass (its peak
#: overshoots least) 0.8x the error for 3.9x the time.
ACCURACY_PRESETS: dict[str, TransientPreset] = {
    "fast": TransientPreset(2.0, "consistent"),
    "balanced": TransientPreset(1.0, "consistent"),
    "reference": TransientPreset(0.25, "averaged"),
}


#: The factor of the element size near the contact a preset gives a mesh built from a size,
#: from the Hertz front: twice the size is 7x faster at 2.0 % (the default's 0.44 %), two
#: thirds of it 2.3x more accurate at 7x the time (docs/tradeoff.md, "Presets").
MESH_FACTORS: dict[str, float] = {"fast": 2.0, "balanced": 1.0, "reference": 2.0 / 3.0}


def mesh_size(h: float, accuracy: str) -> float:
    """The element size near the contact for a mesh built from size ``h`` under a preset.

    ``h`` is the "balanced" size and is returned as it is for "balanced"; a builder that
    takes a preset passes its size through here (:func:`dd_contact.paper.verify.hertz`).
    """
    return h * MESH_FACTORS[check_accuracy(accuracy, "mesh_size")]


def check_accuracy(accuracy: str, where: str) -> str:
    """``accuracy`` if it names a preset; an :class:`InputError` naming the valid ones."""
    if accuracy not in ACCURACY_PRESETS:
        raise InputError(
            f"{where}: unknown accuracy {accuracy!r}; valid: "
            f"{', '.join(map(repr, ACCURACY_PRESETS))} (docs/tradeoff.md, 'Presets')"
        )
    return accuracy


def _shortest_edge(mesh: dolfinx.mesh.Mesh) -> float:
    """The least distance of two vertices of a cell: a cell's shortest edge (no topology)."""
    cells = mesh.geometry.x[mesh.geometry.dofmaps[0]]
    if len(cells) == 0:
        return np.inf
    pairs = [(i, j) for i in range(cells.shape[1]) for j in range(i)]
    return float(min(np.linalg.norm(cells[:, i] - cells[:, j], axis=1).min() for i, j in pairs))


def contact_wave_time(scene: Scene) -> float:
    """Collective: the least time a P-wave takes to cross an element of a body in contact.

    ``h / c`` with h the shortest cell edge of the body (its smallest cells are where it
    touches, on a mesh refined for contact) and c = sqrt(E (1 - nu) / ((1 + nu)(1 - 2 nu)
    rho)); the least over the scene's contacts. An :class:`InputError` if the scene has
    no contact or a body in contact has no density.
    """
    zones = [*scene.contacts, *(side for pair in scene.pairs for side in pair.sides)]
    if not zones:
        raise InputError(
            "TransientProblem: dt=None takes the accuracy preset's step, in wave times of "
            "the scene's contacts, and the scene has no contact: give dt"
        )
    least = np.inf
    for zone in zones:
        m = zone.subdomain.material
        if not m.rho > 0:
            raise InputError(
                f"TransientProblem: dt=None, and the body of contact {zone.name!r} has no "
                "density (Material rho) to give its wave time: give dt or rho"
            )
        c = np.sqrt(m.E * (1.0 - m.nu) / ((1.0 + m.nu) * (1.0 - 2.0 * m.nu) * m.rho))
        least = min(least, _shortest_edge(zone.subdomain.mesh) / c)
    return -max_over_ranks(scene.comm, -least)


def transient_preset(
    scene: Scene, accuracy: str | None, dt: float | None, mass: str | None, inertia: bool
) -> tuple[float, str]:
    """Collective: the time step and mass kind of a transient problem (given ones kept).

    With no preset named (``accuracy=None``) the mass is "balanced"'s and ``dt`` must be
    given: a step silently taken from the contacts' wave time could be thousands of times
    finer than a slowly loaded scene needs.
    """
    if accuracy is None and dt is None:
        raise InputError(
            "TransientProblem: no time step; give dt, or name an accuracy preset ("
            f"{', '.join(map(repr, ACCURACY_PRESETS))}) to take it from the wave time of "
            "the scene's contacts (docs/tradeoff.md, 'Presets')"
        )
    name = "balanced" if accuracy is None else accuracy
    preset = ACCURACY_PRESETS[check_accuracy(name, "TransientProblem")]
    mass = preset.mass if mass is None else mass
    if mass not in MASS_KINDS:
        raise InputError(
            f"TransientProblem: unknown mass {mass!r}; valid: "
            f"{', '.join(map(repr, MASS_KINDS))} (lumped: a diagonal mass matrix; "
            "averaged: half consistent, half lumped)"
        )
    if dt is None:
        if not inertia:
            raise InputError("TransientProblem: inertia=False steps a load: give its dt")
        dt = preset.courant * contact_wave_time(scene)
    return dt, mass
