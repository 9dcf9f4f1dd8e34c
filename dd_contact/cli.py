"""The ``dd-contact`` command.

* ``dd-contact verify``: run the verification cases and print a table.
* ``dd-contact flops``: the paper's operation-count model (``dd_contact.paper.flops``) for the bar
  (``flops parallelepiped``), the multi-pin joint (``flops pin-joint``) or a scene file
  (``flops --scene FILE``); ``--json`` writes the Table-2 numbers, ``--sweep DIR`` draws the
  paper's parameter studies. See ``docs/cost.md``.
* ``dd-contact calibrate``: measure this machine's rates for the timing model behind
  ``algorithm="auto"`` (``dd_contact.timing``) and cache them; ``--show`` prints them.
* ``dd-contact tradeoff SCENE``: the speed/accuracy trade of a scene (``hertz``,
  ``bar-impact``, ``tilted-wall``, ``pin-joint``) measured, a Pareto front of its settings. See
  ``docs/tradeoff.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from typing import Any

from mpi4py import MPI

from tqdm import tqdm

from dd_contact import __version__, timing
from dd_contact.paper import flops
from dd_contact.paper.flops import PAPER_BAR
from dd_contact.paper.tradeoff.command import add_command as _add_tradeoff
from dd_contact.paper.verify import CASES, run_cases

__all__ = ["main"]


def _format_records(records: list[dict]) -> str:
    header = ("case", "quantity", "computed", "reference", "rel. error", "tolerance", "pass")
    rows = [
        (
            r["case"],
            r["quantity"],
            f"{r['value']:.8g}",
            f"{r['reference']:.8g}",
            f"{r['rel_error']:.2e}",
            f"{r['tolerance']:.1e}",
            "yes" if r["passed"] else "NO",
        )
        for r in records
    ]
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths))  # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, rows)])


def _plain(text: str) -> str:
    """Help text without reST markup: ``x`` and :role:`x` become x."""
    return re.sub(r":\w+:`([^`]*)`|``([^`]*)``", lambda m: m.group(1) or m.group(2), text)


def _verify_usage_error(args: argparse.Namespace) -> str | None:
    """What is wrong with the arguments, found before any case runs (None: nothing)."""
    unknown = [name for name in args.case or [] if name not in CASES]
    if unknown:
        return f"unknown case {', '.join(map(repr, unknown))}; valid: {', '.join(CASES)}"
    if args.json:
        directory = os.path.dirname(os.path.abspath(args.json))
        if os.path.isdir(args.json):
            return f"--json {args.json} is a directory; give a file name"
        if not os.path.isdir(directory):
            return f"--json {args.json}: directory {directory} does not exist"
        if not os.access(directory, os.W_OK):
            return f"--json {args.json}: directory {directory} is not writable"
    return None


def _verify(args: argparse.Namespace) -> int:
    problem = _verify_usage_error(args)
    if problem is not None:
        if args.comm.rank == 0:
            print(f"dd-contact verify: error: {problem}", file=sys.stderr)
        return 2
    records = run_cases(args.case)
    if args.comm.rank == 0:
        print(_format_records(records))
        if args.json:
            with open(args.json, "w") as f:
                json.dump(records, f, indent=2)
    failed = sum(not r["passed"] for r in records)
    if failed and args.comm.rank == 0:
        print(f"{failed} of {len(records)} checks FAILED", file=sys.stderr)
    return 1 if failed else 0


def _int_at_least(minimum: int, what: str):
    """An argparse type: an integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be a {what} integer, got {value}")
        return value

    return parse


_positive_int = _int_at_least(1, "positive")
_non_negative_int = _int_at_least(0, "non-negative")


def _ratio(text: str) -> tuple[int, int]:
    parts = text.split(":")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected A:B (e.g. 5:5), got {text!r}")
    a, b = (_positive_int(p) for p in parts)
    return a, b


def _add_output_options(parser: argparse.ArgumentParser, suppress: bool) -> None:
    """``--json``, ``--sweep``, ``--measured``; on model sub-commands with suppressed defaults.

    Suppressed defaults keep a value given before the model name (``flops --json F
    parallelepiped``) from being overwritten by the model parser's default.
    """
    default: Any = argparse.SUPPRESS if suppress else None
    parser.add_argument(
        "--json", metavar="FILE", default=default, help="write the Table-2 numbers as JSON"
    )
    parser.add_argument(
        "--sweep",
        metavar="DIR",
        default=default,
        help="draw the parameter studies as PNG charts (with their numbers as JSON) into DIR",
    )
    parser.add_argument(
        "--measured",
        metavar="FILE",
        default=default,
        help="JSON {study: {algorithm: [[x, percent_of_full], ...]}} of measured runs, drawn as "
        "markers on the --sweep charts",
    )


def _flops_model(args: argparse.Namespace) -> tuple[str, Any, list[Any]]:
    """Header text, scene sizes and (lazily) the studies of the chosen model."""
    if args.model == "parallelepiped":
        kw = {
            "elements": tuple(args.elements),
            "split": args.split,
            "interface": tuple(args.interface),
            "contact": tuple(args.contact),
            "steps": args.steps,
            "changes": args.changes,
        }
        sizes = flops.parallelepiped_sizes(**kw)
        nx, ny, nz = kw["elements"]
        sd = ", ".join(
            f"{s.name} {s.dofs:,} dofs B = {s.half_bandwidth:,}" for s in sizes.subdomains
        )
        header = (
            f"Rectangular parallelepiped {nx} x {ny} x {nz} hexahedra: "
            f"{sizes.whole.dofs:,} dofs, B = {sizes.whole.half_bandwidth:,}\n"
            f"split {kw['split'][0]}:{kw['split'][1]}: {sd}\n"
            f"interface {sizes.interface_dofs:,} dofs, contact interface on Omega1 "
            f"{sizes.contacts[0].dofs:,} dofs; N_TS = {sizes.n_steps:,}, "
            f"alpha = gamma = {sizes.gamma:,}"
        )
        return header, sizes, [lambda: flops.parallelepiped_studies(**kw)]
    if args.model == "pin-joint":
        layout = flops.PinJointLayout(
            n_holes=args.holes,
            n_circumferential=args.circumferential,
            n_radial=args.radial,
            n_layers=args.layers,
            n_length=args.length_elements,
        )
        active = 2 * layout.n_holes if args.active_holes is None else args.active_holes
        sizes = flops.pin_joint_sizes(active, args.steps, args.changes, layout)
        m = flops.pin_joint_mesh_counts(layout)
        w, length = layout.n_holes * layout.pitch, layout.pitch + layout.free_length
        header = (
            f"Multi-pin lap joint: 2 steel plates {w:g} x {length:g} x {layout.thickness:g} mm, "
            f"{layout.n_holes} pin{'s' * (layout.n_holes > 1)} d = {layout.hole_diameter:g} mm "
            f"at pitch {layout.pitch:g} mm"
            f"\n{m['hexahedra']:,} hexahedra, {m['nodes']:,} nodes, {m['dofs']:,} dofs, "
            f"B = {m['half_bandwidth']:,} (whole model)\n"
            f"subdomains: {2 * layout.n_holes} hole blocks ({m['hole_block_dofs']:,} dofs, "
            f"B = {m['hole_block_half_bandwidth']:,}), 2 grips ({m['grip_dofs']:,} dofs, "
            f"B = {m['grip_half_bandwidth']:,}); interface {m['interface_dofs']:,} dofs; "
            f"{active} of {2 * layout.n_holes} holes in contact ({m['contact_dofs']:,} dofs "
            f"each)\nN_TS = {sizes.n_steps:,}, alpha = gamma = {sizes.gamma:,}"
        )
        return header, sizes, [lambda: flops.pin_joint_studies(args.steps, args.changes, layout)]
    sizes = flops.load_scene(args.scene)
    iface = "no interface" if sizes.interface_dofs is None else f"{sizes.interface_dofs:,}"
    header = (
        f"Scene {args.scene}: {len(sizes.subdomains)} subdomains, interface {iface}, "
        f"{len(sizes.contacts)} contact interfaces; whole model {sizes.whole.dofs:,} dofs, "
        f"B = {sizes.whole.half_bandwidth:,}; N_TS = {sizes.n_steps:,}, "
        f"gamma = {sizes.gamma:,}"
    )
    return header, sizes, [lambda: flops.scene_studies(sizes)]


def _flops(args: argparse.Namespace) -> int:
    if args.model is None and args.scene is None:
        print(
            "dd-contact flops: error: give a model (parallelepiped, pin-joint) or --scene FILE",
            file=sys.stderr,
        )
        return 2
    if args.model is not None and args.scene is not None:
        print("dd-contact flops: error: --scene and a model exclude each other", file=sys.stderr)
        return 2
    try:
        header, sizes, studies = _flops_model(args)
    except (ValueError, OSError) as err:
        print(f"dd-contact flops: error: {err}", file=sys.stderr)
        return 2
    reports = flops.compare(sizes)
    print(header)
    print()
    print(flops.format_table(reports))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(flops.to_json_dict(reports), f, indent=1)
    if args.sweep:
        try:
            written = flops.write_studies(studies[0](), args.sweep, args.measured)
        except (ValueError, OSError) as err:
            print(f"dd-contact flops: error: {err}", file=sys.stderr)
            return 2
        print(f"wrote {len(written)} files to {args.sweep}:")
        for path in written:
            print(f"  {path}")
    return 0


def _add_history_options(parser: argparse.ArgumentParser, alpha: str) -> None:
    """--steps and --changes, with the paper's study defaults."""
    parser.add_argument(
        "--steps", type=_non_negative_int, default=10000, metavar="N_TS", help="default 10000"
    )
    parser.add_argument(
        "--changes",
        type=_non_negative_int,
        default=20000,
        metavar="GAMMA",
        help=f"contact state changes, {alpha} (default 20000)",
    )


def _add_flops(sub: Any) -> None:
    """``flops``: a model's sub-command or ``--scene FILE``, and the output options."""
    flops = sub.add_parser(
        "flops",
        help="operation counts (FLOPs) of every algorithm, as in the paper's Table 2",
        description="Operation-count model of FULL, v-w-u, w-v-u, w-u and v-u (docs/cost.md). "
        "Give a model (parallelepiped, pin-joint) or --scene FILE.",
    )
    flops.add_argument("--scene", metavar="FILE", help="a scene JSON file (schema: docs/cost.md)")
    _add_output_options(flops, suppress=False)
    models = flops.add_subparsers(dest="model", metavar="MODEL")
    _add_parallelepiped(models)
    _add_pin_joint(models)
    flops.set_defaults(run=_flops, model=None)


def _add_parallelepiped(models: Any) -> None:
    """``flops parallelepiped``: the bar's options, the paper's by default."""
    bar = models.add_parser(
        "parallelepiped",
        help="the paper's bar (method.md 7.1)",
        description="The paper's rectangular parallelepiped of 8-node hexahedra, cut across x "
        "into two subdomains, one interface on the cut, one contact interface on the end face "
        "of the first subdomain, alpha = gamma.",
    )
    bar.add_argument(
        "--elements",
        nargs=3,
        type=_positive_int,
        default=list(PAPER_BAR.elements),
        metavar=("NX", "NY", "NZ"),
        help="hexahedra along x (cut), y, z (default: {} {} {})".format(*PAPER_BAR.elements),
    )
    bar.add_argument(
        "--split",
        type=_ratio,
        default=PAPER_BAR.split,
        metavar="A:B",
        help="Omega1:Omega2 (default {}:{})".format(*PAPER_BAR.split),
    )
    bar.add_argument(
        "--interface",
        nargs=2,
        type=_positive_int,
        default=list(PAPER_BAR.interface),
        metavar=("NY", "NZ"),
        help="quads of the interface mesh (default: {} {})".format(*PAPER_BAR.interface),
    )
    bar.add_argument(
        "--contact",
        nargs=2,
        type=_positive_int,
        default=list(PAPER_BAR.contact),
        metavar=("NY", "NZ"),
        help="quads of the contact interface mesh (default: {} {})".format(*PAPER_BAR.contact),
    )
    _add_history_options(bar, "alpha = gamma")
    _add_output_options(bar, suppress=True)


def _add_pin_joint(models: Any) -> None:
    """``flops pin-joint``: the joint's options, the paper's by default."""
    pin = models.add_parser(
        "pin-joint",
        help="the multi-pin lap joint (method.md 7.2, dimensions in docs/cost.md)",
        description="Two steel plates with a row of holes and rigid pins; 2 (holes + 1) "
        "subdomains, one interface, one contact interface per hole in contact.",
    )
    pin.add_argument(
        "--active-holes",
        type=_positive_int,
        default=None,
        metavar="N",
        help="holes in contact, 1 ... 2 x holes (default: all)",
    )
    pin.add_argument(
        "--holes", type=_positive_int, default=5, metavar="N", help="pins in the row (default 5)"
    )
    pin.add_argument(
        "--circumferential",
        type=_positive_int,
        default=16,
        metavar="N",
        help="elements per side of a hole block, a quarter of the hole (default 16)",
    )
    pin.add_argument(
        "--radial",
        type=_positive_int,
        default=16,
        metavar="N",
        help="elements from a hole to its block's boundary (default 16)",
    )
    pin.add_argument(
        "--layers",
        type=_positive_int,
        default=8,
        metavar="N",
        help="elements through the thickness (default 8)",
    )
    pin.add_argument(
        "--length-elements",
        type=_positive_int,
        default=72,
        metavar="N",
        help="elements along the grip (default 72)",
    )
    _add_history_options(pin, "each alpha = gamma")
    _add_output_options(pin, suppress=True)


def _calibrate(args: argparse.Namespace) -> int:
    bar = None

    def progress(done: int, total: int) -> None:  # called on the root rank, as it measures
        nonlocal bar
        if bar is None:
            seconds = "about 3 s" if args.quick else "about 12 s"
            message = f"dd-contact calibrate: measuring this machine's rates ({seconds})"
            print(message, file=sys.stderr)
            bar = tqdm(total=total, desc="calibrate", unit="size", file=sys.stderr)
        bar.update(done - bar.n)

    rates = timing.machine_rates(
        recalibrate=not args.show, quick=args.quick, comm=args.comm, progress=progress
    )
    if bar is not None:
        bar.close()
    print(f"machine: {rates.machine}")
    for kind, points in rates.points.items():
        shown = ", ".join(f"{w / s:.3g}/s at {w:.3g}" for w, s in points)
        print(f"{kind:<19} {shown}   ({timing.RATE_KINDS[kind]})")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``dd-contact``."""
    parser = argparse.ArgumentParser(
        prog="dd-contact",
        description=_plain(__doc__),
        formatter_class=argparse.RawTextHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    verify = sub.add_parser("verify", help="run the verification cases and print a table")
    verify.add_argument("--case", action="append", help="run only this case (repeatable)")
    verify.add_argument("--json", help="write the records to this JSON file")
    verify.set_defaults(run=_verify)
    _add_flops(sub)
    calibrate = sub.add_parser(
        "calibrate", help="measure and cache this machine's rates for algorithm='auto'"
    )
    calibrate.add_argument("--quick", action="store_true", help="small sizes only (seconds)")
    calibrate.add_argument(
        "--show", action="store_true", help="print the cached rates (measure if none)"
    )
    calibrate.set_defaults(run=_calibrate)
    _add_tradeoff(sub)
    args = parser.parse_args(argv)
    args.comm = MPI.COMM_WORLD  # a command runs on every rank that mpiexec starts
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
