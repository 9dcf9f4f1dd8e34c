"""The paper's parameter studies, their charts and the text and JSON forms of the reports.

A :class:`Study` holds every algorithm's cost relative to FULL against one parameter: the four
studies of the bar (:func:`parallelepiped_studies`), the two of the multi-pin joint
(:func:`pin_joint_studies`) and the step and change studies of a user's scene
(:func:`scene_studies`). :func:`plot_study` and :func:`write_studies` draw them (matplotlib is
imported only when a chart is drawn); :func:`format_table` and :func:`to_json_dict` give the
Table-2 reports of :func:`~dd_contact.paper.flops.model.compare` as text and JSON.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

from dd_contact.paper.flops.model import CostReport, SceneSizes, compare
from dd_contact.paper.flops.paper import (
    PAPER_BAR,
    PinJointLayout,
    parallelepiped_sizes,
    pin_joint_sizes,
    split_layers,
)
from dd_contact.solvers.schedule import ALGORITHMS

__all__ = [
    "CHANGES_SWEEP",
    "CONTACT_SCALES",
    "STEPS_SWEEP",
    "MeasuredPoints",
    "Study",
    "format_table",
    "parallelepiped_studies",
    "pin_joint_studies",
    "plot_study",
    "scene_studies",
    "to_json_dict",
    "write_studies",
]


# --------------------------------------------------------------------------- studies


@dataclass(frozen=True)
class Study:
    """One parameter study of the paper: every algorithm's cost relative to FULL vs a parameter.

    Attributes:
        name: Identifier, used in file names (``flops_<name>.png``).
        title: Chart title.
        xlabel: Label of the varied parameter.
        x: Values of the parameter.
        percent_of_full: ``{algorithm: [100 * cost / FULL cost at each x]}``.
        gflops_total: ``{algorithm: [cost at each x, 1e9 operations]}``.
        xscale: ``"log"`` or ``"linear"``.
        yscale: ``"log"`` or ``"linear"``.
        xticklabels: Optional labels of the ``x`` values (e.g. ``"1:9"``).
        extra: Further series along ``x`` (e.g. the contact subdomain's dofs and bandwidth).
        parameters: The fixed parameters of the study.
    """

    name: str
    title: str
    xlabel: str
    x: tuple[float, ...]
    percent_of_full: Mapping[str, tuple[float, ...]]
    gflops_total: Mapping[str, tuple[float, ...]]
    xscale: str = "log"
    yscale: str = "log"
    xticklabels: tuple[str, ...] | None = None
    extra: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    parameters: Mapping[str, Any] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        """JSON-serialisable form (all fields, tuples as lists)."""
        return json.loads(json.dumps(dataclasses.asdict(self)))


def _study(
    name: str,
    title: str,
    xlabel: str,
    x: Sequence[float],
    scenes: Sequence[SceneSizes],
    **kwargs: Any,
) -> Study:
    reports = [compare(s) for s in scenes]
    algorithms = [a for a in ALGORITHMS if all(a in r for r in reports)]
    return Study(
        name=name,
        title=title,
        xlabel=xlabel,
        x=tuple(x),
        percent_of_full={  # compare fills percent_of_full in
            a: tuple(float(cast(float, r[a].percent_of_full)) for r in reports) for a in algorithms
        },
        gflops_total={a: tuple(r[a].gflops_total for r in reports) for a in algorithms},
        **kwargs,
    )


#: N_TS values of the step studies (the paper's 1 ... 10,000).
STEPS_SWEEP: tuple[int, ...] = (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000)
#: gamma values of the contact-change studies.
CHANGES_SWEEP: tuple[int, ...] = (
    1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000, 100000,
)  # fmt: skip
#: Scale factors of the contact interface mesh in the contact-element study.
CONTACT_SCALES: tuple[float, ...] = (0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.4, 2.0)


def parallelepiped_studies(
    elements: tuple[int, int, int] = PAPER_BAR.elements,
    split: tuple[int, int] = PAPER_BAR.split,
    interface: tuple[int, int] = PAPER_BAR.interface,
    contact: tuple[int, int] = PAPER_BAR.contact,
    steps: int = PAPER_BAR.steps,
    changes: int = PAPER_BAR.changes,
) -> list[Study]:
    """The paper's four studies of the bar (method.md 7.1), around the given configuration.

    * ``bar_steps``: ``N_TS`` = 1 ... 10,000 with ``gamma = 2 N_TS``;
    * ``bar_split``: ``Omega1:Omega2`` = 1:9 ... 9:1 (splits that do not divide ``nx`` evenly
      are skipped); the contact subdomain's dofs and half-bandwidth are in ``extra``;
    * ``bar_changes``: ``gamma`` = 1 ... 100,000 at ``N_TS = steps``;
    * ``bar_contact_elements``: the contact interface mesh scaled by :data:`CONTACT_SCALES`
      (``contact`` = 100 x 10 gives 10 x 1 ... 200 x 20 quads); x is the number of contact
      elements, ``D_W`` is in ``extra``.

    Args:
        elements: As for :func:`parallelepiped_sizes`.
        split: As for :func:`parallelepiped_sizes`.
        interface: As for :func:`parallelepiped_sizes`.
        contact: As for :func:`parallelepiped_sizes`.
        steps: As for :func:`parallelepiped_sizes`.
        changes: As for :func:`parallelepiped_sizes`.

    Returns:
        The four studies.
    """
    base = {
        "elements": tuple(elements),
        "split": tuple(split),
        "interface": tuple(interface),
        "contact": tuple(contact),
        "steps": steps,
        "changes": changes,
    }
    params = {k: list(v) if isinstance(v, tuple) else v for k, v in base.items()}

    def sizes(**over: Any) -> SceneSizes:
        return parallelepiped_sizes(**{**base, **over})

    label = f"{elements[0]} x {elements[1]} x {elements[2]} bar"
    return [
        _study(
            "bar_steps",
            f"{label}: FLOPs vs number of time steps (gamma = 2 N_TS)",
            "time steps N_TS",
            STEPS_SWEEP,
            [sizes(steps=n, changes=2 * n) for n in STEPS_SWEEP],
            parameters=params,
        ),
        _bar_split_study(sizes, label, _even_splits(elements[0]), params),
        _study(
            "bar_changes",
            f"{label}: FLOPs vs contact state changes (N_TS = {steps:,})",
            "contact state changes gamma",
            CHANGES_SWEEP,
            [sizes(changes=g) for g in CHANGES_SWEEP],
            parameters=params,
        ),
        _bar_contact_study(sizes, label, _scaled_meshes(contact), params),
    ]


def _even_splits(nx: int) -> list[tuple[int, int]]:
    """The splits 1:9 ... 9:1 that cut ``nx`` layers of hexahedra evenly."""
    splits = []
    for a in range(1, 10):
        try:
            split_layers(nx, (a, 10 - a))
        except ValueError:
            continue
        splits.append((a, 10 - a))
    return splits


def _scaled_meshes(contact: tuple[int, int]) -> list[tuple[int, int]]:
    """The contact interface mesh scaled by :data:`CONTACT_SCALES`, each mesh once."""
    meshes = []
    for s in CONTACT_SCALES:
        m = (max(1, round(contact[0] * s)), max(1, round(contact[1] * s)))
        if m not in meshes:
            meshes.append(m)
    return meshes


def _bar_split_study(
    sizes: Callable[..., SceneSizes],
    label: str,
    splits: list[tuple[int, int]],
    params: Mapping[str, Any],
) -> Study:
    """``bar_split``: the bar at each split, with the contact subdomain's sizes in ``extra``."""
    split_scenes = [sizes(split=sp) for sp in splits]
    return _study(
        "bar_split",
        f"{label}: FLOPs vs split Omega1:Omega2 (contact on Omega1)",
        "split Omega1:Omega2 (Omega1 holds the contact)",
        [a / 10 for a, _ in splits],
        split_scenes,
        xscale="linear",
        xticklabels=tuple(f"{a}:{b}" for a, b in splits),
        extra={
            "contact_subdomain_dofs": tuple(s.subdomains[0].dofs for s in split_scenes),
            "contact_subdomain_half_bandwidth": tuple(
                s.subdomains[0].half_bandwidth for s in split_scenes
            ),
        },
        parameters=params,
    )


def _bar_contact_study(
    sizes: Callable[..., SceneSizes],
    label: str,
    meshes: list[tuple[int, int]],
    params: Mapping[str, Any],
) -> Study:
    """``bar_contact_elements``: the bar with each contact interface mesh, ``D_W`` in ``extra``."""
    contact_scenes = [sizes(contact=m) for m in meshes]
    return _study(
        "bar_contact_elements",
        f"{label}: FLOPs vs contact interface elements",
        "contact interface elements (quadrilaterals, mesh in brackets)",
        [m0 * m1 for m0, m1 in meshes],
        contact_scenes,
        xticklabels=tuple(f"{m0 * m1}\n({m0}x{m1})" for m0, m1 in meshes),
        extra={"contact_dofs": tuple(s.contacts[0].dofs for s in contact_scenes)},
        parameters=params,
    )


def pin_joint_studies(
    steps: int = 10000, changes: int = 20000, layout: PinJointLayout | None = None
) -> list[Study]:
    """The paper's two studies of the multi-pin joint (method.md 7.2).

    * ``pin_steps``: ``N_TS`` = 1 ... 10,000 with ``gamma = 2 N_TS``, every hole in contact;
    * ``pin_holes``: holes in contact 2 ... ``2 n_holes`` at ``N_TS = steps``, ``gamma =
      changes``.

    Args:
        steps: ``N_TS`` of the hole study.
        changes: ``gamma`` of the hole study.
        layout: The joint; the default :class:`PinJointLayout` if ``None``.

    Returns:
        The two studies.
    """
    lay = layout or PinJointLayout()
    n_all = 2 * lay.n_holes
    params = {"layout": dataclasses.asdict(lay), "steps": steps, "changes": changes}
    holes = list(range(min(2, n_all), n_all + 1))
    return [
        _study(
            "pin_steps",
            f"pin joint, {n_all} holes in contact: FLOPs vs time steps (gamma = 2 N_TS)",
            "time steps N_TS",
            STEPS_SWEEP,
            [pin_joint_sizes(n_all, n, 2 * n, lay) for n in STEPS_SWEEP],
            parameters=params,
        ),
        _study(
            "pin_holes",
            f"pin joint: FLOPs vs holes in contact (N_TS = {steps:,}, gamma = {changes:,})",
            "holes in contact",
            holes,
            [pin_joint_sizes(n, steps, changes, lay) for n in holes],
            xscale="linear",
            parameters=params,
        ),
    ]


def _rescaled(sizes: SceneSizes, n_steps: int, gamma: int) -> SceneSizes:
    """``sizes`` with new ``N_TS`` and ``gamma``; each ``alpha`` scaled like ``gamma`` (ceil)."""
    g0 = sizes.gamma
    contacts = tuple(
        dataclasses.replace(c, alpha=gamma if g0 == 0 else math.ceil(c.alpha * gamma / g0))
        for c in sizes.contacts
    )
    return dataclasses.replace(sizes, contacts=contacts, n_steps=n_steps, gamma=gamma)


def scene_studies(sizes: SceneSizes, name: str = "scene") -> list[Study]:
    """Step and contact-change studies of a user's scene.

    * ``<name>_steps``: ``N_TS`` = 1 ... 10,000 with ``gamma`` in the scene's ratio
      ``gamma / N_TS`` (2 if the scene has no steps), at least 1;
    * ``<name>_changes``: ``gamma`` = 1 ... 100,000 at the scene's ``N_TS``.

    Each ``alpha^(k)`` is scaled like ``gamma`` and rounded up, which keeps
    ``max(alpha) <= gamma <= sum(alpha)``.

    Args:
        sizes: The scene.
        name: Prefix of the study names.

    Returns:
        The two studies.
    """
    ratio = sizes.gamma / sizes.n_steps if sizes.n_steps else 2.0
    return [
        _study(
            f"{name}_steps",
            f"{name}: FLOPs vs time steps (gamma = {ratio:.3g} N_TS)",
            "time steps N_TS",
            STEPS_SWEEP,
            [_rescaled(sizes, n, max(1, round(ratio * n))) for n in STEPS_SWEEP],
        ),
        _study(
            f"{name}_changes",
            f"{name}: FLOPs vs contact state changes (N_TS = {sizes.n_steps:,})",
            "contact state changes gamma",
            CHANGES_SWEEP,
            [_rescaled(sizes, sizes.n_steps, g) for g in CHANGES_SWEEP],
        ),
    ]


# --------------------------------------------------------------------------- charts

#: Line colours and markers of the algorithms in every chart.
_STYLE = {
    "FULL": ("black", "o"),
    "v-w-u": ("tab:blue", "s"),
    "w-v-u": ("tab:orange", "^"),
    "w-u": ("tab:green", "D"),
    "v-u": ("tab:red", "v"),
}

MeasuredPoints = Mapping[str, Sequence[Sequence[float]]]


def _read_measured(measured: Any) -> Any:
    if measured is None or isinstance(measured, Mapping):
        return measured
    return json.loads(Path(measured).read_text())


def plot_study(
    study: Study,
    path: str | os.PathLike[str],
    measured: MeasuredPoints | str | os.PathLike[str] | None = None,
) -> Path:
    """Draw ``study`` as a PNG chart (matplotlib, Agg canvas; pyplot is not used).

    Model values are lines with small markers, one per algorithm; FULL is the 100 % line.

    Args:
        study: The study.
        path: Output PNG.
        measured: Hook for measured runs: ``{algorithm: [[x, percent_of_full], ...]}``, or the
            path of a JSON file holding that; drawn as large open markers in the algorithm's
            colour, labelled "measured".

    Returns:
        The path written.
    """
    from matplotlib.figure import Figure

    points = _read_measured(measured) or {}
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.add_subplot()
    for alg, values in study.percent_of_full.items():
        colour, marker = _STYLE.get(alg, ("gray", "x"))
        ax.plot(study.x, values, color=colour, marker=marker, markersize=4, label=f"{alg} (model)")
    for alg, pts in points.items():
        if not pts:
            continue
        colour, marker = _STYLE.get(alg, ("gray", "x"))
        xs, ys = zip(*((float(p[0]), float(p[1])) for p in pts), strict=True)
        ax.plot(
            xs,
            ys,
            linestyle="none",
            marker=marker,
            markersize=9,
            markerfacecolor="none",
            markeredgecolor=colour,
            markeredgewidth=1.6,
            label=f"{alg} (measured)",
        )
    ax.set_xscale(study.xscale)
    ax.set_yscale(study.yscale)
    if study.xticklabels is not None:
        ax.set_xticks(list(study.x), list(study.xticklabels), fontsize=8)
        ax.minorticks_off()
    ax.set_xlabel(study.xlabel)
    ax.set_ylabel("FLOPs relative to FULL [%]")
    ax.set_title(study.title, fontsize=9)
    ax.grid(True, which="major", alpha=0.4)
    ax.legend(fontsize=8)
    out = Path(path)
    fig.savefig(out, dpi=120)
    return out


def write_studies(
    studies: Sequence[Study],
    directory: str | os.PathLike[str],
    measured: Mapping[str, MeasuredPoints] | str | os.PathLike[str] | None = None,
) -> list[Path]:
    """Write ``flops_<name>.png`` and ``flops_<name>.json`` of every study into ``directory``.

    Args:
        studies: The studies.
        directory: Output directory (created if missing).
        measured: Measured points per study, ``{study name: {algorithm: [[x, percent], ...]}}``
            or the path of a JSON file holding that; each study's entry goes to
            :func:`plot_study` and into its JSON under ``"measured"``.

    Returns:
        The files written, PNG then JSON for each study.
    """
    out_dir = Path(directory)
    out_dir.mkdir(parents=True, exist_ok=True)
    all_points = _read_measured(measured) or {}
    written = []
    for study in studies:
        points = all_points.get(study.name)
        png = plot_study(study, out_dir / f"flops_{study.name}.png", points)
        data = study.to_json_dict()
        if points:
            data["measured"] = points
        js = out_dir / f"flops_{study.name}.json"
        js.write_text(json.dumps(data, indent=1) + "\n")
        written += [png, js]
    return written


# --------------------------------------------------------------------------- output


def format_table(reports: Mapping[str, CostReport] | Sequence[CostReport]) -> str:
    """Text table in the style of the paper's Table 2, one block per algorithm.

    Args:
        reports: Reports keyed by algorithm (as from :func:`compare`) or a sequence of them.

    Returns:
        The table; dense matrices show ``dense`` in the bandwidth column.
    """
    items = list(reports.values()) if isinstance(reports, Mapping) else list(reports)
    width = max([24, *(len(m.name) + 2 for r in items for m in r.meshes)])
    head = (
        f"{'mesh':<{width}}{'dofs':>12}{'B':>8}{'decomp.':>10}{'subst.':>14}"
        f"{'GFLOP dec.':>14}{'GFLOP subst.':>14}{'GFLOP':>14}"
    )
    rule = "-" * len(head)
    lines = []
    for r in items:
        pct = "" if r.percent_of_full is None else f"  ({r.percent_of_full:.4g} % of FULL)"
        lines += [f"{r.algorithm}: {r.gflops_total:.6g} GFLOP{pct}", head, rule]
        for m in r.meshes:
            b = "dense" if m.half_bandwidth is None else f"{m.half_bandwidth:,}"
            lines.append(
                f"{m.name:<{width}}{m.dofs:>12,}{b:>8}{m.decompositions:>10,}"
                f"{m.substitutions:>14,}{m.gflops_decomposition:>14.6g}"
                f"{m.gflops_substitution:>14.6g}{m.gflops:>14.6g}"
            )
        lines += [
            rule,
            f"{'total':<{width + 44}}{r.gflops_decomposition:>14.6g}"
            f"{r.gflops_substitution:>14.6g}{r.gflops_total:>14.6g}",
            "",
        ]
    return "\n".join(lines)


def to_json_dict(reports: Mapping[str, CostReport]) -> dict[str, dict[str, Any]]:
    """JSON-serialisable form of reports keyed by algorithm.

    Args:
        reports: Reports keyed by algorithm, e.g. from :func:`compare`.

    Returns:
        ``{algorithm: {"gflops_total", "percent_of_full", "meshes": [{name, dofs,
        half_bandwidth, decompositions, substitutions, gflops_decomposition,
        gflops_substitution}, ...]}}``; ``half_bandwidth`` is ``None`` for dense matrices.
    """
    return {
        key: {
            "gflops_total": r.gflops_total,
            "percent_of_full": r.percent_of_full,
            "meshes": [dataclasses.asdict(m) for m in r.meshes],
        }
        for key, r in reports.items()
    }
