"""The package's floors: no module imports a module of a higher floor.

The floors are declared once, in the table of docs/architecture.md; this test reads that
table and every import of the package (ast, any depth: function-level imports count).
"""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "dd_contact"
TABLE_ROW = re.compile(r"^\|\s*(\d+)\s*\|[^|]*\|([^|]*)\|")


def floors_table(text: str) -> dict[str, int]:
    """``pattern -> floor`` from the table rows ``| floor | name | `module` ... |``."""
    floors = {}
    for line in text.splitlines():
        match = TABLE_ROW.match(line)
        if match:
            for pattern in re.findall(r"`([\w.*]+)`", match.group(2)):
                floors[pattern] = int(match.group(1))
    return floors


def module_names() -> dict[str, Path]:
    """Every module of the package, dotted, without the ``dd_contact.`` prefix."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts) or "__init__"] = path
    return out


def floor_of(module: str, floors: dict[str, int]) -> int | None:
    """The floor of ``module``: its own row, else the nearest ``package.*`` row above it."""
    if module in floors:
        return floors[module]
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        star = ".".join(parts[:n]) + ".*"
        if star in floors:
            return floors[star]
    return None


def _short(name: str) -> str:
    return "__init__" if name == "dd_contact" else name.removeprefix("dd_contact.")


def imports_of(path: Path, modules: set[str]) -> set[str]:
    """The package's modules that the file at ``path`` imports.

    ``from dd_contact.x import y`` imports the module ``x.y`` if there is one, else ``x``.
    """
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {_short(a.name) for a in node.names if a.name.startswith("dd_contact")}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] != "dd_contact":
                continue
            base = _short(node.module)
            for alias in node.names:
                name = f"{node.module}.{alias.name}"
                found.add(_short(name) if _short(name) in modules else base)
    return found


def violations(floors: dict[str, int], graph: dict[str, set[str]]) -> list[str]:
    """Every import of a module from a higher floor, and every module without a floor."""
    out = []
    for module, imported in sorted(graph.items()):
        own = floor_of(module, floors)
        if own is None:
            out.append(f"{module}: no floor in docs/architecture.md")
            continue
        for target in sorted(imported):
            theirs = floor_of(target, floors)
            if theirs is not None and theirs > own:
                out.append(f"{module} (floor {own}) imports {target} (floor {theirs})")
    return out


@pytest.fixture(scope="module")
def floors():
    return floors_table((ROOT / "docs" / "architecture.md").read_text())


def test_the_table_has_every_floor(floors):
    assert sorted(set(floors.values())) == list(range(max(floors.values()) + 1))
    assert floors["errors"] == 0 and floors["cli"] == max(floors.values())
    assert floors["paper.*"] > floors["__init__"] > floors["problem"]


def test_no_module_imports_a_module_of_a_higher_floor(floors):
    modules = module_names()
    graph = {m: imports_of(p, set(modules)) - {m} for m, p in modules.items()}
    assert sum(len(v) for v in graph.values()) > 100  # the imports were found
    assert violations(floors, graph) == []


def test_an_upward_import_and_a_module_without_a_floor_are_found():
    floors = {"errors": 0, "scene": 1, "solvers.*": 2}
    graph = {
        "errors": set(),
        "scene": {"errors", "solvers.engine"},
        "solvers.engine": {"scene"},
        "stray": set(),
    }
    assert violations(floors, graph) == [
        "scene (floor 1) imports solvers.engine (floor 2)",
        "stray: no floor in docs/architecture.md",
    ]


# -- MPI in one place ------------------------------------------------------------------------
#: mpi4py's collective calls (and a few point-to-point ones) by name.
COLLECTIVES = {
    "allreduce", "allgather", "gather", "bcast", "scatter", "alltoall", "reduce_scatter",
    "Allreduce", "Allgather", "Allgatherv", "Gather", "Gatherv", "Bcast", "Scatter",
    "Scatterv", "Reduce", "Barrier", "barrier", "Alltoall", "Alltoallv", "Exscan", "Scan",
    "send", "recv", "Send", "Recv", "isend", "irecv", "Isend", "Irecv",
}  # fmt: skip


def direct_collectives(source: str) -> list[str]:
    """The calls of an mpi4py communication method on something named ``*comm*``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in COLLECTIVES
        ):
            receiver = ast.unparse(node.func.value)
            if "comm" in receiver.lower():
                found.append(f"line {node.lineno}: {receiver}.{node.func.attr}")
    return found


def test_every_collective_call_goes_through_parallel():
    calls = {
        name: direct_collectives(path.read_text())
        for name, path in module_names().items()
        if name != "parallel"
    }
    assert {name: found for name, found in calls.items() if found} == {}


def test_a_direct_collective_call_is_found():
    source = "def f(self):\n    x = self.comm.allreduce(1)\n    factor.reduce(b)\n"
    assert direct_collectives(source) == ["line 2: self.comm.allreduce"]
