"""The scenes of a trade study: their knobs, their references and the error each run is judged by.

* ``hertz``: an elastic hemisphere pressed on a rigid plane (quasi-static,
  :func:`dd_contact.paper.verify.hertz`), against Hertz's closed form.
* ``bar-impact``: an elastic bar, cut in two tied halves, striking a rigid wall
  (:func:`dd_contact.paper.verify.bar_impact`), against 1-D wave theory.
* ``tilted-wall``: the paper's parallelepiped shaken on a tilted wall
  (:mod:`dd_contact.paper.tradeoff.tilted`), against a converged run.
* ``pin-joint``: the paper's multi-pin joint pulled onto its pins
  (:mod:`dd_contact.paper.tradeoff.pin`), against a converged run.

A scene's :attr:`TradeScene.measure` runs one setting and returns its error and the parts the
error is made of; it is what the worker process calls (:mod:`.worker`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from dd_contact.paper.tradeoff.design import (
    ENERGY_SAFE_CONTACT,
    MASS,
    RHO_INFINITY,
    Knob,
    Level,
    scheme,
)
from dd_contact.scene import DEFAULT_KAPPA

__all__ = ["SCENES", "TradeScene", "bar_error", "hertz_error", "hertz_fit", "scene"]


@dataclass(frozen=True)
class TradeScene:
    """A scene of a trade study.

    Attributes:
        name: The scene's name (``dd-contact tradeoff NAME``).
        knobs: The settings it varies, with their defaults and levels.
        error: Which error is measured, and why a user cares about it.
        reference: The reference (closed form, its own error), as written into the JSON.
        measure: ``settings -> {"error": float, "parts": {...}}``, run in a worker.
    """

    name: str
    knobs: tuple[Knob, ...]
    error: str
    reference: dict[str, Any]
    measure: Callable[[dict[str, Any]], dict[str, Any]]

    def with_defaults(self, **values: Any) -> TradeScene:
        """This scene with other defaults (a smaller scene for tests: ``n=10``)."""
        unknown = set(values) - {k.name for k in self.knobs}
        if unknown:
            raise KeyError(f"scene {self.name!r} has no knob {sorted(unknown)}")
        knobs = tuple(
            replace(k, default=values[k.name]) if k.name in values else k for k in self.knobs
        )
        return replace(self, knobs=knobs)

    def only(self, names: list[str]) -> TradeScene:
        """This scene with only the knobs ``names`` varied (the others at their defaults)."""
        knobs = tuple(k if k.name in names else replace(k, levels=()) for k in self.knobs)
        return replace(self, knobs=knobs)


# -- Hertz ---------------------------------------------------------------------------------
def hertz_fit(r: np.ndarray, p: np.ndarray) -> tuple[float, float]:
    """Hertz's profile ``p0 sqrt(1 - r^2 / a^2)`` fitted to pressures ``p`` at radii ``r``.

    Least squares of ``p^2 = p0^2 - (p0 / a)^2 r^2``, linear in ``r^2``; returns (p0, a).
    """
    matrix = np.vstack([np.ones_like(r), r**2]).T
    alpha, beta = np.linalg.lstsq(matrix, p**2, rcond=None)[0]
    return float(np.sqrt(alpha)), float(np.sqrt(-alpha / beta))


def hertz_error(result: dict) -> dict[str, Any]:
    """The worse of the contact radius's and the peak pressure's relative errors.

    Both from Hertz's profile fitted to the pressures of the active contact points
    (:func:`hertz_fit`), against Hertz's a and p0 evaluated with the computed force (the
    approach is prescribed at the flat face, which also compresses the hemisphere's bulk:
    the force-approach law is a half-space's and is not judged). The raw values (the
    radius of the active area, the largest nodal pressure) are in the parts: they scatter
    by 1-3 % with where the nodes fall, which would hide the trade.
    """
    p0, a = hertz_fit(np.asarray(result["profile_r"]), np.asarray(result["profile_p"]))
    errors = {
        "contact_radius": a / result["a_ref"] - 1.0,
        "peak_pressure": p0 / result["p0_ref"] - 1.0,
    }
    parts = {
        **errors,
        "contact_radius_active_area": result["a"] / result["a_ref"] - 1.0,
        "peak_pressure_nodal": result["p_max"] / result["p0_ref"] - 1.0,
        "force": result["force"],
        "dofs": result["dofs"],
        "iterations": result["iterations"],
        "contact_points": len(result["profile_r"]),
    }
    return {"error": float(max(map(abs, errors.values()))), "parts": parts}


def _measure_hertz(settings: dict[str, Any]) -> dict[str, Any]:
    from dd_contact.paper.verify import hertz

    result = hertz(
        settings["h_contact"],
        points=settings["points"],
        contact=settings["contact"],
        contact_kappa=settings["contact_kappa"],
        kappa=settings["kappa"],
        degree=settings["degree"],
        grading=settings["grading"],
        algorithm=settings["algorithm"],
        accuracy=settings["accuracy"],
    )
    return hertz_error(result)


_INTERFACE = {"contact": "interface"}

HERTZ = TradeScene(
    name="hertz",
    knobs=(
        Knob(
            "h_contact",
            0.015,
            (*(Level(h) for h in (0.04, 0.03, 0.02)), Level(0.01, costly=True)),
            "resolution",
            "element size near the pole / R",
        ),
        Knob(
            "grading",
            0.2,
            (Level(0.1), Level(0.4)),
            "resolution",
            "growth of the element size away from the contact (per unit distance)",
        ),
        Knob(
            "contact_kappa",
            DEFAULT_KAPPA,
            tuple(Level(k) for k in (1.0, 10.0, 100.0, 1e4, 1e8)),
            what="contact penalty h / (E eps_C)",
        ),
        Knob("points", "nodes", (Level("quadrature", costly=True),), what="contact points"),
        Knob(
            "contact",
            "boundary",
            (Level("interface"),),
            what="contact on the body's boundary or on a contact interface tied to it",
        ),
        Knob(
            "kappa",
            DEFAULT_KAPPA,
            tuple(Level(k, _INTERFACE) for k in (1e2, 1e4, 1e8)),
            what="tie penalty of the contact interface",
        ),
        Knob(
            "degree",
            1,
            (
                Level(2, {**_INTERFACE, "h_contact": 0.04}),
                Level(2, {**_INTERFACE, "h_contact": 0.03}, costly=True),
            ),
            what="Lagrange degree (P2 on a coarser mesh)",
        ),
        Knob(
            "algorithm",
            "FULL",
            (Level("w-u", _INTERFACE), Level("auto")),
            "time only",
            "elimination order",
        ),
        Knob(
            "accuracy",
            "balanced",
            (Level("fast"), Level("reference")),
            "resolution",
            "the preset: the size near the pole (h_contact x 2 fast, x 2/3 reference: "
            "dd_contact.accuracy.mesh_size); StaticProblem's sets nothing",
        ),
    ),
    error=(
        "max(|a / a_Hertz - 1|, |p0 / p0_Hertz - 1|), a and p0 of Hertz's profile fitted to "
        "the contact points' pressures, against Hertz's evaluated with the computed force: "
        "the contact size and peak pressure a user reads, without the 1-3 % scatter of the "
        "raw nodal values (kept in the parts)"
    ),
    reference={
        "kind": "closed form",
        "model": "quarter hemisphere R = 1, E = 1, nu = 0.3, flat face pushed 0.03 R onto a "
        "rigid plane (dd_contact.paper.verify.hertz)",
        "a": "(3 F R / (4 E*))^(1/3), E* = E / (1 - nu^2)",
        "p0": "3 F / (2 pi a^2)",
        "own_error": "Hertz's half-space theory is off by order (a/R)^2 = 0.03 at a = 0.17 R "
        "(an upper estimate: the fitted a and p0 of the finer runs agree with it to 0.1 % and "
        "0.5 %)",
    },
    measure=_measure_hertz,
)


#: What a preset needs to act: the step and the mass left to it.
_PRESET = {"cfl": None, "mass": None}


# -- bar impact ----------------------------------------------------------------------------
def bar_error(result: dict, dt: float) -> dict[str, Any]:
    """The L1 error of the contact force history against the square pulse of wave theory.

    ``sum_k |F_k - F(t_k)| dt / (F0 2L/c)``, F(t) = rho c v0 A for 0 < t < 2L/c: what the
    wall (or whatever the bar strikes) feels, its level and its duration at once.
    """
    forces = np.asarray(result["forces"])
    f0, duration = result["force_ref"], result["duration_ref"]
    t = dt * np.arange(1, len(forces) + 1)
    exact = np.where(t < duration * (1 - 1e-9), f0, 0.0)  # a step at 2L/c: 0, round-off or not
    error = float(np.sum(np.abs(forces - exact)) * dt / (f0 * duration))
    parts = {
        "duration": result["duration"] / duration - 1.0,
        "parting": result["parting"] / duration - 1.0,
        "plateau_force": result["plateau_force"] / f0 - 1.0,
        "peak_force": result["peak_force"] / f0 - 1.0,
        "rebound": result["rebound"] - 1.0,
        "energy_ratio": result["energy_ratio"],
        "changes": result["changes"],
        "steps": result["steps"],
    }
    return {"error": error, "parts": parts}


def _measure_bar(settings: dict[str, Any]) -> dict[str, Any]:
    from dd_contact.paper.verify import bar_impact

    result = bar_impact(
        n=settings["n"],
        cfl=settings["cfl"],
        contact_kappa=settings["contact_kappa"],
        contact=settings["contact"],
        split=True,
        algorithm=settings["algorithm"],
        energy_safe_contact=settings["energy_safe_contact"],
        mass=settings["mass"],
        scheme=settings["scheme"],
        rho_infinity=settings["rho_infinity"],
        kappa=settings["kappa"],
        degree=settings["degree"],
        interface_resolution=tuple(settings["interface_resolution"]),
        across=settings["across"],
        accuracy=settings["accuracy"],
        watch=False,  # the face's readings are not judged here
    )
    return bar_error(result, result["dt"])


BAR = TradeScene(
    name="bar-impact",
    knobs=(
        Knob(
            "across",
            4,
            (),
            what="elements across the section, each way (not varied: nu = 0 keeps the answer "
            "1-D, the same as with one; 4 x 4 makes the runs cost what a 3-D body's do)",
        ),
        Knob(
            "n",
            40,
            (*(Level(n) for n in (10, 20, 80, 160)), Level(320, costly=True)),
            "resolution",
            "elements",
        ),
        Knob(
            "cfl",
            1.0,
            tuple(Level(c) for c in (0.1, 0.25, 0.5, 2.0)),
            "resolution",
            "time step in units of h / c",
        ),
        Knob(
            "contact_kappa",
            DEFAULT_KAPPA,
            tuple(Level(k) for k in (1.0, 100.0, 1e4, 1e8)),
            what="contact penalty h / (E eps_C)",
        ),
        Knob(
            "kappa",
            DEFAULT_KAPPA,
            tuple(Level(k) for k in (1e2, 1e4, 1e8)),
            what="tie penalty of the interface at the cut",
        ),
        MASS,
        scheme(0.8, 0.0),
        RHO_INFINITY,
        ENERGY_SAFE_CONTACT,
        Knob(
            "contact",
            "boundary",
            (Level("interface"),),
            what="contact on the bar's end face or on a 1x1 contact interface tied to it",
        ),
        Knob(
            "degree",
            1,
            (Level(2, {**_INTERFACE, "n": 20}), Level(2, {**_INTERFACE, "n": 10})),
            what="Lagrange degree (P2 on fewer elements)",
        ),
        Knob(
            "interface_resolution",
            [4, 4],
            (Level([2, 2]), Level([6, 6])),
            what="cells of the interface mesh across the section (4 x 4 elements across)",
        ),
        Knob(
            "algorithm",
            "FULL",
            (Level("v-u"), Level("w-v-u", _INTERFACE), Level("auto")),
            "time only",
            "elimination order",
        ),
        Knob(
            "accuracy",
            "balanced",
            tuple(Level(a, _PRESET) for a in ("fast", "reference")),
            "resolution",
            "TransientProblem's preset: its time step (in wave times h / c) and mass",
        ),
    ),
    error=(
        "L1 error of the contact force history against wave theory's square pulse, "
        "sum |F_k - F(t_k)| dt / (F0 2L/c): the load the struck body feels, its level and "
        "duration in one number"
    ),
    reference={
        "kind": "closed form",
        "model": "bar L = 1, section 0.1 x 0.1 (4 x 4 elements across), E = rho = 1, nu = 0 "
        "(c = 1), v0 = 0.01, cut at L/2 into two tied halves, 3 L/c simulated "
        "(dd_contact.paper.verify.bar_impact)",
        "contact_duration": "2 L / c = 2",
        "force": "rho c v0 A = 1e-4",
        "own_error": "exact for the 1-D bar (nu = 0)",
    },
    measure=_measure_bar,
)


# -- the parallelepiped on the tilted wall ----------------------------------------------------
def _measure_tilted(settings: dict[str, Any]) -> dict[str, Any]:
    from dd_contact.paper.tradeoff.tilted import tilted_error

    return tilted_error(settings)


TILTED = TradeScene(
    name="tilted-wall",
    knobs=(
        Knob(
            "elements",
            [40, 10, 2],
            (Level([20, 5, 1]), Level([80, 20, 4], costly=True)),
            "resolution",
            "hexahedra along, across and through the bar",
        ),
        Knob(
            "dt",
            2.5e-5,
            (Level(2e-4), Level(1e-4), Level(5e-5)),
            "resolution",
            "time step [s] (the load's period 4 ms; the paper's 0.1 ms was the default until "
            "its front put it 2.5x off: the step the coarse-step monitor asks for, <= 28 us)",
        ),
        Knob(
            "split",
            [5, 5],
            (Level([1, 9]), Level([9, 1])),
            what="where the subdomains are cut: element layers of Omega1 : Omega2",
        ),
        Knob(
            "surfaces",
            "non-matching",
            (Level("matching"), Level("coarse")),
            what="interface and contact-interface quads: one in five fewer than the facets, "
            "the facets', or half",
        ),
        Knob(
            "contact_kappa",
            DEFAULT_KAPPA,
            tuple(Level(k) for k in (1e2, 1e4, 1e8)),
            what="contact penalty h / (E eps_C)",
        ),
        MASS,
        Knob(
            "algorithm",
            "FULL",
            (Level("v-w-u"), Level("w-v-u")),
            "time only",
            "elimination order",
        ),
    ),
    error=(
        "relative L2 error of the wall force averaged over windows of 0.2 ms against a "
        "converged run's: the bearing load's course (rise, peak, release) a user reads; at "
        "the step's scale each closing row rings, and that ringing does not converge"
    ),
    reference={
        "kind": "converged run (Richardson over two refinements)",
        "model": "the paper's parallelepiped (dd_contact.paper.models.parallelepiped): steel "
        "400 x 100 x 10 mm, clamped at x = 0.4 m, a body force b sin(2 pi t / 4 ms) pushing "
        "its end onto a wall tilted by 2e-5 rad, one period",
        "run": "80 x 20 x 4 hexahedra, dt = 25 us (benchmarks/tradeoff_tilted_reference.py)",
        "own_error": "Richardson over (20, 5, 1) at 100 us, (40, 10, 2) at 50 us and the "
        "reference: see dd_contact.paper.tradeoff.tilted.REFERENCE['richardson']",
    },
    measure=_measure_tilted,
)

from dd_contact.paper.tradeoff.pin_scene import PIN  # noqa: E402  (it needs TradeScene)

SCENES: dict[str, TradeScene] = {s.name: s for s in (HERTZ, BAR, TILTED, PIN)}


def scene(name: str) -> TradeScene:
    """The scene called ``name``; a ``KeyError`` naming the valid ones otherwise."""
    if name not in SCENES:
        raise KeyError(f"unknown scene {name!r}; valid: {', '.join(SCENES)}")
    return SCENES[name]
