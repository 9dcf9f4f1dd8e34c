"""The speed/accuracy trade of the trade-study scenes (``dd-contact tradeoff``), measured.

For each scene (``hertz``: a hemisphere pressed on a plane against Hertz; ``bar-impact``: a
bar struck on a wall against wave theory; ``tilted-wall``: the paper's parallelepiped shaken
on a tilted wall against a converged run) runs :func:`dd_contact.paper.tradeoff.run_study`
(the default, each knob alone, combined moves along the front, the default once more for the
timing's noise; each run in its own process) and writes

* ``benchmarks/results/tradeoff_<scene>.json``: every run's settings, what it changed, its
  error and error parts, wall and CPU seconds, peak memory, whether it is on the front; the
  front, the default's verdict (on the front, or its time against the front's at its error);
* ``benchmarks/results/tradeoff_<scene>.png``: the Pareto chart.

See docs/tradeoff.md. Usage: python benchmarks/tradeoff.py [--scenes hertz bar-impact tilted-wall]
[--budget SECONDS] (per scene, default 720) [--charts] (fronts, verdicts and charts again
from the JSON's runs) [--table] (print the runs as Markdown).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dd_contact.paper.tradeoff import SCENES, run_study, scene
from dd_contact.paper.tradeoff.chart import draw_front
from dd_contact.paper.tradeoff.study import refresh

RESULTS = Path(__file__).parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--budget", type=float, default=720.0, help="seconds per scene")
    parser.add_argument("--charts", action="store_true", help="fronts and charts again")
    parser.add_argument("--table", action="store_true", help="print the runs as Markdown")
    args = parser.parse_args()
    RESULTS.mkdir(exist_ok=True)
    for name in args.scenes:
        json_path = RESULTS / f"tradeoff_{name}.json"
        plot_path = json_path.with_suffix(".png")
        if args.charts or args.table:
            doc = json.loads(json_path.read_text())
            if args.charts:
                if name == "pin-joint":  # its runs scored against today's reference
                    rescore(doc)
                doc = {**doc, **refresh(doc, scene(name))}  # extra fields kept
                json_path.write_text(json.dumps(doc, indent=1))
                draw_front(doc, plot_path)
            else:
                print(markdown(doc))
            continue
        doc = run_study(scene(name), args.budget, json_path, plot_path)
        verdict = doc["default_verdict"]
        print(f"{name}: {len(doc['runs'])} runs, front {len(doc['front'])}, default {verdict}")


def rescore(doc: dict) -> None:
    """Every pin-joint run's error and parts again, from its windows, against pin.REFERENCE."""
    from dd_contact.paper.tradeoff.pin import score

    for r in doc["runs"]:
        if r.get("error") is not None:
            parts = r["parts"]
            r.update(score(parts["windows"]))
            r["parts"].update(changes=parts["changes"], steps=parts["steps"])
    doc["reference"] = scene("pin-joint").reference


def markdown(doc: dict) -> str:
    """The runs of a study as a Markdown table (front: on the wall-time / CPU-time front)."""
    lines = [
        f"{doc['scene']}: {len(doc['runs'])} runs, default {doc['default_verdict']}",
        "",
        "| # | changed | error | wall s | CPU s | peak MiB | front wall / CPU |",
        "|---|---|---|---|---|---|---|",
    ]
    for i, r in enumerate(doc["runs"]):
        if r.get("error") is None:
            lines.append(f"| {i} | {r['changed']} | {r.get('failed') or r.get('stopped')} |||||")
            continue
        front = f"{'yes' if r['on_front'] else ''} / {'yes' if r['on_front_cpu'] else ''}"
        lines.append(
            f"| {i} | {r['changed']} | {r['error']:.2e} | {r['seconds']:.1f} | "
            f"{r['cpu_seconds']:.1f} | {r['peak_mib']:.0f} | {front} |"
        )
    lines += ["", *knob_table(doc)]
    return "\n".join(lines)


def knob_table(doc: dict) -> list[str]:
    """What each one-knob move buys: its error, wall time and CPU time over the default's."""
    runs = [r for r in doc["runs"] if r.get("error") is not None]
    default = next(r for r in runs if r["default"])
    lines = [
        "| changed | error factor | wall-time factor | CPU-time factor |",
        "|---|---|---|---|",
    ]
    for r in runs:
        if r["phase"] == "one knob":
            lines.append(
                f"| {r['changed']} | {r['error'] / default['error']:.2f} | "
                f"{r['seconds'] / default['seconds']:.2f} | "
                f"{r['cpu_seconds'] / default['cpu_seconds']:.2f} |"
            )
    return lines


if __name__ == "__main__":
    main()
