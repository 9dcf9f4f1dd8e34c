"""The Pareto chart of a trade study: error against time, log axes, the front drawn."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["draw_front", "short_label"]

_PHASE_STYLE = {
    "one knob": ("o", "tab:blue", 30),
    "combined": ("s", "tab:green", 30),
    "repeat": ("*", "tab:orange", 110),
    "default": ("*", "tab:red", 220),
}

#: Short names of the knobs on the chart (the JSON keeps the full ones).
_SHORT = {
    "contact_kappa": "kC",
    "kappa": "kT",
    "interface_resolution": "iface",
    "energy_safe_contact": "energy-safe",
    "algorithm": "",
    "scheme": "",
    "rho_infinity": "rho",
    "h_contact": "h",
    "contact": "",
    "points": "",
    "mass": "mass ",
}


def short_label(run: dict[str, Any]) -> str:
    """What ``run`` changed, in a few characters: ``kC=1e+04, averaged, rho=0``."""
    if run["phase"] == "default":
        return "DEFAULT"
    if run["phase"] == "repeat":
        return "default again"
    parts = []
    for name, value in run.get("changes", {}).items():
        if isinstance(value, list):
            value = "x".join(map(str, value))
        elif isinstance(value, float):
            value = f"{value:g}"
        elif value == "generalized-alpha":
            value = "g-alpha"
        key = _SHORT.get(name, name)
        parts.append(f"{key}{value}" if key.endswith(" ") or not key else f"{key}={value}")
    return ", ".join(parts) or run.get("changed", "")


def _staircase(front: list[dict], time: str) -> tuple[list[float], list[float]]:
    xs: list[float] = []
    ys: list[float] = []
    for r in front:  # each front point holds until the next is reached
        if xs:
            xs.append(r[time])
            ys.append(ys[-1])
        xs.append(r[time])
        ys.append(max(r["error"], 1e-12))
    return xs, ys


def _panel(ax: Any, doc: dict[str, Any], time: str, labels: bool) -> None:
    from matplotlib.ticker import NullFormatter

    runs = [r for r in doc["runs"] if r.get("error") is not None and r.get(time)]
    for phase, (marker, colour, size) in _PHASE_STYLE.items():
        sel = [r for r in runs if r["phase"] == phase]
        if sel:
            ax.scatter(
                [r[time] for r in sel],
                [max(r["error"], 1e-12) for r in sel],
                marker=marker,
                c=colour,
                s=size,
                label=phase,
                zorder=4 if phase in ("default", "repeat") else 3,
                edgecolors="k" if phase == "default" else "none",
            )
    for r in runs:
        if labels or r.get("on_front") or r["phase"] == "default":
            ax.annotate(
                short_label(r),
                (r[time], max(r["error"], 1e-12)),
                fontsize=6.5,
                xytext=(4, 3),
                textcoords="offset points",
                fontweight="bold" if r.get("on_front") else "normal",
            )
    key = "front" if time == "seconds" else "front_cpu"
    front = [doc["runs"][i] for i in doc.get(key, [])]
    if front:
        xs, ys = _staircase(front, time)
        ax.plot(xs, ys, "-", c="k", lw=1.2, alpha=0.6, label="Pareto front", zorder=2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.grid(True, which="both", alpha=0.3)
    if runs:
        ax.legend(fontsize=7, loc="upper right")


def draw_front(doc: dict[str, Any], path: str | Path) -> Path:
    """Draw every measured run of ``doc`` (a :func:`~.study.run_study` document) to ``path``.

    Left: error against whole-run wall time, every run labelled by what it changed (front
    runs in bold); the default is the red star (its repeat, the timing's noise, orange);
    the front is the staircase through the runs that no other beats. Right: the same
    against CPU time, the front on CPU time labelled.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (wall, cpu) = plt.subplots(1, 2, figsize=(15, 7), gridspec_kw={"width_ratios": [1.6, 1.0]})
    _panel(wall, doc, "seconds", labels=True)
    _panel(cpu, doc, "cpu_seconds", labels=False)
    wall.set_xlabel("whole-run wall time [s] (set-up included)")
    cpu.set_xlabel("whole-run CPU time [s]")
    wall.set_ylabel("error against the reference")
    verdict = doc.get("default_verdict", {})
    state = "on the front" if verdict.get("on_front") else "off the front"
    ratio = verdict.get("time_ratio")
    extra = f", {ratio:.2f}x the front's time at its error" if ratio else ""
    wall.set_title(f"Trade study: {doc['scene']} (default {state}{extra})", fontsize=10)
    cpu.set_title("the same against CPU time (front on CPU time)", fontsize=10)
    fig.text(0.01, 0.005, "error: " + doc["error_measure"][:200], fontsize=7, alpha=0.8)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    out = Path(path)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
