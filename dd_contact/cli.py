"""The ``dd-contact`` command."""

from __future__ import annotations

import argparse
import json
import sys

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


def _verify(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from dd_contact.verify import run_cases

    records = run_cases(args.case)
    if MPI.COMM_WORLD.rank == 0:
        print(_format_records(records))
        if args.json:
            with open(args.json, "w") as f:
                json.dump(records, f, indent=2)
    failed = sum(not r["passed"] for r in records)
    if failed and MPI.COMM_WORLD.rank == 0:
        print(f"{failed} of {len(records)} checks FAILED", file=sys.stderr)
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``dd-contact``."""
    parser = argparse.ArgumentParser(prog="dd-contact", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    verify = sub.add_parser("verify", help="run the verification cases and print a table")
    verify.add_argument("--case", action="append", help="run only this case (repeatable)")
    verify.add_argument("--json", help="write the records to this JSON file")
    verify.set_defaults(run=_verify)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
