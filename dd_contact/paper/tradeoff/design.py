"""What a trade study runs, and which runs no other run beats (the Pareto front).

A scene's settings are a dict of named knobs; each :class:`Knob` has a default and the levels
the study tries. The design has two phases: one knob at a time from the default
(:func:`first_design`), then combined moves along the front measured so far
(:func:`combined_design`). A level may need other settings to act at all (a tie penalty
needs a tie, degree 2 needs a contact interface): those come with it (``Level.needs``).
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "Knob",
    "Level",
    "Run",
    "combined_design",
    "default_verdict",
    "first_design",
    "front_time_at",
    "is_costly",
    "pareto_front",
    "settings_key",
]


@dataclass(frozen=True)
class Level:
    """One value of a knob.

    ``needs``: the other settings it needs to act (``{knob: value}``); ``costly``: it costs
    far more than the default (run after the cheap ones, so that a study cut short by its
    budget has measured the most points).
    """

    value: Any
    needs: dict[str, Any] = field(default_factory=dict)
    costly: bool = False


@dataclass(frozen=True)
class Knob:
    """A setting that trades time for accuracy.

    Attributes:
        name: The setting's name (the key in a run's settings).
        default: Its value in the default run.
        levels: The other values the study tries, one at a time from the default.
        kind: ``"resolution"`` (mesh or time step: moves along the front by itself),
            ``"time only"`` (the answer does not change: the algorithm) or ``"model"``.
        what: What it is, in a few words (for the JSON and the docs).
    """

    name: str
    default: Any
    levels: tuple[Level, ...]
    kind: str = "model"
    what: str = ""


#: The knobs several transient scenes share, declared once.
MASS = Knob("mass", "consistent", (Level("lumped"), Level("averaged")), what="mass matrix")
RHO_INFINITY = Knob(
    "rho_infinity", None, (), what="generalized-alpha's spectral radius at infinity"
)
ENERGY_SAFE_CONTACT = Knob(
    "energy_safe_contact",
    True,
    (Level(False),),
    what="energy-safe contact steps (False: the classic trapezoidal contact)",
)


def scheme(*rho_infinity: float) -> Knob:
    """The time scheme knob: trapezoidal, or generalized-alpha at each ``rho_infinity``."""
    return Knob(
        "scheme",
        "trapezoidal",
        tuple(Level("generalized-alpha", {"rho_infinity": r}) for r in rho_infinity),
        what="time scheme (generalized-alpha with rho_infinity)",
    )


@dataclass
class Run:
    """One planned run: its settings and what it changed from the default.

    ``changes`` is the dict of what changed, ``changed`` its label, ``kind`` the kind of
    the knob moved (:class:`Knob`; ``"combined"`` for several).
    """

    settings: dict[str, Any]
    changes: dict[str, Any]
    phase: str = "one knob"
    kind: str = "model"
    costly: bool = False

    @property
    def changed(self) -> str:
        """What the run changed from the default, as ``knob=value, ...``."""
        return _label(self.changes)

    @property
    def key(self) -> str:
        """The settings as a canonical string (equal settings, equal keys)."""
        return settings_key(self.settings)


def settings_key(settings: dict[str, Any]) -> str:
    """``settings`` as canonical JSON (a tuple and a list of the same values agree)."""
    return json.dumps(settings, sort_keys=True)


def defaults(knobs: Sequence[Knob]) -> dict[str, Any]:
    """The default settings of ``knobs``."""
    return {k.name: k.default for k in knobs}


def _label(changes: dict[str, Any]) -> str:
    return ", ".join(f"{name}={_show(value)}" for name, value in changes.items()) or "default"


def _show(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple | list):
        return "x".join(map(str, value))
    return str(value)


def _apply(base: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``changes``."""
    return {**base, **changes}


def _changes_of(knobs: Sequence[Knob], knob: Knob, level: Level) -> dict[str, Any]:
    """What moving ``knob`` to ``level`` changes: the level and what it needs, in order."""
    out = {knob.name: level.value}
    out.update({k: v for k, v in level.needs.items() if k != knob.name})
    return out


def is_costly(knobs: Sequence[Knob], changes: dict[str, Any]) -> bool:
    """Whether ``changes`` set a knob to one of its costly levels."""
    return any(
        level.costly and knob.name in changes and changes[knob.name] == level.value
        for knob in knobs
        for level in knob.levels
    )


def first_design(knobs: Sequence[Knob]) -> list[Run]:
    """The default, then every level of every knob alone (with what the level needs).

    The costly levels come last, in the same order.
    """
    base = defaults(knobs)
    runs = [Run(dict(base), {}, "default", "default")]
    seen = {runs[0].key}
    resolution = {k.name for k in knobs if k.kind == "resolution"}
    for knob in knobs:
        for level in knob.levels:
            changes = _changes_of(knobs, knob, level)
            kind = "resolution" if resolution & set(changes) else knob.kind
            run = Run(_apply(base, changes), changes, kind=kind, costly=level.costly)
            if run.key not in seen:
                seen.add(run.key)
                runs.append(run)
    return [r for r in runs if not r.costly] + [r for r in runs if r.costly]


def _merge(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any] | None:
    """Both sets of changes, or None where they ask different values of one knob."""
    for name in a.keys() & b.keys():
        if a[name] != b[name]:
            return None
    return {**a, **b}


def _wins(points: list[dict], base: dict) -> list[dict]:
    """Single changes that buy speed or accuracy at (almost) no cost of the other.

    At most 0.9x the default's time with an error at most 1.1x its, or at most 0.9x its
    error at most 1.1x its time (a tenth either way: less is the timing's noise), on CPU
    time where every point has it (other jobs on the machine stretch the wall time). The
    resolution knobs, the algorithm and levels that change a resolution too are not wins of
    this kind: they move along the front by themselves.
    """
    out = []
    clock = "cpu_seconds" if all(p.get("cpu_seconds") for p in [*points, base]) else "seconds"
    for p in points:
        if p["phase"] != "one knob" or p.get("kind") != "model":
            continue
        faster = p[clock] <= 0.9 * base[clock] and p["error"] <= 1.1 * base["error"]
        better = p["error"] <= 0.9 * base["error"] and p[clock] <= 1.1 * base[clock]
        if faster or better:
            out.append(p)
    return out


def combined_design(knobs: Sequence[Knob], measured: list[dict], limit: int = 16) -> list[Run]:
    """Combined moves along the front, from the measured one-knob runs.

    ``measured`` holds the runs done so far: ``settings``, ``changes`` (the dict of what
    changed), ``phase``, ``kind`` (of the knob changed), ``error``, ``seconds``. In order:
    every win together (:func:`_wins`); the wins with each resolution level (the front
    drawn again with the cheap settings); pairs of one-knob runs on the front. Runs already
    measured are left out; at most ``limit`` runs.
    """
    base = defaults(knobs)
    done = [p for p in measured if p.get("error") is not None]
    default = next((p for p in done if p["phase"] == "default"), None)
    if default is None:
        return []
    wins = _wins(done, default)
    win_changes: dict[str, Any] = {}
    for p in sorted(wins, key=lambda p: p["error"] * p["seconds"]):
        merged = _merge(win_changes, p["changes"])
        win_changes = merged if merged is not None else win_changes
    candidates: list[dict[str, Any]] = []
    if len(wins) > 1:
        candidates.append(win_changes)
    for knob in knobs:
        if knob.kind == "resolution" and win_changes:
            for level in knob.levels:
                merged = _merge(win_changes, _changes_of(knobs, knob, level))
                if merged is not None:
                    candidates.append(merged)
    front = [p for p in pareto_front(done) if p["phase"] == "one knob"]
    for p, q in itertools.combinations(front, 2):
        if p["changes"].keys() & q["changes"].keys():
            continue
        merged = _merge(p["changes"], q["changes"])
        if merged is not None:
            candidates.append(merged)
    seen = {settings_key(p["settings"]) for p in measured}
    runs: list[Run] = []
    for changes in candidates:
        costly = is_costly(knobs, changes)
        run = Run(_apply(base, changes), changes, "combined", "combined", costly)
        if run.key not in seen and len(runs) < limit:
            seen.add(run.key)
            runs.append(run)
    return runs


def pareto_front(points: list[dict], time: str = "seconds") -> list[dict]:
    """The points that no other point beats in both ``time`` and ``error``, fastest first.

    A point is beaten when another is no slower and no less accurate, and better in one of
    the two. Points without an error (failed or stopped runs) are left out.
    """
    valid = [p for p in points if p.get("error") is not None and p.get(time) is not None]

    def beaten(p: dict) -> bool:
        return any(
            q[time] <= p[time]
            and q["error"] <= p["error"]
            and (q[time] < p[time] or q["error"] < p["error"])
            for q in valid
        )

    return sorted((p for p in valid if not beaten(p)), key=lambda p: (p[time], p["error"]))


def front_time_at(front: list[dict], error: float, time: str = "seconds") -> float | None:
    """The least time on ``front`` of a run at most as wrong as ``error`` (None: none is)."""
    times = [p[time] for p in front if p["error"] <= error]
    return min(times) if times else None


def default_verdict(points: list[dict], time: str = "seconds", margin: float = 0.10) -> dict:
    """Does the default sit on the front, or within ``margin`` of the front's time at its error?

    Returns ``on_front``, ``front_seconds`` (the front's time at the default's error),
    ``time_ratio`` (default / that time), ``good`` (on the front or within the margin), and
    the runs that beat it (``beaten_by``: their ``changed``).
    """
    default = next((p for p in points if p.get("phase") == "default"), None)
    if default is None or default.get("error") is None:
        return {"good": None, "reason": "the default run did not finish"}
    front = pareto_front(points, time)
    on_front = any(p is default for p in front)
    fastest = front_time_at(front, default["error"], time)
    ratio = default[time] / fastest if fastest else None
    beaten_by = [
        p["changed"]
        for p in front
        if p is not default and p[time] <= default[time] and p["error"] <= default["error"]
    ]
    return {
        "on_front": on_front,
        "front_seconds": fastest,
        "time_ratio": ratio,
        "good": on_front or (ratio is not None and ratio <= 1.0 + margin),
        "beaten_by": beaten_by,
    }
