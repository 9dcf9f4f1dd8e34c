"""The package's layout: the library below, the paper's reproduction (dd_contact.paper) on top.

Read from the source (no import): which modules import which, and the length of every
function and module of the package.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "dd_contact"
PAPER = PACKAGE / "paper"
COMMAND = PACKAGE / "cli.py"
LIBRARY = sorted(p for p in PACKAGE.rglob("*.py") if not p.is_relative_to(PAPER) and p != COMMAND)
MAX_FUNCTION_LINES, MAX_MODULE_LINES = 80, 600


def _imported(path: Path) -> set[str]:
    """The modules ``path`` imports (``from a import b`` counts as a and a.b)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def test_the_library_never_imports_the_paper():
    assert len(LIBRARY) > 30
    for path in LIBRARY:
        paper = {n for n in _imported(path) if n.split(".")[:2] == ["dd_contact", "paper"]}
        assert not paper, f"{path.relative_to(PACKAGE)} imports {sorted(paper)}"


def test_the_paper_modules_live_only_in_paper():
    for name in ("flops", "verify", "models"):  # a __pycache__ left behind is no module
        assert not list((PACKAGE / name).rglob("*.py")), name
        assert (PAPER / name / "__init__.py").exists(), name
    for name in ("compare.py", "examples.py"):
        assert not (PACKAGE / name).exists() and (PAPER / name).exists(), name


@pytest.mark.parametrize(
    "path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: p.relative_to(PACKAGE).as_posix()
)
def test_functions_and_modules_are_short(path):
    text = path.read_text()
    assert len(text.splitlines()) <= MAX_MODULE_LINES
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            lines = node.end_lineno - node.lineno + 1
            assert lines <= MAX_FUNCTION_LINES, f"{node.name}: {lines} lines"
